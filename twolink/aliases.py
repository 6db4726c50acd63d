"""The old module names, in one table: each answers as the module it became.

``import twolink.params`` gives ``twolink.arm.params`` itself, the same module object, so
older code, pickles and DESIGN.md's names keep working. Three kinds of old name:

| old name | now |
|---|---|
| ``twolink.<module>`` (flat) | ``twolink.<layer>.<module>``, ``twolink.studies.<stage>.<module>`` |
| ``twolink.studies.<module>`` | ``twolink.studies.<stage>.<module>``, per :data:`STAGES` |
| the names in :data:`MOVED` | the module each names |

A public name of ``twolink`` wins over a flat module name (``twolink.reproduce`` is the
function). Installed once by ``twolink/__init__.py``; nothing else defines an alias.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
from types import ModuleType
from typing import Any

LAYERS = {
    "foundation": ("references", "io", "interrupts", "executors", "overrides"),
    "arm": ("params", "dynamics", "plant", "validation"),
    "simulation": (
        "config", "sim", "batch", "metrics", "outcome", "stability", "experiment",
        "vocabulary",
    ),
    "figures": ("plots",),
    "interface": ("cli", "cli_fuzzy", "cli_output", "cli_studies"),
}  # fmt: skip
STAGES = {
    "designs": (
        "design", "design_checks", "validity", "gains", "sensing", "calibrate",
        "calibration_report", "frontier", "search", "matching",
    ),
    "judgments": (
        "claims", "claims_words", "claims_plans", "claims_studies", "conclusions",
        "regimes", "compare", "flexible_limits",
    ),
    "reproduction": (
        "manifest", "reproduce", "report", "report_sections", "reproduce_figures", "hero",
        "run_folder",
    ),
}  # fmt: skip
MOVED = {
    "twolink.interface.config": "twolink.simulation.config",
    "twolink.interface.overrides": "twolink.foundation.overrides",
    "twolink.interface.io": "twolink.foundation.io",
    "twolink.interface.plots": "twolink.figures.plots",
    "twolink.interface.executors": "twolink.foundation.executors",
    "twolink.interface.interrupts": "twolink.foundation.interrupts",
    "twolink.simulation.references": "twolink.foundation.references",
    # the MATLAB .fis modules, now one sub-package
    "twolink.controllers.fuzzy.fis_sections": "twolink.controllers.fuzzy.fis.sections",
    "twolink.controllers.fuzzy.matlab": "twolink.controllers.fuzzy.fis.matlab",
    "twolink.controllers.fuzzy.matlab_exact": "twolink.controllers.fuzzy.fis.exact",
    "twolink.controllers.fuzzy.matlab_bound": "twolink.controllers.fuzzy.fis.bound",
}


ALIASES: dict[str, str] = {}  # old name -> module, filled by install()


def install(public_names) -> None:
    """Make every old name importable; ``public_names`` (``twolink``'s own) win over a flat
    module name of the same spelling."""
    flat = {
        f"twolink.{name}": f"twolink.{where}.{name}"
        for where, names in [*LAYERS.items(), *((f"studies.{s}", n) for s, n in STAGES.items())]
        for name in names
        if name not in public_names
    }
    staged = {
        f"twolink.studies.{name}": f"twolink.studies.{stage}.{name}"
        for stage, names in STAGES.items()
        for name in names
    }
    ALIASES.update({**flat, **staged, **MOVED})
    if not any(type(finder).__name__ == "_OldNames" for finder in sys.meta_path):
        sys.meta_path.append(_OldNames())


class _OldNames(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an old name (``twolink.params``) as the module it became."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        if name in ALIASES:
            return importlib.util.spec_from_loader(name, self)
        return None

    def create_module(self, spec: Any) -> ModuleType:
        module = importlib.import_module(ALIASES[spec.name])
        spec.loader_state = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        # the import system has just given the module the old name's spec: give it back
        module.__spec__ = module.__spec__.loader_state
