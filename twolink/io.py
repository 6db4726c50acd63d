"""File output: atomic writes (temporary file beside the target, then rename) and TOML.

A crash or Ctrl-C mid-write leaves either the old file or none, never half a file. The
standard library reads TOML (tomllib) but does not write it; the small writer here is
shared by the resolved run configs and the rule-base files.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

# Names from files that become folder or file names (sweep, controller and variant names):
# one rule, so that none can reach outside the output folder ("../x", "/etc", "a/b").
SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")


def unsafe_name_problem(name: Any) -> str | None:
    """Why ``name`` cannot be a folder name inside an output folder, or None if it can."""
    if not isinstance(name, str) or not SAFE_NAME.match(name) or len(name) > 100:
        return (
            f"must be 1-100 letters, digits, '_', '-' or '.', not starting with '.' or '-' "
            f"(it names a folder inside --out), got {name!r}"
        )
    return None


def check_output_folder(path: str | os.PathLike, option: str = "--out") -> Path:
    """Make sure ``path`` can become the output folder, before any work starts and
    without creating it: the folder, or its nearest existing parent, is a folder that a
    probe file can be written to (and removed from).

    Raises
    ------
    OSError
        With a message that names the option and the folder: under a file, read-only,
        no permission.
    """
    path = Path(path)
    _check_writable(path, path, option)
    return path


def check_output_file(path: str | os.PathLike, option: str = "--out") -> Path:
    """Make sure the file ``path`` can be written, before any work starts and without
    creating anything: it is not a folder, and its folder can become one (see
    :func:`check_output_folder`). Errors name the option and ``path``."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{option} {path}: is a folder, not a file")
    _check_writable(path.parent, path, option)
    return path


def _check_writable(folder: Path, shown: Path, option: str) -> None:
    existing = next(p for p in (folder, *folder.parents) if p.exists() or p == Path(p.anchor))
    if not existing.is_dir():
        where = "is a file" if existing == shown else f"is under {existing}, which is a file"
        raise NotADirectoryError(f"{option} {shown}: {where}, not a folder")
    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise OSError(
            f"{option} {shown}: cannot write in {existing} ({exc.strerror or exc})"
        ) from None


LOCK_NAME = ".twolink.lock"


class OutputBusy(OSError):
    """Another twolink process is writing into the same output folder."""


@contextmanager
def output_lock(path: str | os.PathLike) -> Iterator[Path]:
    """Hold the output folder ``path`` (created if need be) for this process.

    A second reproduction or sweep into the same folder stops at once with
    :class:`OutputBusy`, naming the process that holds it, instead of mixing its files
    with the first's. The lock is ``fcntl.flock`` on ``path/.twolink.lock``: the kernel
    drops it when the holder ends, even killed, so a stale lock never blocks a rerun.
    """
    import fcntl

    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    fh = open(path / LOCK_NAME, "a+")  # noqa: SIM115 (held open for the lock's life)
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "?"
            raise OutputBusy(
                f"--out {path}: another twolink (pid {holder}) is writing into this folder; "
                "wait for it to finish or use another --out"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        yield path
    finally:
        fh.close()  # releases the lock


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    ``suffix`` keeps an extension on the temporary file for writers that pick the
    format from the name (matplotlib's ``savefig``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix + ".tmp", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    _PENDING.add(tmp_path)
    _usual_permissions(tmp_path, 0o666)
    try:
        yield tmp_path
        os.replace(tmp_path, path)
    finally:
        tmp_path.unlink(missing_ok=True)
        _PENDING.discard(tmp_path)


def _usual_permissions(path: Path, mode: int) -> None:
    # mkstemp and mkdtemp make private (0600, 0700) temporaries; outputs get the usual mode.
    umask = os.umask(0)
    os.umask(umask)
    path.chmod(mode & ~umask)


# Temporaries being written in this process: a pool worker stopped by SIGTERM removes
# them before it exits (``discard_pending``), so an interrupted command leaves none.
_PENDING: set[Path] = set()


def discard_pending() -> None:
    """Remove this process's temporary files and folders that are still being written."""
    for tmp in list(_PENDING):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            tmp.unlink(missing_ok=True)
        _PENDING.discard(tmp)


@contextmanager
def atomic_folder(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a fresh temporary folder beside ``path``; on success it replaces ``path`` as a
    whole, so no file of an earlier result stays beside the new ones, and two writers
    into one folder cannot mix (the last to finish wins whole).

    On failure the temporary folder is removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    _PENDING.add(tmp)
    _usual_permissions(tmp, 0o777)
    try:
        yield tmp
        old = None
        if path.exists():  # move the old result aside first: rename cannot replace a folder
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
            os.replace(path, old / path.name)
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        _PENDING.discard(tmp)


def _write_with(path: str | os.PathLike, mode: str, write: Callable[[IO], Any]) -> None:
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        write(fh)
        fh.flush()
        os.fsync(fh.fileno())


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    _write_with(path, "w", lambda fh: fh.write(text))


def atomic_write_json(path: str | os.PathLike, obj: Any) -> None:
    """Write ``obj`` as indented JSON (NaN written as null) atomically."""
    atomic_write_text(path, json.dumps(_nan_to_none(obj), indent=2, sort_keys=False) + "\n")


def _nan_to_none(obj: Any) -> Any:
    # JSON has no NaN; null is what other tools read back.
    if isinstance(obj, float) and obj != obj:
        return None
    if isinstance(obj, dict):
        return {k: _nan_to_none(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_nan_to_none(v) for v in obj]
    return obj


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_key(key: Any) -> str:
    """A TOML key: bare when it can be, quoted otherwise."""
    if not isinstance(key, str):
        raise TypeError(f"TOML keys must be strings, got {key!r}")
    return key if _BARE_KEY.match(key) else toml_string(key)


def toml_string(text: str) -> str:
    """A TOML basic string: escape quote, backslash and control characters; UTF-8 otherwise."""
    out = []
    for ch in text:
        if ch in ('"', "\\"):
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_value(value: Any) -> str:
    """A TOML value (numbers, strings, booleans, lists, inline tables; numpy values too)."""
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, Mapping):
        items = ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items())
        return "{" + items + "}" if items else "{}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} value {value!r} to TOML")


def toml_table(lines: list[str], name: str, table: Mapping[str, Any]) -> None:
    """Append ``[name]`` with its values, then its sub-tables, to ``lines``."""
    lines.append(f"[{name}]")
    subtables = []
    for key, value in table.items():
        if isinstance(value, Mapping):
            subtables.append((key, value))
        else:
            lines.append(f"{toml_key(key)} = {toml_value(value)}")
    lines.append("")
    for key, value in subtables:
        toml_table(lines, f"{name}.{toml_key(key)}", value)


def to_toml(data: Mapping[str, Any]) -> str:
    """A TOML document: top-level values first, then one ``[table]`` per nested mapping."""
    lines = [
        f"{toml_key(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, Mapping)
    ]
    lines.append("")
    for key, value in data.items():
        if isinstance(value, Mapping):
            toml_table(lines, toml_key(key), value)
    return "\n".join(lines)
