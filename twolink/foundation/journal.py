"""A held folder's journal, read back: the files and temporaries twolink noted there, and
the command that holds (or, killed, held) the folder (docs/reliability.md). Its writing is
:mod:`twolink.foundation.ownership`'s, which judges a folder by it."""

from __future__ import annotations

import os
import re
from pathlib import Path

from twolink.foundation.planted import (
    HEX64,
    MAX_RECORD_BYTES,
    open_regular,
    plain_relative,
    read_bounded,
    read_head,
)

__all__ = ["journal_command", "read_journal"]

LOCK_NAME = ".twolink.lock"
OWNER_NAME = ".twolink-owner.json"  # which command owns the folder, and what it wrote there
JOURNAL_NAME = ".twolink-journal"  # what the command holding the folder wrote so far
OWN_NAMES = (LOCK_NAME, OWNER_NAME, JOURNAL_NAME)
# The names twolink's writers make exactly: io.atomic_path's and io.scratch_folder's
# (tempfile's 8 random characters between ".NAME." and an optional suffix, ".tmp" last),
# and the owner record's own (".<record>.PID.tmp", :func:`_write_record`). A journal's
# temporary is removed only if its name is one of these, and the entry there is the very
# file or folder twolink made (its kind and inode, noted as it was made).
GENERATED = re.compile(r"^\..+\.[a-z0-9_]{8}(\.[A-Za-z0-9_-]+)?\.tmp$")
RECORD_TEMPORARY = re.compile(r"^\." + re.escape(OWNER_NAME) + r"\.[0-9]+\.tmp$")
# Any temporary twolink makes, by its name alone (what a folder holds less these:
# io.folder_entries); a user's ".notes.tmp" or ".mydata.old" is none of them.
TEMPORARY = re.compile(f"(?:{GENERATED.pattern})|(?:{RECORD_TEMPORARY.pattern})")
RECORD_KIND = "twolink owner record"
RECORD_VERSION = 2
# A journal lists what an owner record lists (and the temporaries): the record's bound.
# A larger one is no journal twolink wrote, refused by its size before a byte is read.
MAX_JOURNAL_BYTES = MAX_RECORD_BYTES
# The last journals parsed, by (device, inode, size, mtime): a command reads its folder's
# journal several times as it checks and takes the folder, and parses it once.
_PARSED: dict[tuple[int, int, int, int], tuple[dict, dict]] = {}


def read_journal(
    folder: Path, dir_fd: int | None = None
) -> tuple[dict[str, tuple], dict[str, tuple[str, int]]]:
    """What a journal lists: {name: (sha256, size, mtime_ns, inode)} of the files written,
    later lines winning, and the temporaries made as {name: (kind, inode)} (kind "file"
    or "dir"). Lines that are not twolink's are skipped (a bare ``tmp NAME`` too: it
    does not say what twolink made); a journal that is not a regular file is
    :class:`PlantedFile`. The command that holds the folder: :func:`journal_command`."""
    return _read_journal(folder, dir_fd)


def journal_command(folder: Path, dir_fd: int | None = None) -> str | None:
    """The command a journal says holds (or held, if it was killed) the folder, None
    where it names none (no journal, or one of an older twolink): its first line, read
    alone."""
    where = JOURNAL_NAME if dir_fd is not None else folder / JOURNAL_NAME
    try:
        head = read_head(where, 256, dir_fd)
    except FileNotFoundError:
        return None
    first = head.split(b"\n", 1)
    parts = first[0].decode("utf-8", "replace").split(" ", 4) if len(first) == 2 else []
    return parts[1] if len(parts) == 2 and parts[0] == "command" else None


def _read_journal(folder: Path, dir_fd: int | None) -> tuple[dict, dict]:
    where = JOURNAL_NAME if dir_fd is not None else folder / JOURNAL_NAME
    try:
        st = os.stat(where, dir_fd=dir_fd, follow_symlinks=False)
    except FileNotFoundError:
        return {}, {}
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    if key in _PARSED:
        files, temporaries = _PARSED[key]
        return dict(files), dict(temporaries)
    try:
        data = read_bounded(where, MAX_JOURNAL_BYTES, dir_fd)
    except FileNotFoundError:
        return {}, {}
    files, temporaries = _parse(data)
    if len(_PARSED) >= 4:
        _PARSED.pop(next(iter(_PARSED)))
    _PARSED[key] = (files, temporaries)
    return dict(files), dict(temporaries)


def _parse(data: bytes) -> tuple[dict[str, tuple], dict[str, tuple[str, int]]]:
    files: dict[str, tuple] = {}
    temporaries: dict[str, tuple[str, int]] = {}
    for line in data.decode("utf-8", "replace").splitlines():
        parts = line.split(" ", 4)
        if len(parts) == 4 and parts[0] == "tmp" and parts[1] in ("file", "dir"):
            if _temporary_name(parts[3]) and parts[2].isdigit():
                temporaries[parts[3]] = (parts[1], int(parts[2]))
        elif len(parts) == 5 and HEX64.match(parts[0]) and plain_relative(parts[4]):
            try:
                files[parts[4]] = (parts[0], int(parts[1]), int(parts[2]), int(parts[3]))
            except ValueError:
                continue
    return files, temporaries


def _temporary_name(name: str) -> bool:
    *above, last = name.split("/")
    return bool(GENERATED.match(last)) and (not above or plain_relative("/".join(above)))


def _is_noted(entry: os.DirEntry, noted: tuple[str, int]) -> bool:
    """Whether ``entry`` is the temporary the journal noted: the same kind (never a
    link) and the same inode."""
    kind, inode = noted
    if entry.is_symlink():
        return False
    is_kind = (
        entry.is_dir(follow_symlinks=False)
        if kind == "dir"
        else entry.is_file(follow_symlinks=False)
    )
    try:
        return is_kind and entry.inode() == inode
    except OSError:
        return False


def _is_record_temporary(folder: Path, entry: os.DirEntry) -> bool:
    """Whether ``entry`` is an owner record's temporary a killed command left
    (:func:`_write_record`): its exact name, a regular file with one link, holding a
    beginning of an owner record as twolink writes it (empty if killed before a byte)."""
    if not RECORD_TEMPORARY.match(entry.name):
        return False
    head = b'{\n "kind": "' + RECORD_KIND.encode() + b'"'
    try:
        fd, st = open_regular(folder / entry.name)
        try:
            data = os.read(fd, len(head)) if st.st_nlink == 1 else None
        finally:
            os.close(fd)
    except OSError:
        return False
    return data is not None and head.startswith(data[: len(head)])
