"""What a command wrote into the clone: a snapshot of its files (size and modification
time) before and after, without the folders a run of Python or git itself touches."""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# Python's and the tools' own caches, the venvs, git, and the build's metadata (written by
# `python -m build` before any twolink command runs)
SKIP = {".git", ".venv", "venv", "__pycache__", ".pytest_cache", ".ruff_cache", "twolink.egg-info"}


def clone_files(root: Path = REPO) -> dict[str, tuple[int, int]]:
    """Every file of the clone (relative path -> (size, mtime_ns)), caches left out."""
    out = {}
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if d not in SKIP]
        for name in names:
            path = Path(folder, name)
            st = path.lstat()
            out[path.relative_to(root).as_posix()] = (st.st_size, st.st_mtime_ns)
    return out


def written(before: dict[str, tuple[int, int]], root: Path = REPO) -> list[str]:
    """The files added or changed in the clone since ``before``."""
    after = clone_files(root)
    return sorted(p for p, stamp in after.items() if before.get(p) != stamp)
