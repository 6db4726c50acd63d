"""File output: atomic writes (temporary file beside the target, then rename) and TOML.

A crash or Ctrl-C mid-write leaves either the old file or none, never half a file. The
standard library reads TOML (tomllib) but does not write it; the small writer here is
shared by the resolved run configs and the rule-base files.
"""

from __future__ import annotations

import hashlib
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


def check_output_file(
    path: str | os.PathLike, option: str = "--out", ours_only: bool = True
) -> Path:
    """Make sure the file ``path`` can be written, before any work starts and without
    creating anything: it is not a folder, and its folder can become one (see
    :func:`check_output_folder`); if it exists, it is a regular file that twolink wrote
    (it carries :data:`WRITTEN_BY`). Errors name the option and ``path``."""
    path = Path(path)
    if path.is_symlink():
        raise ForeignOutput(f"{option} {path}: is a symbolic link; give the file itself")
    if path.is_dir():
        raise IsADirectoryError(f"{option} {path}: is a folder, not a file")
    if path.exists():
        if not path.is_file():
            raise ForeignOutput(f"{option} {path}: is not a regular file (a pipe, a device)")
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        if ours_only and WRITTEN_BY not in head:
            raise ForeignOutput(
                f"{option} {path}: exists and twolink did not write it; "
                f"twolink never overwrites such a file: choose another {option}"
            )
    _check_writable(path.parent, path, option)
    return path


# Files twolink writes to a path the user names (rule bases, figures) carry this mark (a
# TOML comment, a PNG text chunk), so that only they are ever overwritten.
WRITTEN_BY = b"written by twolink"


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
OWNER_NAME = ".twolink-owner.json"  # which command owns the folder, and what it wrote there
# Temporaries twolink leaves beside a target while it writes (".NAME.xxxx.tmp", ".NAME.xxxx.old").
TEMPORARY = re.compile(r"^\..+\.(tmp|old)$")


class OutputBusy(OSError):
    """Another twolink process is writing into the same output folder."""


class WriteFailed(OSError):
    """An output could not be written (disk full, no permission, file-size limit): the
    message names the file. The command line ends with exit 3 (docs/reliability.md)."""

    def __str__(self) -> str:
        return str(self.strerror)

    def moved_to(self, folder: Path) -> WriteFailed:
        """The same failure, naming the file by its place in ``folder`` (where it was
        going) rather than in the temporary folder it was being written in."""
        target = Path(folder) / Path(self.filename).name
        reason = str(self.strerror).rsplit(": ", 1)[-1]
        return WriteFailed(self.errno, f"cannot write {target}: {reason}", str(target))


def _write_failed(path: Path, exc: OSError) -> WriteFailed:
    if isinstance(exc, WriteFailed | ForeignOutput):
        return exc
    reason = exc.strerror or str(exc) or type(exc).__name__
    return WriteFailed(exc.errno, f"cannot write {path}: {reason}", str(path))


class ForeignOutput(OSError):
    """The output folder (or a file in it) holds something twolink did not write, or a
    link: twolink refuses rather than delete, overwrite or write through it (exit 2)."""


def refuse_links(path: str | os.PathLike) -> None:
    """Raise :class:`ForeignOutput` if ``path`` or a folder above it, up to the output
    folder that holds it (the nearest real folder with twolink's lock file), is a
    symbolic link: nothing is written through a link planted inside an output folder.
    Outside an output folder only ``path`` itself is checked."""
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
    """What a folder holds, less twolink's own lock, owner record and temporaries."""
    return {
        name
        for name in os.listdir(path)
        if name not in (LOCK_NAME, OWNER_NAME) and not TEMPORARY.match(name)
    }


def _read_owner(path: Path) -> dict[str, Any] | None:
    try:
        owner = json.loads((path / OWNER_NAME).read_text())
    except (OSError, ValueError):
        return None
    return owner if isinstance(owner, dict) else None


def show_names(names: set[str]) -> str:
    """Up to three of ``names`` for a one-line message, and how many more."""
    shown = sorted(names)[:3]
    return ", ".join(shown) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def check_ownership(
    path: str | os.PathLike,
    command: str,
    source: str | None = None,
    default: bool = False,
    option: str = "--out",
    known: frozenset[str] = frozenset(),
) -> None:
    """Refuse (:class:`ForeignOutput`) an output folder that ``twolink COMMAND`` may not
    write into; read-only, so it can run before any work.

    The rule (docs/reliability.md): twolink writes into a folder that does not exist, is
    empty, or was written by the same command before and holds nothing else. A folder
    with anything twolink did not write is refused, naming what is there; so is another
    command's folder (a sweep's, a reproduction's), and with ``default`` (the command
    picked the folder, not the user) one written for another ``source`` file. A folder
    with no owner record that holds only names in ``known`` (the command's own outputs,
    written by a twolink from before owner records) is taken as the command's.
    """
    path = Path(path)
    if path.is_symlink():
        raise ForeignOutput(
            f"{option} {path}: is a symbolic link"
            + (" to nothing" if not path.exists() else f"; give its folder ({path.resolve()})")
        )
    if not path.exists():
        return
    if not path.is_dir():
        raise NotADirectoryError(f"{option} {path}: is not a folder")
    owner = _read_owner(path)
    entries = folder_entries(path)
    if owner is None:
        if entries and not (path / LOCK_NAME).is_file() and not entries <= known:
            raise ForeignOutput(
                f"{option} {path}: holds files twolink did not write ({show_names(entries)}); "
                "twolink writes only into a new or empty folder or one it wrote before: "
                f"choose another {option}"
            )
        return  # empty, or written by a twolink from before owner records (it has the lock)
    if owner.get("command") != command:
        raise ForeignOutput(
            f"{option} {path}: holds the results of `twolink {owner.get('command')}`"
            + (f" ({owner['source']})" if owner.get("source") else "")
            + f"; `twolink {command}` would mix with them: choose another {option}"
        )
    if default and source is not None and owner.get("source") not in (None, source):
        raise ForeignOutput(
            f"{option} {path}: holds the results of {owner['source']}, not of {source} "
            f"(same default folder); give this run its own {option}"
        )
    foreign = entries - set(owner.get("entries", ()))
    if foreign:
        raise ForeignOutput(
            f"{option} {path}: holds files twolink did not write ({show_names(foreign)}); "
            f"move them away or choose another {option}"
        )


