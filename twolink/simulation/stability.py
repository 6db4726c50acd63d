"""Linear stability of a closed loop at its target: the discrete-time eigenvalues of one
control period, MuJoCo's plant and the controller together.

A run can sit inside the band at its last sample while an unstable mode is still too
small to see (CTC at ωn 4 rad/s on a realistic joint of 2000 N·m/rad grows at +1.4 s⁻¹,
yet its 3 s run ends 7e-4 rad from the target, still decaying). For a law with a
linearisation (no fuzzy term, no internal state) the loop's local stability is decided at
the target instead: the map Φ from the state at one control instant to the next (the
controller's torque held over the period, MuJoCo stepping the plant) is differentiated by
central differences at the loop's rest state near the target, and its spectral radius ρ
gives the growth rate ``σ = ln ρ / control_dt``: σ > 0 is unstable
(:func:`closed_loop_growth`). With an exact model that rest state is the target (at rest;
a flexible arm's rotors where their springs hold it there); with a model error the loop
rests off it (CTC's steady-state error), so the fixed point of Φ is found first by Newton's
method from the target, and where it is not found the answer is NaN (no linearisation
claimed). The map is that of the true state, so a loop behind a sensor with dynamics of
its own (a velocity estimate, a delay, an encoder's quantum) has none here: NaN.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["LINEARISABLE_KINDS", "closed_loop_growth"]

# Laws that are smooth functions of the measured state with no internal state: their
# closed loop has a linearisation at the target. (Fuzzy laws switch rules at e = 0; CTC with
# integral action carries its integral; flexible-FL holds its last torque.)
LINEARISABLE_KINDS = ("ctc", "pd_gravity", "motor_pd", "composite")
_LINEARISABLE = ("ComputedTorque", "PDGravity", "MotorPD", "CompositeControl")  # their classes
EPSILON = 1e-6  # rad, rad/s: central differences; the map is smooth far beyond it
NEWTON_STEPS = 20  # to the loop's rest state: Φ is smooth, so a few steps converge
REST_TOLERANCE = 1e-11  # rad, rad/s: |Φ(x) − x| at a rest state


def closed_loop_growth(
    scenario, plant, controller, eps: float = EPSILON, near: Any = None
) -> float:
    """Largest growth rate σ [1/s] of the closed loop of ``scenario``'s plant (``plant``,
    built afresh: it is stepped here) and ``controller`` (reset and stepped here)
    linearised at its rest state (see the module's docstring); NaN for a law without a
    linearisation (:data:`LINEARISABLE_KINDS`) or where no rest state is found.

    The reference is held at its final value (the map is taken after it has finished), so
    the result describes the loop at rest after the move, where the settling window of the
    run's outcome lies. The rest state is sought from the target and, failing that, from
    ``near`` (a run's last link and rotor angles, ``(q, motor_q)``): a loop with a model
    error may rest far from the target (CTC at a low ωn: a radian off)."""
    from twolink.arm.plant import holding_motor_q
    from twolink.simulation.outcome import reference_end

    if type(controller).__name__ not in _LINEARISABLE or not scenario.sensor.ideal:
        return math.nan
    t_hold = reference_end(scenario.reference)
    if not math.isfinite(t_hold):
        return math.nan
    t_hold += 1.0
    target = np.array(scenario.reference.final, dtype=float)
    flexible = plant.flexible
    needs_motor = bool(getattr(controller, "needs_motor", False))
    substeps = round(scenario.control_dt / plant.dt)
    nq = plant.model.nq
    x0 = np.zeros(2 * nq)
    x0[:2] = target
    if flexible:
        x0[2:4] = holding_motor_q(
            scenario.plant_params, scenario.plant_joints, target, scenario.plant.payload
        )

    def advance(x: np.ndarray) -> np.ndarray:
        plant.set_state(x[:nq], x[nq:])
        q, qd = tuple(x[:2]), tuple(x[nq : nq + 2])
        if needs_motor:
            tau = controller(t_hold, q, qd, tuple(x[2:4]), tuple(x[nq + 2 : nq + 4]))
        else:
            tau = controller(t_hold, q, qd)
        for _ in range(substeps):
            plant.step(*tau)
        return np.concatenate([plant.data.qpos, plant.data.qvel])

    def jacobian(x: np.ndarray) -> np.ndarray:
        jac = np.empty((2 * nq, 2 * nq))
        for i in range(2 * nq):
            dx = np.zeros(2 * nq)
            dx[i] = eps
            jac[:, i] = (advance(x + dx) - advance(x - dx)) / (2 * eps)
        return jac

    def rest_state(x: np.ndarray) -> np.ndarray | None:
        for _ in range(NEWTON_STEPS):  # Φ(x) = x
            residual = advance(x) - x
            if not np.all(np.isfinite(residual)):
                return None
            if np.abs(residual).max() < REST_TOLERANCE:
                return x
            try:
                x = x - np.linalg.solve(jacobian(x) - np.eye(2 * nq), residual)
            except np.linalg.LinAlgError:
                return None
        return None

    controller.reset()
    starts = [x0]
    if near is not None:
        q, motor_q = near
        x1 = np.zeros(2 * nq)
        x1[:2] = q
        if flexible and len(motor_q):
            x1[2:4] = motor_q
        starts.append(x1)
    x = next((r for r in map(rest_state, starts) if r is not None), None)
    if x is None:
        return math.nan
    jac = jacobian(x)
    rho = float(np.max(np.abs(np.linalg.eigvals(jac))))
    return math.log(rho) / scenario.control_dt if rho > 0 else -math.inf
