"""The searched opponents as shipped, read without the search that found them
(:mod:`twolink.studies.designs.opponent_search` runs the search), so the fuzzy table
search and the claims can judge against them without importing the searcher back:

- CTC-best (``runs/paper/frontier_per_joint.json``): CTC with ωn and ζ per joint and its
  torque limit (:class:`SearchedOpponent`);
- the tuned laws (``runs/paper/tuned_opponents.json``): each family of :data:`LAWS` tuned
  by the same search and effort rule, by name (:data:`TUNED`; :class:`TunedOpponent`).

A family's gain vector ``x`` becomes the sweep's ``[controllers]`` entry by its
:class:`Law`'s ``entry``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "LAWS",
    "TUNED",
    "Law",
    "SearchedOpponent",
    "TunedOpponent",
    "controller",
    "shipped_opponents",
    "shipped_tuned",
]

TUNED_FILE = "tuned_opponents.json"  # beside the manifest, as frontier_per_joint.json


def controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """The sweep's ``[controllers]`` entry of ``x = (ωn1, ζ1, ωn2, ζ2)``."""
    wn1, z1, wn2, z2 = (float(v) for v in x)
    return {
        "kind": "ctc",
        "kp": [wn1 * wn1, wn2 * wn2],
        "kd": [2 * z1 * wn1, 2 * z2 * wn2],
        "torque_limit": [float(torque_limit[0]), float(torque_limit[1])],
    }


def integral_controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """CTC-I's entry of ``x = (ωn1, ζ1, ρ1, ωn2, ζ2, ρ2)``: Kp = ωn², Kd = 2ζωn and
    Ki = ρ Kp Kd per joint. ρ is the integral gain's share of the Routh-Hurwitz bound of
    the nominal loop s³ + Kd s² + Kp s + Ki (stable for Ki < Kp Kd, ρ < 1)."""
    wn1, z1, r1, wn2, z2, r2 = (float(v) for v in x)
    kp = [wn1 * wn1, wn2 * wn2]
    kd = [2 * z1 * wn1, 2 * z2 * wn2]
    return {
        "kind": "ctc_integral",
        "kp": kp,
        "kd": kd,
        "ki": [r1 * kp[0] * kd[0], r2 * kp[1] * kd[1]],
        "torque_limit": [float(torque_limit[0]), float(torque_limit[1])],
    }


def _limit(torque_limit: tuple[float, float]) -> list[float]:
    return [float(torque_limit[0]), float(torque_limit[1])]


def _rate_gains(wn1: float, wn2: float) -> dict[str, list[float]]:
    """Kp = ωn², Kd = 2 ωn: the adaptive and sliding laws' λ = ωn, K_D = ωn M̂_jj."""
    return {"kp": [wn1 * wn1, wn2 * wn2], "kd": [2 * wn1, 2 * wn2]}


def adaptive_controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """Slotine-Li's entry of ``x = (ωn1, ωn2, g)``: λ = ωn and K_D = ωn M̂_jj per joint
    (:func:`twolink.controllers.adaptive.adaptive_gains` of Kp = ωn², Kd = 2 ωn), and
    Γ = 10^g times the law's default diagonal."""
    from twolink.controllers.adaptive import DEFAULT_GAMMA

    wn1, wn2, g = (float(v) for v in x)
    gamma = [10.0**g * v for v in DEFAULT_GAMMA]
    return {"kind": "adaptive_ctc", **_rate_gains(wn1, wn2), "gamma": gamma,
            "torque_limit": _limit(torque_limit)}  # fmt: skip


def sliding_controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """Sliding mode's entry of ``x = (ωn1, f1, ωn2, f2)``: λ = ωn per joint and the
    boundary layer φ = 10^f rad/s; the gain K stays the theory's (the model-error bound
    plus η: :func:`twolink.controllers.uncertainty.sliding_gain`), so K/φ, the layer's
    slope, moves with φ."""
    wn1, f1, wn2, f2 = (float(v) for v in x)
    return {"kind": "sliding_mode", **_rate_gains(wn1, wn2), "phi": [10.0**f1, 10.0**f2],
            "torque_limit": _limit(torque_limit)}  # fmt: skip


def observer_controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """CTC-DOB's entry of ``x = (ωn1, ζ1, ωn2, ζ2, h)``: CTC's Kp = ωn², Kd = 2ζωn per
    joint and the observer's time constant T = 10^h s."""
    wn1, z1, wn2, z2, h = (float(v) for v in x)
    return {**controller(np.array([wn1, z1, wn2, z2]), torque_limit), "kind": "ctc_dob",
            "observer_time": 10.0**h}  # fmt: skip


@dataclass(frozen=True)
class Law:
    """A family of a searched opponent: the names of its gain vector's entries and the
    sweep's ``[controllers]`` entry of a gain vector and a torque limit."""

    kind: str
    params: tuple[str, ...]
    entry: Any  # (x, torque_limit) -> dict

    def describe(self, x: tuple[float, ...]) -> str:
        """The gains per joint, then the others, e.g. ``ωn = 27.2 / 33.8, ζ = 0.44 / 0.40``
        (a name ending in 1 is joint 1's, its joint-2 twin ends in 2)."""
        value = dict(zip(self.params, x, strict=True))
        words = []
        for name in self.params:
            if name.endswith("1") and f"{name[:-1]}2" in value:
                words.append(f"{name[:-1]} = {value[name]:.3g} / {value[name[:-1] + '2']:.3g}")
            elif not (name.endswith("2") and f"{name[:-1]}1" in value):
                words.append(f"{name} = {value[name]:.3g}")
        return ", ".join(words)


