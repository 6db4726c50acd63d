"""Linear stability of a closed loop at its rest state: the discrete-time eigenvalues of
one control period, MuJoCo's plant and the controller together.

A run can sit inside the band at its last sample while an unstable mode is still too
small to see (CTC at ωn 4 rad/s on a realistic joint of 2000 N·m/rad grows at +1.4 s⁻¹,
yet its 3 s run ends 7e-4 rad from the target, still decaying). So the loop's local
stability is decided at its rest state instead: the map Φ from the state at one control
instant to the next (the controller's torque held over the period, MuJoCo stepping the
plant) is differentiated by finite differences at the loop's rest state near the target,
and its spectral radius ρ gives the growth rate ``σ = ln ρ / control_dt``: σ > 0 is
unstable (:func:`closed_loop_growth`).

**Every law** is linearised this way (docs/metrics.md, "Linear growth"):

- The state is the plant's (links, and a flexible arm's rotors) and the controller's
  own (:attr:`internal_state`: CTC-I's integrators ``z``, flexible-FL's held torque
  ``held``, flexible-FL-I's both, ACTC's five estimates ``a_hat``, CTC-DOB's observer
  ``integral``), so a law with memory is linearised with it. A neutral mode (ACTC's
  estimates that the torque at rest does not read: a continuum of rest states) gives
  σ = 0, not the rounding's sign.
- A fuzzy law (FCM-CTC, fuzzy-CTC, fuzzy-PD) is linearised with its fuzzy term, whose
  Jacobian at the rest state the differences take along: 0 where no rule fires near the
  rest state (the designed rules near the target: the linearisation is CTC's), the rule
  table's local slope where one does.
- Where the law is not differentiable at the rest state the answer says so: where the
  one-sided differences disagree (a kink, e.g. a rule's edge) σ is the largest of the
  central and the two one-sided Jacobians' (no claim of stability that one side denies);
  where a one-sided difference does not converge as the step shrinks (a jump: the
  Mamdani relay of a reduced rule base, docs/fuzzy.md "The relay") there is no
  linearisation, NaN, and :func:`linearise` says why.

With an exact model the rest state is the target (at rest; a flexible arm's rotors where
their springs hold it there); with a model error the loop rests off it (CTC's steady-state
error), so the fixed point of Φ is found first by Newton's method from the target, and
where it is not found the answer is NaN (no linearisation claimed: a loop with no rest
state near the target may circle one, a limit cycle). The map is that of the true state,
so a loop behind a sensor with dynamics of its own (a velocity estimate, a delay, an
encoder's quantum) is not linearised here (NaN): its filter's state and its quantiser's
steps are not part of Φ (a quantiser has no derivative at all).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "Linearisation",
    "Setup",
    "closed_loop_growth",
    "internal_state",
    "judge",
    "linearise",
    "prepare",
]

EPSILON = 1e-6  # rad, rad/s: the differences' step; the smooth map is smooth far beyond it
# A one-sided difference that changes by more than this (relative to the Jacobian's
# largest entry) when its step shrinks 8-fold does not converge: a jump in the law. A
# smooth map changes by ~h |Φ''| (1e-6 of a unit curvature), a kink not at all.
JUMP_TOLERANCE = 1e-3
KINK_TOLERANCE = 1e-3  # relative: one-sided Jacobians further apart than this are a kink (a
# smooth map's are h |Φ''| apart, 1e-6 of a unit curvature)
NEWTON_STEPS = 20  # to the loop's rest state: Φ is smooth, so a few steps converge
REST_TOLERANCE = 1e-11  # rad, rad/s: |Φ(x) − x| at a rest state
# |σ| below this [1/s] is a neutral mode, read as 0: a continuum of rest states (an adaptive
# law's estimates that the torque at rest does not read) has ρ = 1 exactly, which the
# differences give to ~1e-11 (σ ~ 1e-8 either side); a true growth this slow doubles in
# 2 years.
NEUTRAL_SIGMA = 1e-5


@dataclass(frozen=True)
class Linearisation:
    """The loop linearised at its rest state: ``sigma`` [1/s] (NaN: none) and, where it
    is NaN or from a kink, ``note``: why, in words."""

    sigma: float
    note: str = ""


def internal_state(controller: Any) -> tuple[str, ...]:
    """The names of a controller's own state variables (each a tuple of floats, a pair
    for most, or None before its first call): its class's ``internal_state`` (none by
    default)."""
    return tuple(getattr(controller, "internal_state", ()))


def closed_loop_growth(
    scenario, plant, controller, eps: float = EPSILON, near: Any = None
) -> float:
    """The growth rate σ [1/s] of :func:`linearise` (NaN where it finds none)."""
    return linearise(scenario, plant, controller, eps, near).sigma


# The search evaluates the loop from points far from any rest state, where a law's
# arithmetic may overflow (w² of a runaway): expected, not printed; such a point has no
# finite answer and the search reports "no rest state" (NaN σ, the run's record).
@np.errstate(over="ignore", invalid="ignore", divide="ignore")
def linearise(scenario, plant, controller, eps: float = EPSILON, near: Any = None) -> Linearisation:
    """Largest growth rate σ [1/s] of the closed loop of ``scenario``'s plant (``plant``,
    built afresh: it is stepped here) and ``controller`` (a copy of it is reset and
    stepped here) linearised at its rest state (see the module's docstring).

    The reference is held at its final value (the map is taken after it has finished), so
    the result describes the loop at rest after the move, where the settling window of the
    run's outcome lies. The rest state is sought from the target and, failing that, from
    ``near`` (a run's last link and rotor angles, ``(q, motor_q)``): a loop with a model
    error may rest far from the target (CTC at a low ωn: a radian off)."""
    setup = prepare(scenario, controller, near, plant.flexible, plant.model.nq, plant.dt)
    if isinstance(setup, Linearisation):
        return setup
    fields, n, n_plant, nq, substeps = (
        setup.fields,
        setup.n,
        setup.n_plant,
        setup.nq,
        setup.substeps,
    )
    t_hold, controller = setup.t_hold, setup.controller
    needs_motor = setup.needs_motor

    def call(x: np.ndarray) -> tuple[float, float]:
        q, qd = tuple(x[:2]), tuple(x[nq : nq + 2])
        if needs_motor:
            return controller(t_hold, q, qd, tuple(x[2:4]), tuple(x[nq + 2 : nq + 4]))
        return controller(t_hold, q, qd)

    def advance(x: np.ndarray) -> np.ndarray:
        plant.set_state(x[:nq], x[nq:n_plant])
        i = n_plant
        for name, width in zip(fields, setup.widths, strict=True):
            setattr(controller, name, tuple(float(v) for v in x[i : i + width]))
            i += width
        tau = call(x)
        for _ in range(substeps):
            plant.step(*tau)
        own = [v for name in fields for v in getattr(controller, name)]
        return np.concatenate([plant.data.qpos, plant.data.qvel, own])

    def differences(x: np.ndarray, step: float, side: int) -> np.ndarray:
        """Central (side 0), forward (+1) or backward (−1) differences of Φ at x."""
        jac = np.empty((n, n))
        base = None if side == 0 else advance(x)
        for i in range(n):
            dx = np.zeros(n)
            dx[i] = step
            if side == 0:
                jac[:, i] = (advance(x + dx) - advance(x - dx)) / (2 * step)
            else:
                jac[:, i] = (advance(x + side * dx) - base) / (side * step)
        return jac

    def rest_state(x: np.ndarray) -> np.ndarray | None:
        for _ in range(NEWTON_STEPS):  # Φ(x) = x
            residual = advance(x) - x
            if not np.all(np.isfinite(residual)):
                return None
            if np.abs(residual).max() < REST_TOLERANCE:
                return x
            try:
                x = x - np.linalg.solve(differences(x, eps, 0) - np.eye(n), residual)
            except np.linalg.LinAlgError:
                return None
        return None

    starts = setup.starts
    x = next((r for r in map(rest_state, starts) if r is not None), None)
    if x is None:
        return Linearisation(math.nan, "no rest state found near the target")
    central = differences(x, eps, 0)
    one_sided = {s: differences(x, eps, s) for s in (1, -1)}
    finer = {s: differences(x, eps / 8, s) for s in (1, -1)}
    return judge(central, one_sided, finer, scenario.control_dt)


def judge(
    central: np.ndarray, one_sided: dict[int, np.ndarray], finer: dict[int, np.ndarray], dt: float
) -> Linearisation:
    """The answer from the differences at the rest state: the central Jacobian, the
    one-sided ones (``{1: forward, -1: backward}``) at the same step and at an 8-fold
    smaller one (``finer``); ``dt`` the control period. A jump (a one-sided difference
    that does not converge) gives NaN, a kink the largest σ of all three."""
    scale = max(1.0, float(np.abs(central).max()))
    for side, jac in one_sided.items():
        if np.abs(finer[side] - jac).max() > JUMP_TOLERANCE * scale:
            return Linearisation(
                math.nan, "the law jumps at its rest state (a relay): no linearisation"
            )
    note = ""
    jacs = [central]
    if max(np.abs(j - central).max() for j in one_sided.values()) > KINK_TOLERANCE * scale:
        note = "a kink at the rest state: the largest σ of its one-sided linearisations"
        jacs += list(one_sided.values())
    rho = max(float(np.max(np.abs(np.linalg.eigvals(j)))) for j in jacs)
    sigma = math.log(rho) / dt if rho > 0 else -math.inf
    if abs(sigma) < NEUTRAL_SIGMA:
        sigma = 0.0
        note = note or "a neutral mode (a continuum of rest states): σ = 0"
    return Linearisation(sigma, note)


@dataclass(frozen=True)
class Setup:
    """What a linearisation of one loop starts from (:func:`prepare`)."""

    controller: Any  # a reset copy of the caller's
    fields: tuple[str, ...]  # its own state's names (:func:`internal_state`)
    needs_motor: bool
    nq: int  # the plant's positions: 2 rigid, 4 flexible (links, then rotors)
    n_plant: int  # 2 nq
    n: int  # the state: the plant's and the controller's own, 2 floats per field
    substeps: int  # plant steps per control period
    t_hold: float  # the instant the controller is called at: the reference at rest
    starts: tuple[np.ndarray, ...]  # where Newton's search starts: the target, then near
    widths: tuple[int, ...] = ()  # floats per field (2: a pair; an adaptive estimate: more)


def prepare(
    scenario, controller, near: Any, flexible: bool, nq: int, dt: float
) -> Setup | Linearisation:
    """The start of :func:`linearise` for the plant of ``scenario`` (``flexible``, its
    ``nq`` positions, its timestep ``dt``), or the answer where there is nothing to
    linearise (NaN and why)."""
    from twolink.arm.plant import holding_motor_q
    from twolink.simulation.outcome import reference_end

    if not scenario.sensor.ideal:
        return Linearisation(math.nan, "a sensor with dynamics of its own: not linearised")
    t_hold = reference_end(scenario.reference)
    if not math.isfinite(t_hold):
        return Linearisation(math.nan, "a reference that never rests: no rest state")
    t_hold += 1.0
    fields = internal_state(controller)
    controller = copy.copy(controller)  # the caller's keeps its state; ours is reset
    target = np.array(scenario.reference.final, dtype=float)
    needs_motor = bool(getattr(controller, "needs_motor", False))
    n_plant = 2 * nq

    def start(q: Any, motor_q: Any, own: np.ndarray) -> np.ndarray:
        x = np.zeros(n_plant + len(own))
        x[:2] = q
        if flexible and len(motor_q):
            x[2:4] = motor_q
        x[n_plant:] = own
        return x

    controller.reset()
    motor0 = ()
    if flexible:
        motor0 = holding_motor_q(
            scenario.plant_params, scenario.plant_joints, target, scenario.plant.payload
        )
    # the controller's own state at the target: what one call there leaves (a held
    # torque: the springs' holding torque; an integrator: empty)
    own0 = np.zeros(2 * len(fields))
    if fields:
        x0 = start(target, motor0, own0)
        q, qd = tuple(x0[:2]), tuple(x0[nq : nq + 2])
        if needs_motor:
            controller(t_hold, q, qd, tuple(x0[2:4]), tuple(x0[nq + 2 : nq + 4]))
        else:
            controller(t_hold, q, qd)
        own0 = np.array([v for name in fields for v in getattr(controller, name)], dtype=float)
    widths = tuple(len(getattr(controller, name)) for name in fields)
    n = n_plant + len(own0)
    starts = [start(target, motor0, own0)]
    if near is not None:
        starts.append(start(near[0], near[1], own0))
    substeps = round(scenario.control_dt / dt)
    return Setup(
        controller, fields, needs_motor, nq, n_plant, n, substeps, t_hold, tuple(starts), widths
    )
