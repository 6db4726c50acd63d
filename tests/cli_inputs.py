"""What the tests of output folders share (test_nothing_lost, test_nothing_lost_owner,
test_hostile_files): a quick run, a tiny sweep file, the command line called in-process,
a folder's files with their bytes, and the one-line error check."""

from __future__ import annotations

import os
from pathlib import Path

from click.testing import CliRunner

from twolink.interface.cli import main

REPO = Path(__file__).resolve().parents[1]
STEP = REPO / "runs" / "paper" / "theta1_step.toml"
BASE = (REPO / "runs" / "paper" / "base.toml").as_posix()
QUICK = ["--set", "duration=0.05", "--no-trace", "--no-plots"]
SWEEP = f"""name = "tiny_sweep"
scenario = "{BASE}"
samples = 2
chunk_size = 1

[overrides]
duration = 0.05

[reference.joint1]
kind = "step"
final = 1.0

[parameters]
m1 = {{ dist = "uniform", low = 0.8, high = 1.2 }}

[controllers.ctc]
kind = "ctc"
"""


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def tree(path: Path) -> dict[str, bytes]:
    """Every file under ``path`` with its bytes (links as their target's name)."""
    out = {}
    for p in sorted(path.rglob("*")):
        if p.is_symlink():
            out[str(p.relative_to(path))] = os.readlink(p).encode()
        elif p.is_file():
            out[str(p.relative_to(path))] = p.read_bytes()
    return out


def one_error_line(result) -> None:
    lines = [x for x in result.output.splitlines() if x.startswith("error")]
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
