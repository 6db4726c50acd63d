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
import threading
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

from twolink.foundation.interrupts import interrupts_held
from twolink.foundation.names import SAFE_NAME, NameTooLong, refuse_long_name, unsafe_name_problem


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
    refuse_long_name(path, option, "folder")
    _check_writable(path, path, option)
    return path


def check_output_file(
    path: str | os.PathLike, option: str = "--out", ours_only: bool = True
) -> Path:
    """Make sure the file ``path`` can be written, before any work starts and without
    creating anything: it is not a folder, and its folder can become one (see
    :func:`check_output_folder`); if it exists, it is a regular file that twolink wrote
    (it carries twolink's exact header: :func:`carries_mark`). Errors name the option and
    ``path``."""
    path = Path(path)
    refuse_long_name(path, option, "file")
    if path.is_symlink():
        raise ForeignOutput(f"{option} {path}: is a symbolic link; give the file itself")
    if path.is_dir():
        raise IsADirectoryError(f"{option} {path}: is a folder, not a file")
    if os.path.lexists(path):
        try:
            fd, st = open_regular(path)
            os.close(fd)
        except PlantedFile:
            raise ForeignOutput(
                f"{option} {path}: is not a regular file (a pipe, a device)"
            ) from None
        if st.st_nlink > 1:
            raise ForeignOutput(
                f"{option} {path}: has another name (a hard link); twolink does not replace it"
            )
        if ours_only and not carries_mark(path):
            raise ForeignOutput(
                f"{option} {path}: exists and twolink did not write it; "
                f"twolink never overwrites such a file: choose another {option}"
            )
    _check_writable(path.parent, path, option)
    return path


# Files twolink writes to a path the user names carry an exact header: a TOML file's first
# line is MARK_LINE (a rule base's: its title, then MARK_LINE); a PNG has the text chunk
# Software = "written by twolink". A mention of the words anywhere else is no mark.
WRITTEN_BY = "written by twolink"
MARK_LINE = b"# " + WRITTEN_BY.encode()
RULE_BASE_TITLE = (
    b"# Fuzzy rule base for controllers.fuzzy (read with controllers.fuzzy.load_rule_base)."
)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_text(data: bytes) -> dict[str, str]:
    """The tEXt chunks of a PNG's bytes (before its image data), {key: text}."""
    import struct

    out: dict[str, str] = {}
    at = len(PNG_SIGNATURE)
    while at + 8 <= len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind = data[at + 4 : at + 8]
        body = data[at + 8 : at + 8 + length]
        if kind in (b"IDAT", b"IEND") or len(body) < length:
            break
        if kind == b"tEXt" and b"\0" in body:
            key, text = body.split(b"\0", 1)
            out.setdefault(key.decode("latin-1"), text.decode("latin-1"))
        at += 12 + length
    return out


def carries_mark(path: str | os.PathLike) -> bool:
    """Whether the regular file ``path`` carries twolink's exact header (see above)."""
    from twolink.foundation.planted import read_bounded

    try:
        head = read_bounded(path, 64 << 20)[: 1 << 20]
    except OSError:
        return False
    if head.startswith(PNG_SIGNATURE):
        return png_text(head).get("Software") == WRITTEN_BY
    lines = head.split(b"\n", 2)
    first = lines[0].rstrip(b"\r")
    second = lines[1].rstrip(b"\r") if len(lines) > 1 else b""
    return first == MARK_LINE or (first == RULE_BASE_TITLE and second == MARK_LINE)


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


from twolink.foundation.journal import TEMPORARY  # noqa: E402
from twolink.foundation.ownership import (  # noqa: E402  (one home; the old names import)
    JOURNAL_NAME,
    LOCK_NAME,
    OWNER_NAME,
    ForeignOutput,
    OutputBusy,
    WriteFailed,
    check_ownership,
    discard_pending_records,
    held_by_a_command,
    note_temporary,
    note_written,
    output_lock,
    owned_output,
    refuse_swapped,
    show_names,
)
from twolink.foundation.ownership import write_failed as _write_failed  # noqa: E402
from twolink.foundation.planted import (  # noqa: E402
    HEX64,
    PlantedFile,
    open_regular,
    plain_relative,
    read_json,
    sha256_of,
)

