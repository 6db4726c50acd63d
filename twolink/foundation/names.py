"""Names that become file or folder names: the one rule for names taken from files
(:func:`unsafe_name_problem`) and the file system's length limits for any path twolink
is given (:func:`long_name_problem`), checked before any work (docs/reliability.md)."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

# Names from files that become folder or file names (sweep, controller and variant names):
# one rule, so that none can reach outside the output folder ("../x", "/etc", "a/b").
SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")

# Where the system does not say (no pathconf): Linux's and macOS's usual limits.
NAME_MAX = 255
PATH_MAX = 4096


# What an output adds to a name the user gives: a temporary beside it, ".NAME." then
# tempfile's 8 characters, the name's own suffix again for the writers that keep one
# (io.atomic_path's: ".png", ".parquet"), then ".tmp" (io.atomic_path, io.scratch_folder).
TEMPORARY_ROOM = len("..") + 8 + len(".tmp")
# What an output folder's own files add to its path: its owner record's temporary
# (".twolink-owner.json.PID.tmp"), a sweep's chunks and their temporaries. A name as long as
# a file system takes, and its separator, leaves room for all of them.
FOLDER_ROOM = NAME_MAX + 1


class NameTooLong(OSError):
    """A path with a name (or as a whole) longer than the file system takes."""


def unsafe_name_problem(name: Any) -> str | None:
    """Why ``name`` cannot be a folder name inside an output folder, or None if it can.
    (At most 100 ASCII bytes: with twolink's suffixes, far inside any name limit.)"""
    if not isinstance(name, str) or not SAFE_NAME.match(name) or len(name) > 100:
        return (
            f"must be 1-100 letters, digits, '_', '-' or '.', not starting with '.' or '-' "
            f"(it names a folder inside --out), got {name!r}"
        )
    return None


def _limits(path: Path) -> tuple[int, int]:
    """The longest name and path (bytes) of the file system of the nearest existing
    folder at or above ``path``."""
    for folder in (path, *path.parents):
        try:
            if folder.is_dir():
                return os.pathconf(folder, "PC_NAME_MAX"), os.pathconf(folder, "PC_PATH_MAX")
        except (OSError, ValueError, AttributeError):  # too long itself; no pathconf
            continue
    return NAME_MAX, PATH_MAX


def long_name_problem(path: str | os.PathLike, output: str = "") -> str | None:
    """Why ``path`` can be no file's path: a name in it longer than its file system takes
    (``PC_NAME_MAX``, 255 bytes on most), or the whole path longer than the system's
    limit (``PC_PATH_MAX``); None if neither. Each name is counted in bytes, as the
    file system counts it (a non-ASCII letter is 2-4).

    ``output``: "file" or "folder" where twolink will write ``path``: its last name must
    leave room for the temporary written beside it (:data:`TEMPORARY_ROOM` and its
    suffix), and a folder's whole path for the files twolink writes in it
    (:data:`FOLDER_ROOM`), so a name that passes never fails after the work."""
    whole = Path(os.path.abspath(path))
    name_max, path_max = _limits(whole)
    parts = Path(path).parts
    for k, part in enumerate(parts):
        size = len(os.fsencode(part))
        room = TEMPORARY_ROOM + len(os.fsencode(Path(part).suffix)) if output else 0
        last = output and k == len(parts) - 1
        if size > name_max or (last and size + room > name_max):
            shown = part if len(part) <= 24 else part[:24] + "..."
            if size > name_max or not last:
                return (
                    f"the name {shown!r} is {size} bytes, longer than the file system takes "
                    f"(at most {name_max} bytes a name)"
                )
            return (
                f"the name {shown!r} is {size} bytes, and {size + room} with the temporary "
                f"twolink writes beside it: longer than the file system takes (at most "
                f"{name_max} bytes a name; {name_max - room} for this one)"
            )
    size = len(os.fsencode(str(whole)))
    if size >= path_max:
        return f"the path is {size} bytes, longer than the system takes (under {path_max})"
    room = (
        FOLDER_ROOM if output == "folder" else TEMPORARY_ROOM + len(whole.suffix) if output else 0
    )
    if size + room >= path_max:
        inside = "the files twolink writes in it" if output == "folder" else "its temporary"
        return (
            f"the path is {size} bytes: with {inside} ({room} bytes more), longer than the "
            f"system takes (under {path_max}; at most {path_max - room - 1} bytes for this path)"
        )
    return None


def refuse_long_name(path: str | os.PathLike, what: str = "", output: str = "") -> None:
    """:class:`NameTooLong`, one line starting with ``what`` (an option, a key), where
    :func:`long_name_problem` finds one in ``path`` (``output``: as a file or folder
    twolink writes)."""
    if problem := long_name_problem(path, output):
        raise NameTooLong(f"{what}: {problem}" if what else problem)
