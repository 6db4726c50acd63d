"""Arm-steps counted for a profile, when the environment asks for it.

Set ``TWOLINK_STEP_LOG`` to a folder and every engine call (a batch of arms, or one arm
alone) appends one JSON line to ``steps-<pid>.jsonl`` there: how many arms it carried,
how many physics steps it took, each arm's steps, a digest of each arm's record, the
twolink functions that called it and the sweep it belongs to. Unset, nothing is written
and nothing is computed. ``benchmarks/profile_reproduce.py`` reads these lines.

Two arms with the same digest computed the same run: the same plant, controller and
reference, with the same noise (their recorded states and torques are equal bit for bit).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ENV = "TWOLINK_STEP_LOG"


def enabled() -> bool:
    """Whether the environment asks for a step log."""
    return bool(os.environ.get(ENV))


def arm_digest(q: np.ndarray, tau: np.ndarray) -> str:
    """The digest of one arm's record: its joint angles and torques, bit for bit."""
    h = hashlib.sha256(np.ascontiguousarray(q).tobytes())
    h.update(np.ascontiguousarray(tau).tobytes())
    return h.hexdigest()[:20]


def _callers() -> tuple[list[str], str]:
    """The twolink functions on the stack (outermost first) and the sweep plan in scope
    ("name:digest", "" where none)."""
    chain: list[str] = []
    sweep = ""
    frame = sys._getframe(2)
    while frame is not None:
        module = frame.f_globals.get("__name__", "")
        if module.startswith("twolink.") and module != __name__:
            chain.append(f"{module}.{frame.f_code.co_name}")
            plan = frame.f_locals.get("plan")
            if not sweep and hasattr(plan, "digest") and hasattr(plan, "name"):
                sweep = f"{plan.name}:{str(plan.digest)[:12]}"
        frame = frame.f_back
    return chain[::-1], sweep


def record(
    engine: str,
    started: float,
    physics_steps: int,
    lengths: np.ndarray,
    substeps: int,
    digests: list[str],
) -> None:
    """Append one engine call to the log: ``physics_steps`` calls of ``mj_step`` on a
    model of ``len(lengths)`` arms, arm i kept for ``lengths[i]`` control samples of
    ``substeps`` physics steps each. A no-op where the log is off."""
    folder = os.environ.get(ENV)
    if not folder:
        return
    chain, sweep = _callers()
    line = {
        "engine": engine,
        "pid": os.getpid(),
        "start": started,
        "end": time.time(),
        "arms": len(lengths),
        "physics_steps": int(physics_steps),
        "arm_steps": int(physics_steps) * len(lengths),
        "useful_arm_steps": int(np.maximum(np.asarray(lengths) - 1, 0).sum()) * substeps,
        "digests": digests,
        "callers": chain,
        "sweep": sweep,
    }
    path = Path(folder) / f"steps-{os.getpid()}.jsonl"
    with open(path, "a") as f:
        f.write(json.dumps(line) + "\n")
