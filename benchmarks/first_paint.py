"""Time to first paint of rerun recordings in the web viewer (headless Chromium, WebGL on
the CPU), the way ``../shared/tools/rerun-screenshot`` opens them.

For each recording: ``rerun --serve-web`` on it (own process group, 127.0.0.1 only), a
fresh headless Chromium (SwiftShader) on the viewer's page, then a screenshot every
``--every`` seconds (the browser waits with playwright's ``wait_for_timeout``, not a
blocking sleep) until the first tab's plots show their curves: at least ``--min-pixels``
coloured pixels in the plot area (the controllers' colours; the loading screen and an
empty layout have none, one view of overlapping curves ~350, mostly its legend's
swatches, which a view shows only once it plots). First paint = seconds from
``page.goto`` to that screenshot (late by up to ``--every`` s). Trials interleave the
recordings (A B A B ...) so that a busy machine slows all alike; the viewer and browser
are stopped after every trial. The last screenshot of each trial is kept (``--shots``).

**Polling slows what it measures.** A screenshot is a full-page read-back on the software
renderer, and one every 2 s delays the viewer: on 2026-11-26 an 8 KB recording first
showed its curve 10-21 s in when polled, yet a single screenshot showed it at 10 s in 4
of 4 trials (docs/tracing.md). Polled times are upper bounds, for comparing two files
interleaved. ``--at S`` checks the way ``rerun-screenshot RECORDING OUT S`` looks: one
screenshot S seconds after ``page.goto``; a trial passes if it shows the curves, and the
summary counts passes (bracket the paint with several S).

    export PYTHONPATH=~/.cache/rerun-screenshot/lib/python3.11/site-packages
    .venv/bin/python benchmarks/first_paint.py main.rrd new.rrd -n 5 --shots /tmp/shots
    .venv/bin/python benchmarks/first_paint.py new.rrd -n 4 --at 15
"""

from __future__ import annotations

import argparse
import io
import os
import signal
import socket
import statistics
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

# The viewer's plot area at 1600x1000 (between the blueprint and selection panels, below
# the tab bar): the curves' pixels are coloured there, everything else is grey or white.
PLOTS = (slice(70, 850), slice(210, 1290))
ARGS = [
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--disable-features=WebGPU",
]


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _pixels(png: bytes) -> int:
    """Coloured pixels (chroma > 60 of 255) in the plot area: the curves and the legends'
    swatches (about 50 pixels each)."""
    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)[PLOTS]
    return int((a.max(axis=-1) - a.min(axis=-1) > 60).sum())


def trial(
    rrd: Path,
    rerun: str,
    every: float,
    limit: float,
    min_pixels: int,
    shot: Path | None,
    at: float | None = None,
):
    web, grpc = _port(), _port()
    viewer = subprocess.Popen(
        [rerun, "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", str(web),
         "--port", str(grpc), str(rrd)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    try:
        for _ in range(150):  # both servers up (the viewer does not retry its connection)
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=1)
                socket.create_connection(("127.0.0.1", grpc), timeout=1).close()
                break
            except OSError:
                time.sleep(0.2)
        src = urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="")
        with sync_playwright() as p:
            b = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            try:
                page = b.new_page(viewport={"width": 1600, "height": 1000})
                t0 = time.monotonic()
                page.goto(f"http://127.0.0.1:{web}/?url={src}&renderer=webgl")
                if at is not None:  # one look, as rerun-screenshot takes it
                    page.wait_for_timeout(at * 1000 - (time.monotonic() - t0) * 1000)
                    png = page.screenshot()
                    n = _pixels(png)
                    if shot:
                        shot.write_bytes(png)
                    return (at if n >= min_pixels else float("inf")), n
                while (elapsed := time.monotonic() - t0) < limit:
                    page.wait_for_timeout(every * 1000)
                    png = page.screenshot()
                    elapsed = time.monotonic() - t0
                    n = _pixels(png)
                    if n >= min_pixels:
                        break
                else:
                    elapsed = float("inf")
                if shot:
                    shot.write_bytes(png)
                return elapsed, n
            finally:
                b.close()
    finally:
        os.killpg(viewer.pid, signal.SIGTERM)
        viewer.wait(timeout=30)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", type=Path)
    ap.add_argument("-n", "--trials", type=int, default=5)
    ap.add_argument("--every", type=float, default=2.0, help="seconds between screenshots")
    ap.add_argument("--limit", type=float, default=150.0, help="give up after (s)")
    ap.add_argument("--min-pixels", type=int, default=250)
    ap.add_argument("--at", type=float, help="one screenshot this many seconds in: pass/fail")
    ap.add_argument("--shots", type=Path, help="folder for each trial's first-paint PNG")
    ap.add_argument("--rerun", default=".venv/bin/rerun")
    a = ap.parse_args()
    if a.shots:
        a.shots.mkdir(parents=True, exist_ok=True)
    times: dict[Path, list[float]] = {r: [] for r in a.recordings}
    for k in range(a.trials):
        for i, r in enumerate(a.recordings):
            shot = a.shots / f"{i}-{r.stem}-{k}.png" if a.shots else None
            with open("/proc/loadavg") as f:
                load = f.read().split()[0]
            s, n = trial(r, a.rerun, a.every, a.limit, a.min_pixels, shot, a.at)
            times[r].append(s)
            print(f"trial {k} {r}: {s:.1f} s ({n} curve pixels, load {load})",
                  flush=True)  # fmt: skip
    for r, ts in times.items():
        if a.at is not None:
            passed = sum(t != float("inf") for t in ts)
            print(f"{r} ({r.stat().st_size / 1e6:.2f} MB): curves shown at {a.at:g} s in "
                  f"{passed} of {len(ts)} trials")  # fmt: skip
            continue
        ok = [t for t in ts if t != float("inf")]
        print(
            f"{r} ({r.stat().st_size / 1e6:.2f} MB): median {statistics.median(ts):.1f} s, "
            f"range {min(ok, default=float('nan')):.1f}-{max(ok, default=float('nan')):.1f} s, "
            f"{len(ts) - len(ok)} of {len(ts)} not painted",
            file=sys.stdout,
        )


if __name__ == "__main__":
    main()
