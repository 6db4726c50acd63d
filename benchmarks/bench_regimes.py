"""Wall time of ``twolink regimes`` (the regime map: 30 cells x 100 plants x 2 regimes x
4 controllers), beside a machine yardstick timed in the same run; issue 29 asks for at
most 3 min on 2 cores.

The yardstick is bench_reproduce's: 10^6 bare single-arm ``mj_step`` calls in this
process, before and after (this VM's speed varies from day to day by up to 1.8x, so the
time is also printed as a multiple of it). The command runs in a subprocess, start-up
included, into a fresh folder.

    python benchmarks/bench_regimes.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_reproduce import yardstick  # this folder is on the path when run as a script


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        before = yardstick()
        start = time.perf_counter()
        command = [sys.executable, "-m", "twolink", "regimes", "--out", str(Path(tmp) / "r")]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        took = time.perf_counter() - start
        after = yardstick()
    unit = (before + after) / 2
    print(f"yardstick: 10^6 bare single-arm mj_steps {before:.2f} s before, {after:.2f} s after")
    print(f"twolink regimes: {took:.1f} s ({took / unit:.1f}x the yardstick; target 180 s)")


if __name__ == "__main__":
    main()
