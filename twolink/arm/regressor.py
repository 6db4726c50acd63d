"""The arm's linear parameterisation: ``M(q) qddr + C(q, qd) qdr + G(q) = Y(q, qd, qdr, qddr) a``.

The parameter vector ``a`` (:func:`parameters`) lumps the physical quantities of two
uniform rods and a point payload ``mp`` at the tip of link 2 (the plant's ``payload``)::

    a1 = (m1/3 + m2 + mp) l1²     [kg m²]  about joint 1: link 1, and link 2 + payload at l1
    a2 = (m2/3 + mp) l2²          [kg m²]  about joint 2: link 2 and the payload
    a3 = (m2/2 + mp) l1 l2        [kg m²]  the coupling of the two links
    a4 = (m1/2 + m2 + mp) l1 g    [N m]    link 1's gravity lever (link 2 + payload at l1)
    a5 = (m2/2 + mp) l2 g         [N m]    link 2's gravity lever

so that ``M11 = a1 + a2 + 2 a3 cos q2``, ``M12 = a2 + a3 cos q2``, ``M22 = a2``,
``h = a3 sin q2`` (:func:`twolink.arm.dynamics.coriolis_matrix`'s) and
``G = (a4 cos q1 + a5 cos(q1 + q2), a5 cos(q1 + q2))``. Every ``a_i`` grows with each
mass, length and (for g > 0) gravity, which is what :func:`parameter_box` uses.

``C`` is the Christoffel-symbol Coriolis matrix, the one with ``dM/dt - 2C`` skew, which
Slotine and Li's adaptive law needs (Slotine & Li 1987, "On the adaptive control of robot
manipulators", IJRR 6(3)). The regressor reads no parameter at all. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from twolink.arm.params import ArmParams

PARAMETER_NAMES = ("a1", "a2", "a3", "a4", "a5")
N_PARAMETERS = len(PARAMETER_NAMES)

__all__ = [
    "N_PARAMETERS",
    "PARAMETER_NAMES",
    "parameter_box",
    "parameters",
    "regressor",
    "regressor_rows",
]


def parameters(p: ArmParams, payload: float = 0.0) -> np.ndarray:
    """The parameter vector ``a`` (5,) of the arm ``p`` with a point ``payload`` [kg] at
    the tip (the module's docstring)."""
    m2 = p.m2 + payload  # link 2's mass with the payload, at l2 (not l2 / 2)
    return np.array(
        [
            (p.m1 / 3 + m2) * p.l1**2,
            (p.m2 / 3 + payload) * p.l2**2,
            (p.m2 / 2 + payload) * p.l1 * p.l2,
            (p.m1 / 2 + m2) * p.l1 * p.g,
            (p.m2 / 2 + payload) * p.l2 * p.g,
        ]
    )


def regressor_rows(
    q1, q2, w1, w2, r1, r2, b1, b2, cos=math.cos, sin=math.sin
) -> tuple[tuple, tuple]:
    """The two rows of Y at ``q``, ``qd = w``, ``qdr = r``, ``qddr = b``, entry by entry.

    Plain floats with ``math``'s cos and sin (the 1 kHz single-arm path); the same
    arithmetic on arrays with ``cos=np.cos, sin=np.sin`` (the batch laws)."""
    c2, s2 = cos(q2), sin(q2)
    c1, c12 = cos(q1), cos(q1 + q2)
    zero = 0.0 * q1
    b12 = b1 + b2
    row1 = (b1, b12, c2 * (2 * b1 + b2) - s2 * (w2 * r1 + (w1 + w2) * r2), c1, c12)
    row2 = (zero, b12, c2 * b1 + s2 * w1 * r1, zero, c12)
    return row1, row2


def regressor(q: np.ndarray, qd: np.ndarray, qdr: np.ndarray, qddr: np.ndarray) -> np.ndarray:
    """Y(q, qd, qdr, qddr), shape (..., 2, 5): ``Y a = M qddr + C qdr + G``. Arguments
    (..., 2) broadcast over leading axes."""
    args = [np.asarray(x, dtype=float) for x in (q, qd, qdr, qddr)]
    for x in args:
        if x.shape[-1:] != (2,):
            raise ValueError(f"expected a trailing axis of length 2, got shape {x.shape}")
    parts = [x[..., j] for x in args for j in (0, 1)]
    row1, row2 = regressor_rows(*parts, cos=np.cos, sin=np.sin)
    shape = np.broadcast_shapes(*(np.shape(v) for v in parts))
    rows = [np.stack([np.broadcast_to(v, shape) for v in row], -1) for row in (row1, row2)]
    return np.stack(rows, -2)


def parameter_box(
    p: ArmParams,
    factors: dict[str, Sequence[float]],
    payload: Sequence[float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """The smallest box ``(low, high)`` holding ``a`` of every arm in the declared ranges.

    ``factors``: for any of ``m1, m2, l1, l2, g``, a ``(low, high)`` factor on ``p``'s
    value (missing: 1); ``payload``: its ``(low, high)`` in kg. Each ``a_i`` is increasing
    in every quantity (g > 0), so the box's corners are the arm at all-low and all-high.
    """
    unknown = set(factors) - {"m1", "m2", "l1", "l2", "g"}
    if unknown:
        raise ValueError(f"parameter_box: unknown quantities {sorted(unknown)}")
    if p.g < 0:
        raise ValueError("parameter_box: g must be >= 0 (a_4, a_5 then grow with it)")
    lows, highs = {}, {}
    for name, (lo, hi) in factors.items():
        if not 0 < lo <= hi:
            raise ValueError(f"parameter_box: {name} factors must be 0 < low <= high")
        lows[name], highs[name] = lo, hi
    if not 0 <= payload[0] <= payload[1]:
        raise ValueError("parameter_box: payload must be 0 <= low <= high")
    return parameters(p.scaled(**lows), payload[0]), parameters(p.scaled(**highs), payload[1])