__all__ = [
    "JOURNAL_NAME",
    "LOCK_NAME",
    "OWNER_NAME",
    "TEMPORARY",
    "ForeignOutput",
    "OutputBusy",
    "NameTooLong",
    "PlantedFile",
    "SAFE_NAME",
    "WriteFailed",
    "check_ownership",
    "held_by_a_command",
    "sha256_of",
    "output_lock",
    "owned_output",
    "show_names",
    "unsafe_name_problem",
]


def refuse_links(path: str | os.PathLike) -> None:
    """Raise :class:`ForeignOutput` if ``path`` or a folder above it, up to the output
    folder that holds it (the nearest real folder with twolink's lock file), is a
    symbolic link: nothing is written through a link planted inside an output folder.
    Outside an output folder only ``path`` itself is checked."""
    refuse_swapped(path)
    path = Path(os.path.abspath(path))
    below = [path]
    for p in path.parents:
        if (p / LOCK_NAME).is_file() and not p.is_symlink():
            break
        below.append(p)
    else:
        below = [path]
    for p in below:
        if p.is_symlink():
            raise ForeignOutput(
                f"{p}: is a symbolic link inside the output folder; twolink never writes "
                "through one (remove it, or use another --out)"
            )


def folder_entries(path: Path) -> set[str]:
    """What a folder holds, less twolink's lock, owner record, journal and temporaries."""
    return {
        name
        for name in os.listdir(path)
        if name not in (LOCK_NAME, OWNER_NAME, JOURNAL_NAME) and not TEMPORARY.match(name)
    }


