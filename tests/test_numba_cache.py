"""numba's cache in the user's cache folder, never beside the package's source (a wheel's
site-packages): issue 49."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import twolink.controllers.fuzzy.kernels as kernels

SOURCE = Path(kernels.__file__).parent


def cache_dir(**env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    code = "import os, twolink; print(os.environ['NUMBA_CACHE_DIR'])"
    out = subprocess.run(
        [sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
        check=True,
    )  # fmt: skip
    return out.stdout.strip()


def test_numbas_cache_goes_to_the_users_cache_folder_unless_chosen(tmp_path):
    assert cache_dir(XDG_CACHE_HOME=str(tmp_path)) == str(tmp_path / "twolink" / "numba")
    home = str(tmp_path / "home")
    assert cache_dir(HOME=home) == os.path.join(home, ".cache", "twolink", "numba")
    assert cache_dir(HOME=home, XDG_CACHE_HOME="relative") == cache_dir(HOME=home)
    assert cache_dir(NUMBA_CACHE_DIR=str(tmp_path / "mine")) == str(tmp_path / "mine")


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
def test_the_compiled_kernels_are_cached_there_and_not_beside_their_source(tmp_path):
    def beside() -> set[Path]:
        return {p for p in SOURCE.rglob("*") if p.suffix in (".nbi", ".nbc")}

    before = beside()
    clean = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    code = "from twolink.controllers.fuzzy import kernels; kernels.warm()"
    subprocess.run(
        [sys.executable, "-c", code], env={**clean, "XDG_CACHE_HOME": str(tmp_path)}, check=True,
        timeout=300,
    )  # fmt: skip
    cached = list((tmp_path / "twolink" / "numba").rglob("*.nbi"))
    assert cached, "no kernel cached in the user's cache folder"
    assert beside() == before


def _warm(env: dict[str, str], before: str = "") -> subprocess.CompletedProcess:
    clean = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    code = before + "from twolink.controllers.fuzzy import kernels; kernels.warm()"
    return subprocess.run(
        [sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip


def _beside() -> set[Path]:
    return {p for p in SOURCE.rglob("*") if p.suffix in (".nbi", ".nbc")}


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
@pytest.mark.parametrize("where", ["a file", "under a file", "chosen, under a file"])
def test_a_cache_folder_that_cannot_be_made_turns_caching_off_with_a_note(tmp_path, where):
    # numba would then cache beside the source (site-packages) or, with nowhere to write,
    # raise at the kernels' first call (the pool's fork server died of it)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder\n")
    env = {
        "a file": {"XDG_CACHE_HOME": str(blocker)},
        "under a file": {"XDG_CACHE_HOME": str(blocker / "cache")},
        "chosen, under a file": {"NUMBA_CACHE_DIR": str(blocker / "numba")},
    }[where]
    before = _beside()
    done = _warm(env)
    assert done.returncode == 0, done.stderr
    notes = [x for x in done.stderr.splitlines() if x.startswith("note: numba's cache")]
    assert len(notes) == 1 and "not cached" in notes[0] and "Traceback" not in done.stderr
    assert str(blocker) in notes[0]
    assert _beside() == before
    assert blocker.read_text() == "not a folder\n"


# Root writes through a read-only mode, so as root the writes under the folder meet the
# EACCES that a user's would (numba probes with tempfile.TemporaryFile, as twolink does).
_READ_ONLY = """import errno, tempfile
_made = tempfile.TemporaryFile
def _denied(*args, dir=None, **kwargs):
    if str(dir).startswith({folder!r}):
        raise PermissionError(errno.EACCES, "Permission denied", dir)
    return _made(*args, dir=dir, **kwargs)
tempfile.TemporaryFile = _denied
"""


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
def test_a_read_only_cache_folder_turns_caching_off_with_a_note(tmp_path):
    folder = tmp_path / "cache"
    folder.mkdir()
    folder.chmod(0o555)
    before = _beside()
    done = _warm({"XDG_CACHE_HOME": str(folder)}, _READ_ONLY.format(folder=str(folder)))
    folder.chmod(0o755)
    assert done.returncode == 0, done.stderr
    notes = [x for x in done.stderr.splitlines() if x.startswith("note: numba's cache")]
    assert len(notes) == 1 and "not cached" in notes[0] and "Traceback" not in done.stderr
    assert str(folder) in notes[0] and "Permission denied" in notes[0], notes
    assert _beside() == before
    assert not list(folder.rglob("*.nb[ic]"))


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
def test_a_full_cache_disk_turns_caching_off_with_a_note_and_the_kernels_still_run(tmp_path):
    # the folder can be made and probed, then numba's save meets ENOSPC (a disk that filled)
    full = (
        "import errno, numba.core.caching as c\n"
        "def full(self, path, overwrite=False):\n"
        "    raise OSError(errno.ENOSPC, 'No space left on device', path)\n"
        "c.IndexDataCacheFile._open_for_write = full\n"
    )
    before = _beside()
    done = _warm({"XDG_CACHE_HOME": str(tmp_path)}, full)
    assert done.returncode == 0, done.stderr
    notes = [x for x in done.stderr.splitlines() if x.startswith("note: numba's cache")]
    assert len(notes) == 1 and "No space left on device" in notes[0], done.stderr
    assert _beside() == before


@pytest.mark.slow  # ~15 s: a fork server and two workers, the kernels compiled uncached
@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
def test_a_sweep_on_the_pool_runs_with_the_cache_off_and_says_so_once(tmp_path):
    # the pool's fork server loads the kernels first (kernels_loaded): it lives, and the
    # command finishes (not "interrupted", exit 130, as when the server died of it)
    from cli_inputs import SWEEP

    blocker = tmp_path / "file"
    blocker.write_text("")
    (tmp_path / "tiny.toml").write_text(SWEEP)
    clean = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    done = subprocess.run(
        [sys.executable, "-m", "twolink", "sweep", str(tmp_path / "tiny.toml"), "--workers", "2",
         "--executor", "process", "--out", str(tmp_path / "out"), "--no-plots"],
        env={**clean, "XDG_CACHE_HOME": str(blocker)}, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stderr.count("note: numba's cache") == 1, done.stderr  # after the bar's start
    assert "Traceback" not in done.stderr and (tmp_path / "out" / "results.parquet").is_file()
