"""twolink: a two-link arm in MuJoCo with CTC and FCM fuzzy controllers.

The public API in one import (see the README's library quick start)::

    from twolink import ArmParams, ArmReference, ComputedTorque, Plant, Step, simulate

Names are loaded on first use (PEP 562), so ``import twolink`` stays cheap and the
package imports nothing it does not need: MuJoCo comes with ``Plant``, matplotlib with
``run_figures``. The controllers are ``twolink.controllers`` (the repository's top-level
``controllers/`` folder, mapped there by ``pyproject.toml``) and are re-exported here.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("twolink")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

# public name -> the module that defines it
_EXPORTS = {
    # the arm and its model
    "ArmParams": "twolink.params",
    "Flexibility": "twolink.params",
    "Plant": "twolink.plant",
    # references and the closed loop
    "ArmReference": "twolink.references",
    "Step": "twolink.references",
    "Ramp": "twolink.references",
    "Sine": "twolink.references",
    "Quintic": "twolink.references",
    "simulate": "twolink.sim",
    "Trajectory": "twolink.sim",
    # controllers
    "ComputedTorque": "twolink.controllers.ctc",
    "FuzzyComputedTorque": "twolink.controllers.fuzzy_ctc",
    "MamdaniEngine": "twolink.controllers.fuzzy",
    "default_fuzzy_pd": "twolink.controllers.fuzzy",
    "paper_fuzzy_pd": "twolink.controllers.fuzzy",
    # metrics
    "step_metrics": "twolink.metrics",
    "StepMetrics": "twolink.metrics",
    "error_measures": "twolink.metrics",
    # scenario files, sweeps, figures
    "load_scenario": "twolink.config",
    "run_scenario": "twolink.experiment",
    "measure": "twolink.experiment",
    "load_results": "twolink.sweep",
    "run_figures": "twolink.plots",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'twolink' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
