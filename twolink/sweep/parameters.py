"""A sweep's drawn parameters: their names and domains, their distributions, and the
``[parameters]`` entries of a sweep file read into :class:`Parameter` (docs/sweeps.md,
"Parameters" and "Distributions")."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.simulation.config import TomlTable
from twolink.sweep.friction_draws import FRICTION_NAMES

__all__ = ["DISTRIBUTIONS", "NOT_DRAWN", "PARAMETERS", "Parameter", "domain_problem"]

DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice", "grid", "listed")
# Not drawn: a grid point from the sample index, a listed value at it (sample i, values[i])
NOT_DRAWN = ("grid", "listed")
# name -> domain of the drawn value: "positive" (> 0), "nonnegative" (>= 0),
# "at_least_one" (>= 1: a ratio such as breakaway / Coulomb) or "any".
PARAMETERS: Mapping[str, str] = {
    "m1": "positive",
    "m2": "positive",
    "mass": "positive",  # a factor on both masses (times m1's and m2's own)
    "l1": "positive",
    "l2": "positive",
    "g": "any",
    "payload": "nonnegative",
    **{f"{p}{j}": dom for p, dom in zip("kdj", ("positive", "nonnegative", "positive"), strict=True)
       for j in ("", "1", "2")},
    "zeta_joint": "nonnegative",  # the joints' damping ratio: d = 2 zeta sqrt(k j)
    "k_scale": "positive",  # plant.scale.k: the plant's stiffness / the controllers' model
    "j_scale": "positive",  # plant.scale.j: the same for the rotor inertia
    "ei_scale": "positive",  # plant.scale.ei: the bending links' E I / the laws' model
    "wn": "positive",  # the controllers' bandwidth [rad/s], zeta = 1
    **FRICTION_NAMES,  # joint friction over the base's [plant.friction]
}  # fmt: skip
TRUNCATION_TRIES = 10_000
# A truncated normal must keep this share of the draws: with 10,000 tries per value, no
# draw in the truncation is then a chance of (1 - 0.01)**10_000 ~ 1e-44.
MIN_TRUNCATION_MASS = 0.01


@dataclass(frozen=True)
class Parameter:
    """One swept plant parameter and its distribution.

    Attributes
    ----------
    name : str
        A key of :data:`PARAMETERS`.
    dist : str
        One of :data:`DISTRIBUTIONS`.
    low, high : float or None
        Bounds (uniform, loguniform; optional truncation of normal).
    mean, std : float or None
        Normal distribution.
    values, weights : tuple of float
        Choice and grid points, or the listed values (sample i takes ``values[i]``);
        optional choice weights.
    """

    name: str
    dist: str
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = None
    values: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()

    def draw(self, rng: np.random.Generator) -> float:
        """Draw one value (not for "grid" nor "listed", whose values come from the sample
        index: :meth:`twolink.sweep.plan.SweepPlan.draw`)."""
        if self.dist == "uniform":
            return float(rng.uniform(self.low, self.high))
        if self.dist == "loguniform":
            return float(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        if self.dist == "choice":
            p = None
            if self.weights:
                w = np.asarray(self.weights)
                p = w / w.sum()
            return float(self.values[int(rng.choice(len(self.values), p=p))])
        if self.dist == "normal":
            lo = -math.inf if self.low is None else self.low
            hi = math.inf if self.high is None else self.high
            for _ in range(TRUNCATION_TRIES):
                x = float(rng.normal(self.mean, self.std))
                if lo <= x <= hi:
                    return x
            raise ValueError(
                f"{self.name}: no draw of normal({self.mean}, {self.std}) fell in "
                f"[{lo}, {hi}] in {TRUNCATION_TRIES} tries"
            )
        raise ValueError(f"{self.name}: {self.dist!r} values are not drawn")


def _check_value(t: TomlTable, key: str, value: Any, domain: str) -> float:
    value = t.as_float(key, value)
    if not math.isfinite(value):
        t.fail(key, f"must be finite, got {value!r}")
    if problem := domain_problem(t.where.split(".")[-1], domain, value):
        t.fail(key, problem)
    return float(value)


def domain_problem(name: str, domain: str, value: float) -> str | None:
    """Why the finite ``value`` lies outside ``domain`` (a value of :data:`PARAMETERS`)
    for parameter ``name``; None where it lies within."""
    bound = {"positive": "> 0", "nonnegative": ">= 0", "at_least_one": ">= 1"}.get(domain)
    inside = {
        "positive": value > 0,
        "nonnegative": value >= 0,
        "at_least_one": value >= 1,
    }.get(domain, True)
    return None if inside else f"must be {bound} for parameter {name!r}, got {value!r}"


def _normal_mass(mean: float, std: float, low: float | None, high: float | None) -> float:
    """The probability that a draw of normal(mean, std) lies in [low, high]."""
    if std == 0:
        return 1.0  # every draw is the mean, which lies within the truncation
    lo = -math.inf if low is None else (low - mean) / std
    hi = math.inf if high is None else (high - mean) / std
    return 0.5 * (math.erf(hi / math.sqrt(2)) - math.erf(lo / math.sqrt(2)))


def _number_list(t: TomlTable, key: str, domain: str) -> tuple[float, ...]:
    values = t.raw(key)
    if values is None:
        t.fail(key, "missing: a list of numbers")
    if not isinstance(values, list) or not values:
        t.fail(key, f"must be a non-empty list of numbers, got {values!r}")
    return tuple(_check_value(t, key, v, domain) for v in values)


def _parameter(name: str, data: Any, file: str) -> Parameter:
    t = TomlTable(data, f"parameters.{name}", file)
    domain = PARAMETERS[name]
    dist = t.raw("dist")
    if dist is None:
        t.fail("dist", f"missing: one of {list(DISTRIBUTIONS)}")
    if dist not in DISTRIBUTIONS:
        t.fail("dist", f"must be one of {list(DISTRIBUTIONS)}, got {dist!r}")
    known = {
        "uniform": ("low", "high"),
        "loguniform": ("low", "high"),
        "normal": ("mean", "std", "low", "high"),
        "choice": ("values", "weights"),
        "grid": ("values",),
        "listed": ("values",),
    }[dist]
    for key in t.data:  # a misspelt key first: it explains a "missing" one
        if key not in ("dist", *known):
            t.fail(key, f"unknown key for {dist} (known: {['dist', *known]})")

    def need(key: str, dom: str = domain) -> float:
        if key not in t.data:
            t.fail(key, f"missing: {dist} needs it")
        return _check_value(t, key, t.raw(key), dom)

    if dist in ("uniform", "loguniform"):
        # a log needs > 0; a domain of its own (>= 1) stays
        dom = "positive" if dist == "loguniform" and domain != "at_least_one" else domain
        low, high = need("low", dom), need("high", dom)
        if low > high:
            t.fail("high", f"must be >= low ({low}): the distribution is empty, got {high}")
        p = Parameter(name, dist, low=low, high=high)
    elif dist == "normal":
        mean = need("mean", "any")
        std = need("std", "nonnegative")
        low = need("low") if "low" in t.data else None
        high = need("high") if "high" in t.data else None
        if low is None and domain != "any":
            t.fail("low", f"missing: a normal draw of {name!r} can be negative; truncate it")
        if low is not None and high is not None and low > high:
            t.fail("high", f"must be >= low ({low}): the distribution is empty, got {high}")
        if (low is not None and mean < low) or (high is not None and mean > high):
            t.fail("mean", f"must lie within the truncation [{low}, {high}], got {mean}")
        mass = _normal_mass(mean, std, low, high)
        if mass < MIN_TRUNCATION_MASS:
            t.fail(
                "high" if high is not None else "low",
                f"the truncation [{low}, {high}] keeps {mass:.3g} of normal({mean}, {std})'s "
                f"draws; at least {MIN_TRUNCATION_MASS:g} is needed (values are drawn by "
                "rejection): widen [low, high] or raise std",
            )
        p = Parameter(name, dist, low=low, high=high, mean=mean, std=std)
    else:
        values = _number_list(t, "values", domain)
        weights: tuple[float, ...] = ()
        if dist == "choice" and "weights" in t.data:
            weights = _number_list(t, "weights", "nonnegative")
            if len(weights) != len(values):
                t.fail("weights", f"must have {len(values)} entries (one per value)")
            if sum(weights) <= 0:
                t.fail("weights", "must not all be zero")
        p = Parameter(name, dist, values=values, weights=weights)
    t.done()
    return p
