"""Linear stability of a closed loop at its target: the discrete-time eigenvalues of one
control period, MuJoCo's plant and the controller together.

A run can sit inside the band at its last sample while an unstable mode is still too
small to see (CTC at ωn 4 rad/s on a realistic joint of 2000 N·m/rad grows at +1.4 s⁻¹,
yet its 3 s run ends 7e-4 rad from the target, still decaying). For a law with a
linearisation (no fuzzy term, no internal state) the loop's local stability is decided at
the target instead: the map Φ from the state at one control instant to the next (the
controller's torque held over the period, MuJoCo stepping the plant) is differentiated by
central differences at the target state (at rest; a flexible arm's rotors where their
springs hold it there), and its spectral radius ρ gives the growth rate
``σ = ln ρ / control_dt``: σ > 0 is unstable (:func:`closed_loop_growth`). The map is
that of the true state, so a loop behind a sensor with dynamics of its own (a velocity
estimate, a delay, an encoder's quantum) has none here: NaN.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LINEARISABLE_KINDS", "closed_loop_growth"]

# Laws that are smooth functions of the measured state with no internal state: their
# closed loop has a linearisation at the target. (Fuzzy laws switch rules at e = 0; CTC with
# integral action carries its integral; flexible-FL holds its last torque.)
LINEARISABLE_KINDS = ("ctc", "pd_gravity", "motor_pd", "composite")
_LINEARISABLE = ("ComputedTorque", "PDGravity", "MotorPD", "CompositeControl")  # their classes
EPSILON = 1e-6  # rad, rad/s: central differences; the map is smooth far beyond it


def closed_loop_growth(scenario, plant, controller, eps: float = EPSILON) -> float:
    """Largest growth rate σ [1/s] of the closed loop of ``scenario``'s plant (``plant``,
    built afresh: it is stepped here) and ``controller`` (reset and stepped here)
    linearised at its target (see the module's docstring); NaN for a law without a
    linearisation (:data:`LINEARISABLE_KINDS`).

    The reference is held at its final value (the map is taken after it has finished), so
    the result describes the loop at rest at the target, where the settling window of the
    run's outcome lies."""
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

    controller.reset()
    jac = np.empty((2 * nq, 2 * nq))
    for i in range(2 * nq):
        dx = np.zeros(2 * nq)
        dx[i] = eps
        jac[:, i] = (advance(x0 + dx) - advance(x0 - dx)) / (2 * eps)
    rho = float(np.max(np.abs(np.linalg.eigvals(jac))))
    return math.log(rho) / scenario.control_dt if rho > 0 else -math.inf
