"""The files twolink ships: scenarios, sweeps and studies (the repository's ``runs/``),
the MJCF models (``models/``) and the rule bases (``controllers/rulebases/``).

They are package data (``pyproject.toml`` maps ``runs/`` to ``twolink.runs`` and
``models/`` to ``twolink.models``, as ``controllers/`` is ``twolink.controllers``), found
through :mod:`importlib.resources`, never through the source tree: twolink reads the same
files installed from a wheel as from its clone.

A shipped file is named by its path under the shipped runs without the extension
(``paper/theta1_step``, ``sweeps/robustness``); a local file always wins, with or without
its extension, and a name with ``..`` never reaches outside them (:func:`locate`).
The ``--install`` options rewrite shipped files: that needs the clone they live in
(:func:`install_target`); a wheel's copy in site-packages is not twolink's to edit.
"""

from __future__ import annotations

import difflib
import errno
from importlib.resources import files
from pathlib import Path

from twolink.foundation.names import NameTooLong, refuse_long_name

__all__ = [
    "LinkLoop",
    "NameTooLong",
    "NotAClone",
    "clone_root",
    "install_target",
    "locate",
    "locate_beside",
    "models_dir",
    "refuse_link_loop",
    "rulebases_dir",
    "runs_dir",
    "shipped_hint",
    "shipped_names",
]

SUFFIX = ".toml"


class NotAClone(OSError):
    """``--install`` where twolink is installed from a wheel: nothing to install into."""


def _package_folder(package: str) -> Path:
    folder = files(package)
    if not isinstance(folder, Path):  # a zip import: twolink reads its files by path
        raise OSError(f"{package}: twolink's data must be installed as files, not in {folder}")
    return folder


def runs_dir() -> Path:
    """The shipped scenarios, sweeps and studies (``runs/`` in the clone)."""
    return _package_folder("twolink.runs")


def models_dir() -> Path:
    """The shipped MJCF files (``models/`` in the clone)."""
    return _package_folder("twolink.models")


def rulebases_dir() -> Path:
    """The shipped rule bases (``controllers/rulebases/`` in the clone)."""
    return _package_folder("twolink.controllers") / "rulebases"


def shipped_names() -> list[str]:
    """Every shipped TOML file's name: its path under the shipped runs, no extension."""
    root = runs_dir()
    return sorted(p.relative_to(root).with_suffix("").as_posix() for p in root.rglob("*.toml"))


def locate(path: str | Path, suffix: str = SUFFIX) -> Path:
    """The file ``path`` names: itself where it exists, or itself with the extension (a
    local file always wins: ``paper/theta1_step`` in a folder holding your own
    ``paper/theta1_step.toml`` is yours), else the shipped file of that name
    (``paper/theta1_step`` is ``<runs>/paper/theta1_step.toml``; the extension and a
    leading ``runs/`` may be given too, as the clone's paths read; a name with ``..`` is
    never a shipped one), else ``path`` unchanged, for the caller's own "no such file"
    error. A name longer than the file system takes (:class:`NameTooLong`) and a loop of
    symbolic links (:class:`LinkLoop`) are refused in one line: ``exists()`` is False for
    a loop, so it read "no such file", and raises for the other."""
    path = Path(path)
    refuse_long_name(path)
    refuse_link_loop(path)
    if path.exists() or path.is_absolute():
        return path
    local = path.with_name(path.name + suffix) if path.name else path
    refuse_link_loop(local)
    if local.exists():  # your paper/theta1_step.toml, named as the shipped one would be
        return local
    if ".." in path.parts:  # a shipped name never leaves the shipped files
        return path
    name = path.as_posix()
    names = [name, name.removeprefix("runs/")]
    root = runs_dir()
    for candidate in dict.fromkeys(n + s for n in names for s in ("", suffix)):
        shipped = root / candidate
        if candidate and shipped.is_file():
            return shipped
    return path


def locate_beside(folder: Path, name: str, suffix: str = SUFFIX) -> Path:
    """A file another file names (``extends``, a sweep's ``scenario``): ``folder / name``
    where it exists (relative to the naming file, as always), else the shipped file of
    that name (a user's own file in any folder can ``extends = "paper/theta1_step"``),
    else ``folder / name`` for the caller's error."""
    beside = Path(folder) / name
    refuse_link_loop(beside)
    if beside.exists() or Path(name).is_absolute():
        return beside
    found = locate(name, suffix)
    return found if found.is_absolute() and found.is_file() else beside


class LinkLoop(OSError):
    """A path that is a loop of symbolic links (l1 -> l2 -> l1)."""


def refuse_link_loop(path: Path) -> None:
    """:class:`LinkLoop` (an OSError, one line naming ``path``) where ``path`` is a loop
    of symbolic links: pathlib's ``resolve()`` raises RuntimeError there and ``exists()``
    says False, so a reader would print a traceback or "no such file". A missing or
    unreadable path is left to the reader's own error."""
    try:
        Path(path).resolve(strict=True)
    except (RuntimeError, OSError) as exc:  # OSError ELOOP from Python 3.13 on
        if isinstance(exc, RuntimeError) or exc.errno == errno.ELOOP:
            raise LinkLoop(f"{path}: a loop of symbolic links") from None


def shipped_hint(path: str | Path) -> str:
    """What to add to a "no such file" error for a relative path: the shipped names
    closest to it (or where the list is), so a typo in ``paper/theta1_stpe`` says
    what was meant."""
    path = Path(path)
    if path.is_absolute() or path.exists():
        return ""
    name = path.with_suffix("").as_posix().removeprefix("runs/")
    close = difflib.get_close_matches(name, shipped_names(), n=3, cutoff=0.6)
    if close:
        return f" (nor a shipped file; did you mean {' or '.join(close)}?)"
    return " (nor a shipped file: the shipped ones are `python -m twolink.foundation.shipped`)"


def clone_root() -> Path | None:
    """The repository twolink runs from (an editable install or a source checkout), or
    ``None`` where it is installed from a wheel: the shipped runs are a clone's where the
    folder above them holds the project's ``pyproject.toml`` and ``controllers/``."""
    runs = runs_dir()
    root = runs.parent
    clone = (root / "pyproject.toml").is_file() and (root / "controllers").is_dir()
    if runs.name == "runs" and clone:
        return root
    return None


def install_target(path: Path, option: str = "--install") -> Path:
    """``path``, a file ``--install`` rewrites; :class:`NotAClone` (one line saying why)
    where that file is the installed package's own copy: twolink was installed from a
    wheel, and its site-packages copy is nothing to install into. A clone's shipped
    files (an editable install) are rewritten in the clone."""
    package = _package_folder("twolink").resolve()
    ours = (package, runs_dir().resolve(), models_dir().resolve(), rulebases_dir().resolve())
    if clone_root() is None and any(Path(path).resolve().is_relative_to(d) for d in ours):
        raise NotAClone(
            f"{option} rewrites the shipped files of a clone of the repository; this twolink "
            f"is installed from a wheel ({package}), so there is nothing to install into: "
            "clone the repository and install it with `pip install -e .`"
        )
    return path


if __name__ == "__main__":  # the list a "no such file" error points to
    print("\n".join(shipped_names()))
