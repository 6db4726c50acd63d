"""One writer per output folder: a second reproduction or sweep into a folder in use stops
at once (exit 2, naming the holder), writes nothing, and the lock dies with its holder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from twolink.foundation.io import LOCK_NAME, OutputBusy, output_lock
from twolink.interface.cli import main

REPO = Path(__file__).resolve().parents[1]


def test_a_held_folder_refuses_a_second_holder(tmp_path):
    with output_lock(tmp_path / "out"):
        with pytest.raises(OutputBusy, match=r"another twolink \(pid \d+\)"):
            with output_lock(tmp_path / "out"):
                pass
    with output_lock(tmp_path / "out"):  # released: free again
        pass


@pytest.mark.parametrize(
    "args",
    [
        ["sweep", str(REPO / "runs/sweeps/flexible_map.toml"), "-n", "1", "--no-plots"],
        ["reproduce", "--no-trace"],
    ],
    ids=["sweep", "reproduce"],
)
def test_a_second_command_into_a_folder_in_use_exits_2_and_writes_nothing(tmp_path, args):
    out = tmp_path / "out"
    with output_lock(out):
        result = CliRunner().invoke(main, [*args, "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert "another twolink" in result.output and "Traceback" not in result.output
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


def test_the_lock_dies_with_a_killed_holder(tmp_path):
    out = tmp_path / "out"
    code = (
        "import os, sys; from twolink.foundation.io import output_lock\n"
        f"with output_lock({str(out)!r}): os.kill(os.getpid(), 9)"
    )
    subprocess.run([sys.executable, "-c", code], check=False)
    assert (out / LOCK_NAME).exists()  # the file stays, its lock does not
    with output_lock(out):
        pass
