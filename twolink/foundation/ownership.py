"""Which files of a folder are twolink's, proven by their content (docs/reliability.md).

A folder is a command's only by its owner record, ``.twolink-owner.json``, which twolink
writes as the command ends: the command, its source file, and every file the command (or
an earlier one into the same folder) wrote there, each with its SHA-256. While a command
holds the folder, every file twolink writes into it is noted, with its SHA-256, in the
folder's journal (``.twolink-journal``, by the writer's process: pool workers too), and
the record is built from the journal and the previous record, keeping only the files
that still have the bytes twolink wrote. Before any work a command checks that every
file under the folder is one the record (or the journal a killed command left) lists
with its current bytes: a user's file, whatever its name, a file twolink wrote but the
user edited since, a link, a pipe, stop the command with one line and exit 2.

The lock (``.twolink.lock``) is created with an exclusive create or, if it is there, used
only if it is a regular file with one link; the lock, the journal and the record are
opened relative to the folder, opened once (``dir_fd``), so a folder swapped for a link
while the command runs cannot redirect them; the record is not written then.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from twolink.foundation.journal import (  # the names, and the journal read back
    JOURNAL_NAME,
    LOCK_NAME,
    OWN_NAMES,
    OWNER_NAME,
    RECORD_KIND,
    RECORD_VERSION,
    _is_noted,
    _is_record_temporary,
    _temporary_name,
    journal_command,
    read_journal,
)
from twolink.foundation.names import refuse_long_name
from twolink.foundation.planted import (
    HEX64,
    PlantedFile,
    open_regular,
    plain_relative,
    read_json,
    sha256_of,
    shown,
)

LOCK_TEXT = re.compile(rb"(?:[0-9]{1,20}\n)?")  # what :func:`_locked` writes in a lock


class OutputBusy(OSError):
    """Another twolink process is writing into the same output folder."""


class ForeignOutput(OSError):
    """The output folder (or a file in it) holds something twolink did not write, or a
    link: twolink refuses rather than delete, overwrite or write through it (exit 2)."""


class WriteFailed(OSError):
    """An output could not be written (disk full, no permission, file-size limit): the
    message names the file. The command line ends with exit 3 (docs/reliability.md)."""

    def __str__(self) -> str:
        return str(self.strerror)

    def __reduce__(self) -> Any:  # across a process pool, with its message and file
        return (type(self), (self.errno, self.strerror, self.filename))

    def moved_to(self, folder: Path) -> WriteFailed:
        """The same failure, naming the file by its place in ``folder`` (where it was
        going) rather than in the temporary folder it was being written in."""
        target = Path(folder) / Path(self.filename).name
        reason = str(self.strerror).rsplit(": ", 1)[-1]
        return WriteFailed(self.errno, f"cannot write {target}: {reason}", str(target))


def write_failed(path: Path, exc: OSError) -> WriteFailed:
    """``exc`` as a :class:`WriteFailed` naming ``path`` (unless it already is one)."""
    if isinstance(exc, WriteFailed | ForeignOutput):
        return exc
    reason = exc.strerror or str(exc) or type(exc).__name__
    return WriteFailed(exc.errno, f"cannot write {path}: {reason}", str(path))


def show_names(names: set[str] | list[str]) -> str:
    """Up to three of ``names`` (escaped) for a one-line message, and how many more."""
    names = sorted(names)
    shown_ = [shown(n, 80) for n in names[:3]]
    return ", ".join(shown_) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


# ----------------------------------------------------------------------------- records


def read_record(folder: Path, dir_fd: int | None = None) -> dict[str, Any] | None:
    """The folder's owner record if twolink could have written it (its kind, version,
    command, source and files of the right types; names plain paths inside the folder;
    digests SHA-256), None where there is none; :class:`PlantedFile` for any other."""
    where = OWNER_NAME if dir_fd is not None else folder / OWNER_NAME
    try:
        record = read_json(where, dir_fd=dir_fd)
    except FileNotFoundError:
        return None
    files = record.get("files")
    ok = (
        record.get("kind") == RECORD_KIND
        and record.get("version") == RECORD_VERSION
        and isinstance(record.get("command"), str)
        and isinstance(record.get("source"), str | None)
        and isinstance(files, dict)
        and all(
            plain_relative(k) and isinstance(v, str) and HEX64.match(v) for k, v in files.items()
        )
    )
    if not ok:
        raise PlantedFile(errno.EINVAL, f"{folder / OWNER_NAME}: not an owner record twolink wrote")
    return record


# --------------------------------------------------------------------------- the journal

# Folders this process holds: {absolute path: (folder fd, journal fd)}.
_HELD: dict[Path, tuple[int, int]] = {}
_HELD_LOCK = threading.Lock()


def _owner_of(path: Path) -> tuple[Path, int | None] | None:
    """The nearest folder above ``path`` that a twolink command holds (its journal is
    there, and its lock is held: by this process, or by a running one such as the
    command whose pool worker this is), and this process's journal descriptor for it if
    it holds it. A killed command's journal is not appended to."""
    for p in path.parents:
        held = _HELD.get(p)
        if held is not None:
            return p, held[1]
        if (
            os.path.isfile(p / LOCK_NAME)
            and os.path.lexists(p / JOURNAL_NAME)
            and live_holder(p) is not None
        ):
            return p, None
    return None