LAWS = {
    "CTC": Law("ctc", ("ωn1", "ζ1", "ωn2", "ζ2"), controller),
    "CTC clipped": Law("ctc", ("ωn1", "ζ1", "ωn2", "ζ2"), controller),
    "CTC-I": Law("ctc_integral", ("ωn1", "ζ1", "ρ1", "ωn2", "ζ2", "ρ2"), integral_controller),
    "Slotine-Li": Law("adaptive_ctc", ("ωn1", "ωn2", "log10 Γ/Γ₀"), adaptive_controller),
    "sliding mode": Law("sliding_mode", ("ωn1", "log10 φ1", "ωn2", "log10 φ2"), sliding_controller),
    "CTC-DOB": Law("ctc_dob", ("ωn1", "ζ1", "ωn2", "ζ2", "log10 T"), observer_controller),
}
# the tuned opponents' names in sweeps and tables, and the family each is tuned in
TUNED = {
    "CTC-I-best": "CTC-I",
    "SL-best": "Slotine-Li",
    "SMC-best": "sliding mode",
    "CTC-DOB-best": "CTC-DOB",
}


@dataclass(frozen=True)
class SearchedOpponent:
    """A regime's searched opponent, as shipped (``runs/paper/frontier_per_joint.json``):
    CTC with ωn and ζ per joint, its torque limit, and its and FCM-CTC's medians of peak
    |τ|₁, peak |τ|₂, Σ|Δτ|₁, Σ|Δτ|₂ and the index on the training and the judged plants."""

    regime: str
    family: str
    wn: tuple[float, float]
    zeta: tuple[float, float]
    torque_limit: tuple[float, float]
    train: tuple[float, ...]
    train_fcm: tuple[float, ...]
    judged: tuple[float, ...]
    judged_fcm: tuple[float, ...]

    @classmethod
    def from_json(cls, found: dict[str, Any]) -> SearchedOpponent:
        pair = lambda key: tuple(float(v) for v in found[key])  # noqa: E731
        return cls(
            regime=str(found["regime"]),
            family=str(found["family"]),
            wn=pair("wn"),
            zeta=pair("zeta"),
            torque_limit=pair("torque_limit"),
            train=pair("train"),
            train_fcm=pair("train_fcm"),
            judged=pair("judged"),
            judged_fcm=pair("judged_fcm"),
        )

    def controller(self) -> dict[str, Any]:
        """The sweep's ``[controllers]`` entry."""
        x = (self.wn[0], self.zeta[0], self.wn[1], self.zeta[1])
        return controller(np.array(x), self.torque_limit)

    def describe(self) -> str:
        clip = (
            f", clipped at {self.torque_limit[0]:.1f} / {self.torque_limit[1]:.1f} N·m"
            if self.family == "CTC clipped"
            else ""
        )
        return (
            f"CTC per joint at ωn = {self.wn[0]:.3g} / {self.wn[1]:.3g} rad/s, "
            f"ζ = {self.zeta[0]:.2g} / {self.zeta[1]:.2g}{clip}"
        )


def shipped_opponents(folder: Path) -> dict[str, SearchedOpponent]:
    """The searched opponents shipped in ``folder`` (``frontier_per_joint.json``) by
    regime; none where the file is absent."""
    from twolink.foundation.planted import read_json

    path = Path(folder) / "frontier_per_joint.json"
    if not path.is_file():
        return {}
    data = read_json(path)
    return {r: SearchedOpponent.from_json(o) for r, o in data["opponents"].items()}


@dataclass(frozen=True)
class TunedOpponent:
    """A tuned law of one regime, as shipped (``runs/paper/tuned_opponents.json``): its
    name, family (:data:`LAWS`), gain vector and torque limit; its and FCM-CTC's medians
    of peak |τ|₁, peak |τ|₂, Σ|Δτ|₁, Σ|Δτ|₂ and the index on the training and the judged
    plants; and ``within``, whether the effort rule admits it
    (:func:`twolink.studies.designs.effort.admissible`). One not within is the family's
    loop nearest the budget: a result, judged and shown as over FCM-CTC's effort."""

    name: str
    regime: str
    family: str
    x: tuple[float, ...]
    torque_limit: tuple[float, float]
    train: tuple[float, ...]
    train_fcm: tuple[float, ...]
    judged: tuple[float, ...]
    judged_fcm: tuple[float, ...]
    within: bool

    @classmethod
    def from_json(cls, name: str, found: dict[str, Any]) -> TunedOpponent:
        floats = lambda key: tuple(float(v) for v in found[key])  # noqa: E731
        return cls(
            name=name,
            regime=str(found["regime"]),
            family=str(found["family"]),
            x=floats("x"),
            torque_limit=floats("torque_limit"),
            train=floats("train"),
            train_fcm=floats("train_fcm"),
            judged=floats("judged"),
            judged_fcm=floats("judged_fcm"),
            within=bool(found["within"]),
        )

    def controller(self) -> dict[str, Any]:
        """The sweep's ``[controllers]`` entry."""
        return LAWS[self.family].entry(np.array(self.x), self.torque_limit)

    def describe(self) -> str:
        law = LAWS[self.family]
        budget = "within FCM-CTC's effort" if self.within else "OVER FCM-CTC's effort"
        return f"{self.family} per joint at {law.describe(self.x)} ({budget})"


def shipped_tuned(folder: Path) -> dict[str, dict[str, TunedOpponent]]:
    """The tuned opponents shipped in ``folder`` (:data:`TUNED_FILE`): by name, then by
    regime; none where the file is absent."""
    from twolink.foundation.planted import read_json

    path = Path(folder) / TUNED_FILE
    if not path.is_file():
        return {}
    data = read_json(path)
    return {
        name: {r: TunedOpponent.from_json(name, o) for r, o in by_regime.items()}
        for name, by_regime in data["opponents"].items()
    }