def append_line(path: str | os.PathLike, line: str) -> None:
    """Append ``line`` to a log file, never through a link nor into a file with another
    name (a hard link), a pipe or a device."""
    import stat

    refuse_links(path)
    try:
        fd = os.open(
            path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o644
        )
    except OSError as exc:
        raise _write_failed(Path(path), exc) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            what = "a hard link" if stat.S_ISREG(st.st_mode) else "not a regular file"
            raise ForeignOutput(f"{path}: is {what}; twolink does not append to it")
        data = (line if line.endswith("\n") else line + "\n").encode()
        while data:
            data = data[os.write(fd, data) :]
    except OSError as exc:
        raise _write_failed(Path(path), exc) from None
    finally:
        os.close(fd)
    note_written(path)


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    ``suffix`` keeps an extension on the temporary file for writers that pick the
    format from the name (matplotlib's ``savefig``).
    """
    path = Path(path)
    refuse_links(path)
    if path.exists() and not path.is_file():
        raise ForeignOutput(f"{path}: is not a regular file; twolink does not replace it")

    def make() -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix + ".tmp", dir=path.parent)
        os.close(fd)
        note_temporary(tmp)
        return Path(tmp)

    with _pending(path, make, lambda tmp: tmp.unlink(missing_ok=True)) as tmp_path:
        try:
            _usual_permissions(tmp_path, 0o666)
            yield tmp_path
            os.replace(tmp_path, path)
            note_written(path)
        except OSError as exc:
            raise _write_failed(path, exc) from None


def _usual_permissions(path: Path, mode: int) -> None:
    # mkstemp and mkdtemp make private (0600, 0700) temporaries; outputs get the usual mode.
    umask = os.umask(0)
    os.umask(umask)
    path.chmod(mode & ~umask)


# Temporaries being written in this process: a pool worker stopped by SIGTERM removes
# them before it exits (``discard_pending``), so an interrupted command leaves none.
_PENDING: set[Path] = set()
# Held while a temporary is made and registered, or removed and forgotten, so that
# discard_pending (a worker's SIGTERM handler, or its thread that watches the command)
# never runs between the two and misses one.
_PENDING_LOCK = threading.RLock()


@contextmanager
def _pending(
    target: Path, make: Callable[[], Path], remove: Callable[[Path], Any]
) -> Iterator[Path]:
    """A temporary made by ``make`` for ``target``, known to :func:`discard_pending` for
    as long as it exists: Ctrl-C and SIGTERM wait while it is made and while it is removed."""
    tmp: Path | None = None
    try:
        # A signal held here is handled as the block ends, once the temporary is known.
        with interrupts_held(), _PENDING_LOCK:
            try:
                tmp = make()
            except OSError as exc:
                raise _write_failed(target, exc) from None
            _PENDING.add(tmp)
        yield tmp
    finally:
        if tmp is not None:
            with interrupts_held(), _PENDING_LOCK:
                remove(tmp)
                _PENDING.discard(tmp)


def discard_pending() -> None:
    """Remove this process's temporary files and folders that are still being written
    (owner records' included)."""
    discard_pending_records()
    with _PENDING_LOCK:
        for tmp in list(_PENDING):
            if tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                tmp.unlink(missing_ok=True)
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


# --------------------------------------------------------------------------- sealed folders

SEAL_NAME = "seal.json"


def _sha256(path: Path) -> str:
    return sha256_of(path)


def write_seal(folder: str | os.PathLike, names: Iterator[str] | list[str]) -> None:
    """Seal ``folder``'s files ``names``: their SHA-256 in ``seal.json``, written last, so a
    file cut short, damaged or edited afterwards is found (:func:`seal_intact`). A seal
    finds damage, not a deliberate forgery: whoever edits a file can write its seal too."""
    folder = Path(folder)
    atomic_write_json(folder / SEAL_NAME, {n: _sha256(folder / n) for n in sorted(names)})


def read_seal(folder: str | os.PathLike) -> dict[str, str] | None:
    """``folder``'s seal if it is one twolink could have written (a regular file, bounded,
    {plain name inside the folder: SHA-256}), else None."""
    try:
        seal = read_json(Path(folder) / SEAL_NAME)
    except OSError:
        return None
    ok = all(
        plain_relative(n) and "/" not in n and isinstance(d, str) and HEX64.match(d)
        for n, d in seal.items()
    )
    return seal if ok else None


def seal_intact(folder: str | os.PathLike, needed: tuple[str, ...] = ()) -> bool:
    """Whether ``folder``'s seal is readable, covers ``needed``, and every file it names
    (a plain name in the folder, a regular file, never through a link) still has the
    bytes it was sealed with."""
    folder = Path(folder)
    seal = read_seal(folder)
    if seal is None or not set(needed) <= set(seal):
        return False
    try:
        return all(_sha256(folder / n) == digest for n, digest in seal.items())
    except OSError:
        return False


def replace_files(
    folder: str | os.PathLike, new: str | os.PathLike, names: tuple[str, ...]
) -> None:
    """Move the files ``names`` of the finished temporary folder ``new`` into ``folder``,
    each by one rename; a name of ``names`` that ``new`` lacks is removed from ``folder``
    (a stale plot of an earlier run). Only those names are touched: anything else in
    ``folder`` stays. The seal goes first and is written again by the caller, so a stop
    half-way leaves a folder that reads as unsealed, never as whole."""
    folder, new = Path(folder), Path(new)
    for name in (SEAL_NAME, *names):
        refuse_links(folder / name)
        if (folder / name).is_dir():
            raise ForeignOutput(f"{folder / name}: is a folder; twolink does not replace it")
    (folder / SEAL_NAME).unlink(missing_ok=True)
    for name in names:
        try:
            if (new / name).exists():
                os.replace(new / name, folder / name)
                note_written(folder / name)
            else:
                (folder / name).unlink(missing_ok=True)
        except OSError as exc:
            raise _write_failed(folder / name, exc) from None


@contextmanager
def scratch_folder(beside: str | os.PathLike) -> Iterator[Path]:
    """A temporary folder beside ``beside`` (same file system: renames out of it are
    atomic), removed afterwards, and by a stopped worker (:func:`discard_pending`)."""
    beside = Path(beside)
    refuse_links(beside)

    def make() -> Path:
        beside.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.mkdtemp(prefix=f".{beside.name}.", suffix=".tmp", dir=beside.parent)
        note_temporary(tmp)
        return Path(tmp)

    with _pending(beside, make, lambda tmp: shutil.rmtree(tmp, ignore_errors=True)) as tmp:
        _usual_permissions(tmp, 0o777)
        yield tmp
