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