@contextmanager
def owned_output(
    path: str | os.PathLike,
    command: str,
    source: str | None = None,
    default: bool = False,
    option: str = "--out",
    known: frozenset[str] = frozenset(),
) -> Iterator[Path]:
    """Check (:func:`check_ownership`), lock (:func:`output_lock`) and record the output
    folder of ``twolink COMMAND`` for the command's life.

    The folder's owner record (``.twolink-owner.json``) names the command, its source
    file and every top-level entry twolink wrote there, so that a later command can tell
    twolink's files from a user's."""
    path = Path(path)
    check_ownership(path, command, source, default, option, known)
    refuse_links(path / LOCK_NAME)
    with output_lock(path, option) as held:
        check_ownership(path, command, source, default, option, known)  # again, now held
        record = {"command": command, "source": source}
        owner = _read_owner(path) or {}
        try:
            yield held
        finally:
            entries = set(owner.get("entries", ())) | folder_entries(path)
            try:
                atomic_write_json(path / OWNER_NAME, {**record, "entries": sorted(entries)})
            except OSError:
                pass  # the command's own write error (disk full) is the one to report


@contextmanager
def output_lock(path: str | os.PathLike, option: str = "--out") -> Iterator[Path]:
    """Hold the output folder ``path`` (created if need be) for this process.

    A second reproduction or sweep into the same folder stops at once with
    :class:`OutputBusy`, naming the process that holds it, instead of mixing its files
    with the first's. The lock is ``fcntl.flock`` on ``path/.twolink.lock``: the kernel
    drops it when the holder ends, even killed, so a stale lock never blocks a rerun.
    The lock file is never opened through a link (``O_NOFOLLOW``).
    """
    import fcntl

    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    lock = path / LOCK_NAME
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    except OSError:
        if lock.is_symlink():
            raise ForeignOutput(
                f"{option} {path}: {LOCK_NAME} is a symbolic link; twolink never writes "
                "through one (remove it)"
            ) from None
        raise
    fh = os.fdopen(fd, "r+")
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "?"
            raise OutputBusy(
                f"{option} {path}: another twolink (pid {holder}) is writing into this folder; "
                "wait for it to finish or use another --out"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        yield path
    finally:
        fh.close()  # releases the lock


def append_line(path: str | os.PathLike, line: str) -> None:
    """Append ``line`` to a log file, never through a link."""
    refuse_links(path)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "a") as fh:
            fh.write(line if line.endswith("\n") else line + "\n")
    except OSError as exc:
        raise _write_failed(Path(path), exc) from None


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
        return Path(tmp)

    with _pending(path, make, lambda tmp: tmp.unlink(missing_ok=True)) as tmp_path:
        try:
            _usual_permissions(tmp_path, 0o666)
            yield tmp_path
            os.replace(tmp_path, path)
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
    """Remove this process's temporary files and folders that are still being written."""
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
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_seal(folder: str | os.PathLike, names: Iterator[str] | list[str]) -> None:
    """Seal ``folder``'s files ``names``: their SHA-256 in ``seal.json``, written last, so a
    file cut short, damaged or edited afterwards is found (:func:`seal_intact`)."""
    folder = Path(folder)
    atomic_write_json(folder / SEAL_NAME, {n: _sha256(folder / n) for n in sorted(names)})


def seal_intact(folder: str | os.PathLike, needed: tuple[str, ...] = ()) -> bool:
    """Whether ``folder``'s seal is readable, covers ``needed``, and every file it names
    still has the bytes it was sealed with."""
    folder = Path(folder)
    try:
        seal = json.loads((folder / SEAL_NAME).read_text())
        if not isinstance(seal, dict) or not set(needed) <= set(seal):
            return False
        return all(
            not (folder / n).is_symlink() and _sha256(folder / n) == digest
            for n, digest in seal.items()
        )
    except (OSError, ValueError):
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
    refuse_links(folder / SEAL_NAME)
    (folder / SEAL_NAME).unlink(missing_ok=True)
    for name in names:
        refuse_links(folder / name)
        try:
            if (new / name).exists():
                os.replace(new / name, folder / name)
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
        return Path(tempfile.mkdtemp(prefix=f".{beside.name}.", suffix=".tmp", dir=beside.parent))

    with _pending(beside, make, lambda tmp: shutil.rmtree(tmp, ignore_errors=True)) as tmp:
        _usual_permissions(tmp, 0o777)
        yield tmp
