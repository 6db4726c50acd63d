"""A searched linear opponent as shipped (``runs/paper/frontier_per_joint.json``): CTC with
ωn and ζ per joint and its torque limit, read without the search that found it
(:mod:`twolink.studies.designs.opponent_search` runs the search), so the fuzzy table
search can judge against it without importing its own searcher back."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SearchedOpponent", "controller", "shipped_opponents"]


def controller(x: np.ndarray, torque_limit: tuple[float, float]) -> dict[str, Any]:
    """The sweep's ``[controllers]`` entry of ``x = (ωn1, ζ1, ωn2, ζ2)``."""
    wn1, z1, wn2, z2 = (float(v) for v in x)
    return {
        "kind": "ctc",
        "kp": [wn1 * wn1, wn2 * wn2],
        "kd": [2 * z1 * wn1, 2 * z2 * wn2],
        "torque_limit": [float(torque_limit[0]), float(torque_limit[1])],
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
