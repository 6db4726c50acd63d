"""The scenario keys of the field's laws (adaptive CTC, sliding mode, CTC with a
disturbance observer, and the two-time-scale law of links that bend): which kind reads
which ``[controller]`` key, how each is read and checked, and how a resolved config
writes them (only for the kind that reads them).
The scenario model (:mod:`twolink.simulation.config`) calls these."""

from __future__ import annotations

from typing import Any

from twolink.controllers.adaptive import DEFAULT_GAMMA
from twolink.controllers.observer import DEFAULT_OBSERVER_TIME
from twolink.controllers.sliding import DEFAULT_ETA

AUTO = "auto"
FIELD_KINDS = ("adaptive_ctc", "sliding_mode", "ctc_dob")
# Laws of links that bend (controllers/flexible_links.py): they model [arm.links]
LINK_KINDS = ("two_time_scale",)
FIELD_KEYS = {
    "adaptive_ctc": ("gamma",),
    "sliding_mode": ("eta", "phi"),
    "ctc_dob": ("observer_time",),
    "two_time_scale": ("ks",),
}
DEFAULT_KS = (0.01, 0.01)  # s: the strain-rate gain of docs/flexible_links.md's linearisation
DEFAULTS = {"gamma": DEFAULT_GAMMA, "eta": DEFAULT_ETA, "phi": None}
DEFAULTS["observer_time"] = DEFAULT_OBSERVER_TIME
DEFAULTS["ks"] = DEFAULT_KS


def read_field_keys(t: Any) -> dict[str, Any]:
    """The field laws' keys of a ``[controller]`` table ``t`` (a ``TomlTable``), checked:
    ``gamma`` one number or one per regressor parameter (>= 0), ``eta`` >= 0, ``phi``
    > 0 or ``"auto"`` (None), ``observer_time`` > 0, ``ks`` >= 0 (one or a pair)."""
    value = t.raw("gamma", DEFAULT_GAMMA)
    n = len(DEFAULT_GAMMA)
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = (value,) * n
    if not isinstance(value, list | tuple) or len(value) != n:
        t.fail("gamma", f"must be a number or a list of {n} numbers, got {value!r}")
    phi = t.raw("phi", AUTO)
    return {
        "gamma": tuple(t._checked("gamma", v, minimum=0.0) for v in value),
        "eta": t.pair("eta", DEFAULT_ETA, minimum=0.0),
        "phi": None if phi == AUTO else t.pair("phi", (1.0, 1.0), positive=True),
        "observer_time": t.number("observer_time", DEFAULT_OBSERVER_TIME, positive=True),
        "ks": t.pair("ks", DEFAULT_KS, minimum=0.0),
    }


def write_field_keys(ctrl: dict[str, Any], kind: str) -> None:
    """Keep in a resolved ``[controller]`` dict only the keys ``kind`` reads (so the
    digests of other kinds' runs stay as they were), as TOML values."""
    for key in DEFAULTS:
        if key not in FIELD_KEYS.get(kind, ()):
            del ctrl[key]
        elif ctrl[key] is None:
            ctrl[key] = AUTO
        elif isinstance(ctrl[key], tuple):
            ctrl[key] = list(ctrl[key])


def check_field_keys(top: Any, scenario: Any) -> None:
    """What the keys need of the rest of the scenario: an observer no faster than the
    control period (the discrete observer is unstable below it); links that bend for a
    law that models them."""
    c = scenario.controller
    if c.kind in LINK_KINDS and scenario.links is None:
        top.fail(
            "controller.kind",
            f"{c.kind!r} models links that bend and reads their hinges: it needs [arm.links]",
        )
    if c.kind == "ctc_dob" and c.observer_time < scenario.control_dt:
        top.fail(
            "controller.observer_time",
            f"must be >= control_dt {scenario.control_dt}, got {c.observer_time}",
        )
