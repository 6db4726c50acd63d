"""Control laws for the two-link arm: computed torque, Mamdani fuzzy PD, FCM rule reduction.

Installed as ``twolink.controllers`` (the repository keeps this folder at its top level;
``pyproject.toml`` maps it), so no generic ``controllers`` module lands in site-packages::

    from twolink.controllers import ComputedTorque, FuzzyComputedTorque

Names load on first use (PEP 562), as in :mod:`twolink`.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "Controller": "twolink.controllers.base",
    "ComputedTorque": "twolink.controllers.ctc",
    "FuzzyComputedTorque": "twolink.controllers.fuzzy_ctc",
    "PDGravity": "twolink.controllers.baselines",
    "IntegralComputedTorque": "twolink.controllers.baselines",
    "FuzzyPD": "twolink.controllers.baselines",
    "AdaptiveComputedTorque": "twolink.controllers.adaptive",
    "SlidingMode": "twolink.controllers.sliding",
    "DisturbanceObserverCTC": "twolink.controllers.observer",
    "Uncertainty": "twolink.controllers.uncertainty",
    "MotorPD": "twolink.controllers.flexible",
    "CompositeControl": "twolink.controllers.flexible",
    "FlexibleFeedbackLinearisation": "twolink.controllers.flexible",
    "FCMResult": "twolink.controllers.fcm",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'twolink.controllers' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