def _journal_line(line: str, owner: Path, fd: int | None) -> None:
    data = line.encode()
    if fd is not None:
        os.write(fd, data)
        return
    jfd = os.open(owner / JOURNAL_NAME, os.O_WRONLY | os.O_APPEND | os.O_NOFOLLOW | os.O_NONBLOCK)
    try:
        st = os.fstat(jfd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            raise ForeignOutput(f"{owner / JOURNAL_NAME}: not the journal twolink made")
        os.write(jfd, data)
    finally:
        os.close(jfd)


def refuse_swapped(path: str | os.PathLike) -> None:
    """Raise :class:`ForeignOutput` if a folder above ``path`` that this process holds is
    no longer the folder it opened (swapped for a link or another folder meanwhile):
    nothing is written through it."""
    path = Path(os.path.abspath(path))
    for p in (path, *path.parents):
        held = _HELD.get(p)
        if held is not None and not _same_folder(p, held[0]):
            raise ForeignOutput(
                f"{p}: was replaced (by a link or another folder) while twolink wrote into it; "
                "nothing more is written there"
            )


def held_by_a_command(path: str | os.PathLike) -> bool:
    """Whether a twolink command holds ``path`` or a folder above it (it checked, as it
    began, that every file under it is twolink's): this process, or another whose lock
    is held (a killed command's lock and journal are not)."""
    found = _owner_of(Path(os.path.abspath(path)) / "x")
    if found is None:
        return False
    owner, fd = found
    return fd is not None or live_holder(owner) is not None


def live_holder(folder: Path) -> str | None:
    """The pid (as its lock says it) of the running process that holds ``folder``'s lock,
    None where none does (no lock, or the lock of a command that ended or was killed: the
    kernel released it)."""
    import fcntl

    try:
        lfd = os.open(folder / LOCK_NAME, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return None
    try:
        fcntl.flock(lfd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:  # its holder runs
        return shown(os.pread(lfd, 32, 0).decode("ascii", "replace").strip() or "?", 32)
    except OSError:
        return None
    finally:
        os.close(lfd)  # releases a lock taken here
    return None


def note_written(path: str | os.PathLike) -> None:
    """Note in the journal of the folder that holds ``path`` (if a command holds one) that
    twolink wrote ``path``, with its SHA-256: the owner record will list it."""
    path = Path(os.path.abspath(path))
    found = _owner_of(path)
    if found is None:
        return
    owner, fd = found
    rel = path.relative_to(owner).as_posix()
    if not plain_relative(rel):
        return  # inside a temporary folder: noted when it is moved out
    try:
        jfd, st = open_regular(path)
        os.close(jfd)
        digest = sha256_of(path)
        _journal_line(f"{digest} {st.st_size} {st.st_mtime_ns} {st.st_ino} {rel}\n", owner, fd)
    except OSError as exc:
        raise write_failed(path, exc) from None


def note_temporary(path: str | os.PathLike) -> None:
    """Note a temporary made inside a held folder: a command killed before it removes
    it leaves it listed, and the next command into the folder removes it."""
    path = Path(os.path.abspath(path))
    found = _owner_of(path)
    if found is None:
        return
    owner, fd = found
    rel = path.relative_to(owner).as_posix()
    if _temporary_name(rel):
        try:
            st = os.stat(path, follow_symlinks=False)
            kind = "dir" if stat.S_ISDIR(st.st_mode) else "file"
            _journal_line(f"tmp {kind} {st.st_ino} {rel}\n", owner, fd)
        except OSError as exc:
            raise write_failed(path, exc) from None


# ----------------------------------------------------------------------------- checking


def _claims(
    folder: Path,
) -> tuple[dict[str, str], dict[str, tuple[str, int]], dict[str, Any] | None]:
    """What twolink wrote in ``folder`` by its own account: {name: sha256} from the owner
    record and a journal a killed command left, the temporaries listed, and the record."""
    record = read_record(folder)
    files = dict(record["files"]) if record else {}
    journal, temporaries = read_journal(folder)
    files.update({name: entry[0] for name, entry in journal.items()})
    return files, temporaries, record


def foreign_entries(
    folder: Path, inherited: dict[str, str] | None = None
) -> tuple[list[str], dict[str, Any] | None, list[Path]]:
    """The entries under ``folder`` that twolink cannot prove it wrote (not listed by the
    folder's record or journal with their current SHA-256: a user's file, an edited one,
    a link, a pipe), the folder's record, and the temporaries it may remove. A folder
    below with its own record or journal is judged by those (and by what the record above
    lists inside it: ``inherited``)."""
    try:
        claims, temporaries, record = _claims(folder)
    except PlantedFile as exc:
        which = Path(exc.filename).name if exc.filename else f"{OWNER_NAME} or {JOURNAL_NAME}"
        why = (exc.strerror or "").removeprefix(f"{exc.filename}: ")
        return [f"{which} ({why})"], None, []
    claims = {**(inherited or {}), **claims}
    foreign: list[str] = []
    removable: list[Path] = []

    def walk(sub: Path, prefix: str) -> None:
        with os.scandir(sub) as it:
            entries = sorted(it, key=lambda e: e.name)
        for entry in entries:
            name = prefix + entry.name
            if not prefix and entry.name in OWN_NAMES:
                continue
            if entry.name == LOCK_NAME and _is_lock(entry):  # a sub-folder's, left there
                continue
            if name in temporaries and _is_noted(entry, temporaries[name]):
                removable.append(Path(entry.path))
                continue
            if not prefix and _is_record_temporary(sub, entry):
                removable.append(Path(entry.path))
                continue
            if entry.is_symlink():
                foreign.append(name + " (a link)")
            elif entry.is_dir(follow_symlinks=False):
                if any(os.path.lexists(os.path.join(entry.path, n)) for n in OWN_NAMES[1:]):
                    below = {
                        k[len(name) + 1 :]: v for k, v in claims.items() if k.startswith(name + "/")
                    }
                    inner, _, more = foreign_entries(Path(entry.path), below)
                    foreign.extend(f"{name}/{n}" for n in inner)
                    removable.extend(more)
                else:
                    walk(Path(entry.path), name + "/")
            elif not entry.is_file(follow_symlinks=False):
                foreign.append(name + " (not a regular file)")
            elif name not in claims:
                foreign.append(name)
            else:
                try:
                    same = sha256_of(entry.path) == claims[name]
                except OSError:
                    same = False
                if not same:
                    foreign.append(name + " (changed since twolink wrote it)")
            if len(foreign) > 100:
                return

    walk(folder, "")
    return foreign, record, removable


def _is_lock(entry: os.DirEntry) -> bool:
    """Whether ``entry`` is a lock as twolink leaves one (:func:`_locked`): a regular file
    with one link, empty (a command stopped by a full disk before it wrote its pid) or
    holding a pid and a line break. A sub-folder a stopped command held keeps it; the
    kernel released the lock itself (``flock``), so a rerun takes it again."""
    try:
        fd, st = open_regular(entry.path)
        try:
            data = os.read(fd, 33) if st.st_nlink == 1 else None
        finally:
            os.close(fd)
    except OSError:
        return False
    return data is not None and bool(LOCK_TEXT.fullmatch(data))


def check_ownership(
    path: str | os.PathLike,
    command: str,
    source: str | None = None,
    default: bool = False,
    option: str = "--out",
) -> list[Path]:
    """Refuse (:class:`ForeignOutput`) an output folder that ``twolink COMMAND`` may not
    write into; read-only, so it runs before any work. Returns the temporaries a killed
    command left there (listed by its journal), for the command to remove once it holds
    the folder.

    The rule (docs/reliability.md): twolink writes into a folder that does not exist, is
    empty (a lock alone counts as empty), or whose owner record, written by the same
    command, lists every file in it with its current SHA-256. With ``default`` (the
    command picked the folder, not the user) one written for another ``source`` is
    refused too."""
    path = Path(path)
    refuse_long_name(path, option, "folder")
    if path.is_symlink():
        raise ForeignOutput(
            f"{option} {path}: is a symbolic link"
            + (" to nothing" if not path.exists() else f"; give its folder ({path.resolve()})")
        )
    if not path.exists():
        return []
    if not path.is_dir():
        raise NotADirectoryError(f"{option} {path}: is not a folder")
    foreign, record, removable = foreign_entries(path)
    if foreign:
        raise ForeignOutput(
            f"{option} {path}: holds files twolink did not write ({show_names(foreign)}); "
            "twolink writes only into a new or empty folder or one whose owner record lists "
            f"every file in it: move them away or choose another {option}"
        )
    held_by = journal_command(path)
    if held_by is not None and held_by != command and (pid := live_holder(path)) is not None:
        raise OutputBusy(
            f"{option} {path}: `twolink {shown(held_by, 40)}` (pid {pid}) is writing into this "
            f"folder; `twolink {command}` would mix with it: wait for it to finish or choose "
            f"another {option}"
        )
    if held_by is not None and held_by != command:
        raise ForeignOutput(
            f"{option} {path}: holds what `twolink {shown(held_by, 40)}` wrote before it was "
            f"stopped; `twolink {command}` would mix with it: rerun `twolink "
            f"{shown(held_by, 40)}` there to finish it, or choose another {option}"
        )
    if record is None:
        return removable
    if record["command"] != command:
        src = f" ({shown(record['source'])})" if record.get("source") else ""
        raise ForeignOutput(
            f"{option} {path}: holds the results of `twolink {shown(record['command'], 40)}`"
            f"{src}; `twolink {command}` would mix with them: choose another {option}"
        )
    if default and source is not None and record.get("source") not in (None, source):
        raise ForeignOutput(
            f"{option} {path}: holds the results of {shown(record['source'])}, not of "
            f"{source} (same default folder); give this run its own {option}"
        )
    return removable


# ----------------------------------------------------------------------------- holding


def _open_folder(path: Path, option: str) -> int:
    try:
        return os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENOTDIR) and path.is_symlink():
            raise ForeignOutput(f"{option} {path}: is a symbolic link") from None
        raise


def _open_lock(dfd: int, path: Path, option: str) -> int:
    """The lock file's descriptor: created exclusively, or, where it is there, only a
    regular file with one link (never a link, a pipe, a folder, a hard link elsewhere)."""
    flags = os.O_RDWR | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        return os.open(LOCK_NAME, flags | os.O_CREAT | os.O_EXCL, 0o644, dir_fd=dfd)
    except FileExistsError:
        pass
    try:
        fd = os.open(LOCK_NAME, flags, dir_fd=dfd)
    except OSError as exc:
        what = {errno.ELOOP: "a symbolic link", errno.EISDIR: "a folder"}.get(
            exc.errno, "not a regular file"
        )
        raise ForeignOutput(
            f"{option} {path}: {LOCK_NAME} is {what}; twolink never writes through one (remove it)"
        ) from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
        os.close(fd)
        what = "not a regular file" if not stat.S_ISREG(st.st_mode) else "a hard link"
        raise ForeignOutput(
            f"{option} {path}: {LOCK_NAME} is {what} (another name shares its bytes); "
            "twolink never writes into one (remove it)"
        )
    return fd


@contextmanager
def output_lock(path: str | os.PathLike, option: str = "--out") -> Iterator[Path]:
    """Hold the output folder ``path`` (created if need be) for this process.

    A second command into the same folder stops at once with :class:`OutputBusy`, naming
    the process that holds it. The lock is ``fcntl.flock`` on ``path/.twolink.lock``: the
    kernel drops it when the holder ends, even killed, so a stale lock never blocks a
    rerun. See :func:`_open_lock` for what is never used as the lock."""
    with _locked(Path(path), option) as (held, _dfd):
        yield held


@contextmanager
def _locked(path: Path, option: str) -> Iterator[tuple[Path, int]]:
    import fcntl

    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_failed(path, exc) from None
    dfd = _open_folder(path, option)
    try:
        fd = _open_lock(dfd, path, option)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = shown(os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?", 32)
                raise OutputBusy(
                    f"{option} {path}: another twolink (pid {holder}) is writing into this "
                    "folder; wait for it to finish or use another --out"
                ) from None
            try:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            except OSError as exc:
                raise write_failed(path / LOCK_NAME, exc) from None
            yield path, dfd
        finally:
            os.close(fd)  # releases the lock
    finally:
        os.close(dfd)


def _same_folder(path: Path, dfd: int) -> bool:
    try:
        st = os.stat(path, follow_symlinks=False)
    except OSError:
        return False
    here = os.fstat(dfd)
    return stat.S_ISDIR(st.st_mode) and (st.st_dev, st.st_ino) == (here.st_dev, here.st_ino)


@contextmanager
def owned_output(
    path: str | os.PathLike,
    command: str,
    source: str | None = None,
    default: bool = False,
    option: str = "--out",
) -> Iterator[Path]:
    """Check (:func:`check_ownership`), lock (:func:`output_lock`) and journal the output
    folder of ``twolink COMMAND`` for the command's life; as it ends, write the owner
    record: the files the journal and the previous record list that still have the
    bytes twolink wrote. Nothing is recorded for a command that wrote nothing into a
    folder that had no record (a refusal), nor into a folder swapped while it ran."""
    path = Path(os.path.abspath(path))
    check_ownership(path, command, source, default, option)
    existed = path.exists()
    with _locked(path, option) as (_, dfd):
        removable = check_ownership(path, command, source, default, option)  # again, held
        claims, _, record = _claims(path)
        for tmp in removable:  # a killed command's temporaries: its journal lists them
            _remove(tmp)
        try:
            os.unlink(JOURNAL_NAME, dir_fd=dfd)
        except FileNotFoundError:
            pass
        try:
            jfd = os.open(
                JOURNAL_NAME,
                os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW,
                0o644,
                dir_fd=dfd,
            )
        except OSError as exc:
            raise write_failed(path / JOURNAL_NAME, exc) from None
        # the files twolink wrote before stay listed (checked above: same bytes)
        try:
            # first, which command writes here: a killed command's folder is its own
            os.write(jfd, f"command {command}\n".encode())
            for name, digest in claims.items():
                try:
                    st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
                except FileNotFoundError:
                    continue
                line = f"{digest} {st.st_size} {st.st_mtime_ns} {st.st_ino} {name}\n"
                os.write(jfd, line.encode())
        except OSError as exc:
            os.close(jfd)
            raise write_failed(path / JOURNAL_NAME, exc) from None
        with _HELD_LOCK:
            _HELD[path] = (dfd, jfd)
        ok = False
        try:
            yield path
            ok = True
        finally:
            with _HELD_LOCK:
                _HELD.pop(path, None)
            os.close(jfd)
            _finish(path, dfd, command, source, record is not None, existed, ok)


def _remove(tmp: Path) -> None:
    import shutil

    if tmp.is_symlink() or not tmp.is_dir():
        tmp.unlink(missing_ok=True)
    else:
        shutil.rmtree(tmp, ignore_errors=True)


def _finish(
    path: Path, dfd: int, command: str, source: str | None, had: bool, existed: bool, ok: bool
) -> None:
    """Write the owner record from the journal (see :func:`owned_output`)."""
    if not _same_folder(path, dfd):
        if ok:
            raise ForeignOutput(
                f"{path}: was replaced (by a link or another folder) while twolink wrote into "
                "it; no owner record written: check what was written where"
            )
        return
    try:
        journal, _ = read_journal(path, dfd)
    except OSError:
        journal = {}
    files = {}
    for name, (digest, size, mtime, ino) in journal.items():
        try:
            st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
            if not stat.S_ISREG(st.st_mode):
                continue
            if (st.st_size, st.st_mtime_ns, st.st_ino) == (size, mtime, ino) or (
                sha256_of(name, dfd) == digest
            ):
                files[name] = digest
        except OSError:
            continue
    try:
        if not files and not had:  # nothing written (a refusal): leave no trace
            os.unlink(JOURNAL_NAME, dir_fd=dfd)
            if not existed:
                os.unlink(LOCK_NAME, dir_fd=dfd)
                try:
                    os.rmdir(path)
                except OSError:
                    pass  # it holds an empty folder the command made
            return
        record = {
            "kind": RECORD_KIND,
            "version": RECORD_VERSION,
            "command": command,
            "source": source,
            "files": dict(sorted(files.items())),
        }
        _write_record(dfd, record, path)
        os.unlink(JOURNAL_NAME, dir_fd=dfd)
    except OSError:
        if ok:
            raise
        # the command's own error (a full disk) is the one to report; the journal stays


# Owner records this process is writing: (folder fd, temporary's name). A pool worker
# stopped by SIGTERM, or whose command is gone, removes them with its other temporaries
# (io.discard_pending): a worker stopped inside _write_record (a flexible study's folder,
# 4.5 s into `reproduce`) left '..twolink-owner.json.PID.tmp', and the rerun refused it.
_RECORDS: set[tuple[int, str]] = set()
_RECORDS_LOCK = threading.RLock()  # re-entrant: the worker's SIGTERM handler runs here too


def discard_pending_records() -> None:
    """Remove the temporaries of the owner records this process is writing."""
    with _RECORDS_LOCK:
        for dfd, tmp in list(_RECORDS):
            try:
                os.unlink(tmp, dir_fd=dfd)
            except OSError:
                pass
            _RECORDS.discard((dfd, tmp))


def _write_record(dfd: int, record: dict[str, Any], path: Path) -> None:
    import json

    data = (json.dumps(record, indent=1) + "\n").encode()
    tmp = f".{OWNER_NAME}.{os.getpid()}.tmp"
    with _RECORDS_LOCK:  # known before it exists: removed however the process ends
        _RECORDS.add((dfd, tmp))
    try:
        _write_record_via(dfd, tmp, data, path)
    finally:
        with _RECORDS_LOCK:
            _RECORDS.discard((dfd, tmp))


def _write_record_via(dfd: int, tmp: str, data: bytes, path: Path) -> None:
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644, dir_fd=dfd)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, OWNER_NAME, src_dir_fd=dfd, dst_dir_fd=dfd)
    except BaseException as exc:  # SIGTERM arrives as KeyboardInterrupt: no temporary left
        try:
            os.unlink(tmp, dir_fd=dfd)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise write_failed(path / OWNER_NAME, exc) from None
        raise
