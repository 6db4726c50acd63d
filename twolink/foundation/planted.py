"""One bounded reader for every file twolink reads back from a folder someone else can
write into: owner records, journals, seals, manifests, marks, locks (docs/reliability.md).

A file read back is read only if it is a regular file (not a pipe, a device, a folder),
opened without following a link (``O_NOFOLLOW``, and ``O_NONBLOCK`` so that opening a
pipe never waits), no larger than a cap, and, for JSON, nested no deeper than a cap. Any
other file is :class:`PlantedFile`, an ``OSError`` and a ``ValueError`` at once, so that
the callers that treat an unreadable record or seal as "not twolink's" or "damaged"
catch it as they catch the others. Strings from such files are shown escaped
(:func:`shown`): a planted record cannot clear the screen or forge a line.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import stat
from pathlib import Path
from typing import Any

import numpy as np

# Caps of what a file read back may hold: far above anything twolink writes (an owner
# record of a full reproduction is ~200 kB), far below what hurts a laptop.
MAX_RECORD_BYTES = 16 << 20
MAX_DEPTH = 64


class PlantedFile(OSError, ValueError):
    """A file twolink reads back is not one it could have written: not a regular file, a
    link, too large, nested too deep, or not of the expected shape."""


def _flags() -> int:
    return os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)


def open_regular(path: str | os.PathLike, dir_fd: int | None = None) -> tuple[int, os.stat_result]:
    """An open descriptor of the regular file ``path`` (never a link, a pipe, a device,
    a folder) and its ``fstat``; :class:`PlantedFile` otherwise. The caller closes it."""
    try:
        fd = os.open(path, _flags(), dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.EMLINK):
            raise PlantedFile(exc.errno, f"{path}: is a symbolic link", str(path)) from None
        if exc.errno in (errno.ENXIO, errno.ENODEV, errno.EISDIR):
            raise PlantedFile(exc.errno, f"{path}: is not a regular file", str(path)) from None
        raise
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise PlantedFile(
            errno.EINVAL, f"{path}: is not a regular file (a pipe, a device, a folder)", str(path)
        )
    return fd, st


def read_bounded(
    path: str | os.PathLike, limit: int = MAX_RECORD_BYTES, dir_fd: int | None = None
) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them (a larger file is
    :class:`PlantedFile`)."""
    fd, st = open_regular(path, dir_fd)
    try:
        if st.st_size > limit:
            raise PlantedFile(errno.EFBIG, f"{path}: larger than {limit} bytes", str(path))
        chunks, total = [], 0
        while True:
            block = os.read(fd, min(1 << 20, limit + 1 - total))
            if not block:
                break
            chunks.append(block)
            total += len(block)
            if total > limit:  # it grew while read
                raise PlantedFile(errno.EFBIG, f"{path}: larger than {limit} bytes", str(path))
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_head(path: str | os.PathLike, size: int, dir_fd: int | None = None) -> bytes:
    """The first ``size`` bytes (or fewer) of the regular file ``path``, whatever its
    length: what a file's first line says, read without reading the file."""
    fd, _ = open_regular(path, dir_fd)
    try:
        return os.read(fd, size)
    finally:
        os.close(fd)


_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKET = re.compile(rb"[^\[\]{}]")


def nesting_depth(data: bytes) -> int:
    """How deep the JSON (or TOML arrays) text ``data`` nests brackets, strings skipped."""
    brackets = _NOT_BRACKET.sub(b"", _STRING.sub(b"", data))
    if not brackets:
        return 0
    steps = np.frombuffer(brackets, dtype=np.uint8)
    opening = (steps == ord("[")) | (steps == ord("{"))
    return int(np.cumsum(np.where(opening, 1, -1)).max())


def read_json(
    path: str | os.PathLike,
    limit: int = MAX_RECORD_BYTES,
    depth: int = MAX_DEPTH,
    dir_fd: int | None = None,
    kind: type = dict,
) -> Any:
    """The JSON document in ``path``, read with :func:`read_bounded`, nested at most
    ``depth`` deep and of type ``kind``; :class:`PlantedFile` otherwise."""
    data = read_bounded(path, limit, dir_fd)
    if nesting_depth(data) > depth:
        raise PlantedFile(errno.EINVAL, f"{path}: nested deeper than {depth}", str(path))
    try:
        value = json.loads(data)
    except (ValueError, RecursionError) as exc:
        raise PlantedFile(errno.EINVAL, f"{path}: not JSON ({exc})", str(path)) from None
    if not isinstance(value, kind):
        raise PlantedFile(
            errno.EINVAL,
            f"{path}: holds a {type(value).__name__}, not a {kind.__name__}",
            str(path),
        )
    return value


def sha256_of(path: str | os.PathLike, dir_fd: int | None = None) -> str:
    """The SHA-256 of the regular file ``path`` (never through a link, never a pipe)."""
    fd, _ = open_regular(path, dir_fd)
    h = hashlib.sha256()
    try:
        while block := os.read(fd, 1 << 20):
            h.update(block)
    finally:
        os.close(fd)
    return h.hexdigest()


PLAIN_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,200}$")
HEX64 = re.compile(r"^[0-9a-f]{64}$")


def plain_relative(name: Any) -> bool:
    """Whether ``name`` (from a record or a seal) is a path inside its folder: plain parts
    joined by "/", none empty, ".", ".." or starting with "."."""
    if not isinstance(name, str) or not name or len(name) > 1000:
        return False
    return all(PLAIN_NAME.match(part) for part in name.split("/"))


def shown(text: Any, limit: int = 200) -> str:
    """``text`` (a string from a file) safe to print on one line: control characters and
    terminal escapes escaped, at most ``limit`` characters."""
    text = str(text)
    out = "".join(
        ch if ch.isprintable() and ch not in "\x1b\x9b" else ch.encode("unicode_escape").decode()
        for ch in text[:limit]
    )
    return out + ("..." if len(text) > limit else "")


def is_under(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or inside it (both absolute, not resolved)."""
    try:
        path.relative_to(folder)
    except ValueError:
        return False
    return True
