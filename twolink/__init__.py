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
import os
import time
from importlib.metadata import PackageNotFoundError, version
from typing import Any

IMPORTED_AT = time.perf_counter()  # a command's clock where the OS does not give its start


def _numba_cache_in_the_users_cache() -> None:
    """numba caches the compiled fuzzy kernels (``controllers/fuzzy/kernels.py``,
    ``cache=True``) beside their source by default: in a wheel install, inside
    site-packages. Unless the user chose a folder (``NUMBA_CACHE_DIR``), they go to
    ``$XDG_CACHE_HOME/twolink/numba`` (an absolute XDG_CACHE_HOME), else
    ``~/.cache/twolink/numba``. Set here, as the package is imported, so before any of
    its modules imports numba (numba reads it once, at its own import), and inherited
    by the pools' fork server and workers."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(base, "twolink", "numba")


_numba_cache_in_the_users_cache()

try:
    __version__ = version("twolink")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

# public name -> the module that defines it
_EXPORTS = {
    # the arm and its model
    "ArmParams": "twolink.arm.params",
    "Flexibility": "twolink.arm.params",
    "Plant": "twolink.arm.plant",
    # references and the closed loop
    "ArmReference": "twolink.foundation.references",
    "Step": "twolink.foundation.references",
    "Ramp": "twolink.foundation.references",
    "Sine": "twolink.foundation.references",
    "Quintic": "twolink.foundation.references",
    "simulate": "twolink.simulation.sim",
    "Trajectory": "twolink.simulation.sim",
    # controllers
    "ComputedTorque": "twolink.controllers.ctc",
    "FuzzyComputedTorque": "twolink.controllers.fuzzy_ctc",
    "MamdaniEngine": "twolink.controllers.fuzzy",
    "read_fis": "twolink.controllers.fuzzy.fis.matlab",
    "default_fuzzy_pd": "twolink.controllers.fuzzy",
    "paper_fuzzy_pd": "twolink.controllers.fuzzy",
    # metrics
    "step_metrics": "twolink.simulation.metrics",
    "StepMetrics": "twolink.simulation.metrics",
    "error_measures": "twolink.simulation.metrics",
    # scenario files, sweeps, figures
    "load_scenario": "twolink.simulation.config",
    "run_scenario": "twolink.simulation.experiment",
    "measure": "twolink.simulation.experiment",
    "load_results": "twolink.sweep",
    # every command as one call (twolink/api.py)
    "load_rule_base": "twolink.api",
    "design_rule_base": "twolink.api",
    "run_sweep": "twolink.api",
    "reproduce": "twolink.studies.reproduction.reproduce",
    # two controllers on one scenario, judged plant by plant (twolink compare)
    "compare": "twolink.studies.judgments.compare",
    "Comparison": "twolink.studies.judgments.compare",
    "paired_claims": "twolink.studies.judgments.claims",
    # figures of finished results (matplotlib, headless)
    "run_figures": "twolink.figures.plots",
    "response_figure": "twolink.figures.plots",
    "control_surface_figure": "twolink.figures.plots",
    "membership_figure": "twolink.figures.plots",
    "sweep_figures": "twolink.sweep.figures",
}

__all__ = ["__version__", *_EXPORTS]

from twolink import aliases  # noqa: E402  (the old module names, one table)

aliases.install(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'twolink' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
