"""A table of the user's own plants (a CSV file or a DataFrame) read as a sweep's
``listed`` parameters: one row per plant, one column per sweep parameter (the names of
:data:`twolink.sweep.parameters.PARAMETERS`), every value checked against its
parameter's domain, so ``twolink compare --plants-file`` (docs/compare.md) judges the two
controllers on exactly those plants and ``twolink sweep compare.toml`` reruns them.

Every error is one line naming the file (and the row and column of a bad value); a file
over :data:`MAX_PLANTS_BYTES` is refused by its size, before a byte is read."""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.planted import read_bounded
from twolink.simulation.config import MAX_TOML_BYTES, ConfigError
from twolink.sweep.parameters import PARAMETERS, domain_problem

__all__ = ["MAX_PLANTS_BYTES", "listed_parameters", "plants_source", "read_plants"]

# The plants become the values of a sweep file (compare.toml), which holds at most
# MAX_TOML_BYTES: a larger table could not be rerun. About 10,000 plants of 6 columns.
MAX_PLANTS_BYTES = MAX_TOML_BYTES
DATAFRAME = "plants (a DataFrame)"  # what errors name where the plants are no file


def plants_source(plants: str | Path | pd.DataFrame) -> str:
    """The name an error gives the plants: the file, or "plants (a DataFrame)"."""
    return DATAFRAME if isinstance(plants, pd.DataFrame) else str(plants)


def read_plants(plants: str | Path | pd.DataFrame) -> pd.DataFrame:
    """The user's plants as a table of floats: one row per plant in the file's order, one
    column per parameter in the file's order.

    Parameters
    ----------
    plants : str, Path or DataFrame
        A CSV file (UTF-8; a header line of parameter names, then one line per plant;
        from ``#`` to the end of a line is a comment; blank lines are skipped) or a
        DataFrame of the same columns (its index is ignored).

    Raises
    ------
    ConfigError
        One line naming the file: no such file, larger than :data:`MAX_PLANTS_BYTES`,
        empty, not a CSV table, an unknown, repeated or conflicting column, no rows, more
        rows than a sweep holds, a value that is empty, not a number, not finite or
        outside its parameter's domain (naming its row, counted from 1 under the header,
        and its column).
    """
    from twolink.sweep.plan import parameter_conflict, too_many_samples

    source = plants_source(plants)
    if isinstance(plants, pd.DataFrame):
        names, rows = [str(c) for c in plants.columns], plants.to_numpy(dtype=object).tolist()
        if not all(isinstance(c, str) for c in plants.columns):
            raise ConfigError(f"{source}: column names must be parameter names, got {names}")
    else:
        names, rows = _csv_cells(Path(plants), source)
    if not names:
        raise ConfigError(f"{source}: no columns: a plants table has one per sweep parameter")
    _check_names(names, source)
    if conflict := parameter_conflict(names):
        raise ConfigError(f"{source}: column {conflict[0]!r} {conflict[1]}")
    if not rows:
        raise ConfigError(f"{source}: no plants: a header of parameter names and no row under it")
    if problem := too_many_samples(len(rows)):
        raise ConfigError(f"{source}: {len(rows):,} rows: {problem}")
    values = {name: [_value(row[c], k + 1, name, source) for k, row in enumerate(rows)]
              for c, name in enumerate(names)}  # fmt: skip
    return pd.DataFrame(values, columns=names, dtype=float)


def listed_parameters(table: pd.DataFrame) -> dict[str, dict[str, Any]]:
    """A sweep file's ``[parameters]`` for the plants of ``table`` (from
    :func:`read_plants`): each column a ``listed`` parameter, sample i its row i."""
    return {
        str(name): {"dist": "listed", "values": [float(v) for v in table[name]]}
        for name in table.columns
    }


def _csv_cells(path: Path, source: str) -> tuple[list[str], list[list[Any]]]:
    """The header's names and the rows' cells (text) of the CSV file ``path``."""
    try:
        raw = read_bounded(path.resolve(), MAX_PLANTS_BYTES)
    except RuntimeError:  # Path.resolve on a loop of links (an OSError from Python 3.13)
        raise ConfigError(f"{source}: a loop of symbolic links, no file") from None
    except FileNotFoundError:
        raise ConfigError(f"{source}: no such file (a CSV of plants)") from None
    except OSError as exc:  # too large (by its size, unread), a folder, a pipe, a device
        problem = (exc.strerror or str(exc)).removeprefix(f"{path.resolve()}: ")
        if problem.startswith("larger than"):
            problem = (
                f"larger than {MAX_PLANTS_BYTES:,} bytes, the most a plants file may hold "
                "(its values become a sweep file, compare.toml): split it into several files"
            )
        raise ConfigError(f"{source}: {problem}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{source}: not a UTF-8 text file (a CSV of plants): {exc}") from None
    try:
        cells = pd.read_csv(
            io.StringIO(text), header=None, dtype=str, keep_default_na=False, na_filter=False,
            skipinitialspace=True, comment="#",
        )  # fmt: skip
    except pd.errors.EmptyDataError:
        raise ConfigError(
            f"{source}: empty file: a header of parameter names, then one row per plant"
        ) from None
    except (pd.errors.ParserError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ConfigError(f"{source}: not a CSV table of plants: {first}") from None
    table = cells.to_numpy(dtype=object).tolist()
    return [str(n).strip() for n in table[0]], table[1:]


def _check_names(names: list[str], source: str) -> None:
    known = ", ".join(PARAMETERS)
    for k, name in enumerate(names):
        if name not in PARAMETERS:
            hint = (
                " (an index written by DataFrame.to_csv? write it with index=False)"
                if name in ("", "Unnamed: 0") and k == 0
                else ""
            )
            raise ConfigError(
                f"{source}: unknown column {name!r}{hint}; the columns are sweep parameters: "
                f"{known} (docs/sweeps.md)"
            )
        if name in names[:k]:
            raise ConfigError(f"{source}: column {name!r} given twice")


def _value(cell: Any, row: int, name: str, source: str) -> float:
    """The number of one cell, checked against its parameter's domain."""
    where = f"{source}: row {row} under the header, column {name!r}"
    if isinstance(cell, str):
        text = cell.strip()
        if not text:
            raise ConfigError(f"{where}: empty; every plant needs a value in every column")
        value = None if "_" in text else _float(text)  # float() reads "1_0" as 10
        shown = text[:40]
    else:  # a DataFrame's cell: a number (numpy's too), never a bool or None
        value = None if isinstance(cell, bool | np.bool_) or cell is None else _float(cell)
        shown = cell
    if value is None:
        raise ConfigError(f"{where}: not a number: {shown!r}")
    if not math.isfinite(value):
        raise ConfigError(f"{where}: must be finite, got {value!r}")
    if problem := domain_problem(name, PARAMETERS[name], value):
        raise ConfigError(f"{where}: {problem}")
    return value


def _float(x: Any) -> float | None:
    try:
        return float(x)
    except (TypeError, ValueError, OverflowError):
        return None
