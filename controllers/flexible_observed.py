"""A flexible-joint law a lab can run: feedback linearisation with integral action, fed by a
Kalman filter on the link and motor encoders.

:class:`~controllers.flexible_robust.IntegralFlexibleFeedbackLinearisation` needs the
links' and rotors' angles *and rates*; behind encoders the rates must be estimated, and
the estimates a drive gives (the differenced angle, or that difference through a low-pass)
either chatter (a count per period is 0.048 rad/s of rate noise, which the law's fast
pair multiplies by J (Kd + 2 ζp ωp), about 120 N m s/rad on a harmonic-drive joint) or
lag (a 50 Hz filter's 5 ms is a quarter period of the joints' spring mode, where the
law's damping turns into drive). ``docs/control.md``, "A law a lab can run", has the
measured figures.

:class:`SpringKalmanFilter` estimates the full state from the encoder *angles* alone (the
sensor's rates are ignored): a constant-gain (steady-state) extended Kalman filter of the
flexible-joint arm, the estimator Lightcap and Banks run in the loop of such an arm (C. A.
Lightcap and S. A. Banks, "An extended Kalman filter for real-time estimation and control
of a rigid-link flexible-joint manipulator", IEEE Trans. Control Syst. Technol. 18(1),
2010, 91-103), here on the link and motor encoder angles and with the gain of the
steady-state filter (D. Simon, *Optimal State Estimation*, Wiley 2006, the steady-state
Kalman filter), so that a step costs a few multiply-adds and no Riccati update. Per joint
i the filter's states are the link angle and rate, the rotor angle and rate, and one
acceleration disturbance on each: random walks that take up the model error, as the
extended high-gain observer of Freidovich and Khalil estimates a feedback-linearised
loop's lumped uncertainty ("Performance recovery of feedback-linearization-based
designs", IEEE Trans. Autom. Control 53(10), 2008):

    q̈ = μ (K δ + D δ̇) + r(x̂) + dq,     J θ̈ = τ − K δ − D δ̇ + J dθ,     δ = θ − q,

μ = (M̂⁻¹)ii at θ2 = 0, r the rest of the model's link acceleration (gravity, Coriolis,
the other joint's spring through M̂⁻¹, the pose's inertia), evaluated at the estimate and
held over the period. The spring's linear part is discretised exactly (``scipy.linalg.expm``,
zero-order hold, the applied torque held as the plant holds it), so the fast spring mode
(ωf·dt up to 0.5) is predicted without an integration error; the measurement update is
the steady-state Kalman gain of that linear model (``scipy.linalg.solve_discrete_are``)
with the encoder's quantisation noise, variance q²/12 for a quantum q, and the process
noise of :data:`DEFAULT_PROCESS_NOISE` (its rule in ``docs/control.md``).

:class:`ObservedIntegralFlexibleFeedbackLinearisation` is the integral law fed by that
filter: the sensor it needs is an encoder on each link and each motor, read at the
control rate (the studies' 17 bits a turn); its integral acts on the measured link angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twolink.arm.dynamics import terms
from twolink.arm.params import Flexibility
from twolink.controllers.flexible_robust import IntegralFlexibleFeedbackLinearisation

__all__ = [
    "DEFAULT_PROCESS_NOISE",
    "DEFAULT_RESOLUTION",
    "ObservedIntegralFlexibleFeedbackLinearisation",
    "SpringKalmanFilter",
]

# Spectral densities of the filter's process noise: white acceleration on each link and
# rotor [(rad/s²)² s], and the random walk of each acceleration disturbance [(rad/s³)² s].
# The rule and the evidence: docs/control.md, "A law a lab can run".
DEFAULT_PROCESS_NOISE = (1.0e-5, 1.0e-3)
# The encoders it assumes: 17 bits a turn, the studies' (twolink.simulation.sensor's
# ENCODER_BITS; this layer does not import the simulation's).
DEFAULT_RESOLUTION = 2.0 * math.pi / 2**17


def _joint_model(k: float, d: float, j: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """The continuous model of one joint: states (q, q̇, dq, θ, θ̇, dθ), inputs (τ, r)."""
    a = np.zeros((6, 6))
    a[0, 1] = 1.0
    a[1] = [-mu * k, -mu * d, 1.0, mu * k, mu * d, 0.0]
    a[3, 4] = 1.0
    a[4] = [k / j, d / j, 0.0, -k / j, -d / j, 1.0]
    b = np.zeros((6, 2))
    b[4, 0] = 1.0 / j  # the torque on the rotor
    b[1, 1] = 1.0  # the rest of the link's acceleration, r
    return a, b


def _discretise(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation: ``expm`` of the augmented matrix."""
    from scipy.linalg import expm

    n, m = b.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = a, b
    e = expm(big * dt)
    return e[:n, :n], e[:n, n:]


def _process_noise(a: np.ndarray, q: np.ndarray, dt: float) -> np.ndarray:
    """Van Loan's discretisation of a continuous white process noise of density ``q``."""
    from scipy.linalg import expm

    n = a.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n], big[:n, n:], big[n:, n:] = -a, q, a.T
    e = expm(big * dt)
    phi_t = e[n:, n:]
    return phi_t.T @ e[:n, n:]


def _steady_gain(phi: np.ndarray, qd: np.ndarray, r: float) -> np.ndarray:
    """The steady-state Kalman gain (6 x 2) of a joint measured at q and θ."""
    from scipy.linalg import solve_discrete_are

    c = np.zeros((2, 6))
    c[0, 0] = c[1, 3] = 1.0
    rm = np.eye(2) * r
    p = solve_discrete_are(phi.T, c.T, qd, rm)  # the predicted (a priori) covariance
    return p @ c.T @ np.linalg.inv(c @ p @ c.T + rm)


class SpringKalmanFilter:
    """The state of a flexible-joint arm from its link and motor encoders (module
    docstring). ``update(q, motor_q, tau)`` takes the angles measured now and the torque
    applied over the period that ended now, and returns the estimate
    ``(q, qd, motor_q, motor_qd)`` as pairs of floats."""

    def __init__(
        self,
        model,
        joints: Flexibility,
        control_dt: float,
        resolution_rad: float,
        process_noise: tuple[float, float] = DEFAULT_PROCESS_NOISE,
    ) -> None:
        m11, m12, m22, _, _ = terms(model, 0.0, 0.0, 0.0, 0.0)
        det = m11 * m22 - m12 * m12
        self.mu = (m22 / det, m11 / det)
        self.model, self.joints, self.dt = model, joints, control_dt
        r = resolution_rad * resolution_rad / 12.0  # a uniform quantisation error's variance
        acc, jerk = process_noise
        qc = np.diag([0.0, acc, jerk, 0.0, acc, jerk])
        self.phi, self.gamma, self.gain = [], [], []
        for i in (0, 1):
            a, b = _joint_model(joints.k[i], joints.d[i], joints.j[i], self.mu[i])
            phi, gamma = _discretise(a, b, control_dt)
            self.phi.append(phi)
            self.gamma.append(gamma)
            self.gain.append(_steady_gain(phi, _process_noise(a, qc, control_dt), r))
        self.x: np.ndarray | None = None  # (2, 6): per joint (q, q̇, dq, θ, θ̇, dθ)
        self.r = np.zeros(2)

    def reset(self) -> None:
        self.x = None

    def _rest(self) -> np.ndarray:
        """r per joint at the estimate: the model's link acceleration less μ (K δ + D δ̇)."""
        (q1, w1, _, t1, n1, _), (q2, w2, _, t2, n2, _) = self.x.tolist()
        jt = self.joints
        u1 = jt.k[0] * (t1 - q1) + jt.d[0] * (n1 - w1)
        u2 = jt.k[1] * (t2 - q2) + jt.d[1] * (n2 - w2)
        m11, m12, m22, b1, b2 = terms(self.model, q1, q2, w1, w2)
        det = m11 * m22 - m12 * m12
        f1, f2 = u1 - b1, u2 - b2
        a1 = (m22 * f1 - m12 * f2) / det
        a2 = (m11 * f2 - m12 * f1) / det
        return np.array([a1 - self.mu[0] * u1, a2 - self.mu[1] * u2])

    def update(self, q, motor_q, tau):
        y = np.array([[q[0], motor_q[0]], [q[1], motor_q[1]]])
        if self.x is None:  # the first reading: at rest there, no disturbance known
            self.x = np.zeros((2, 6))
            self.x[:, 0], self.x[:, 3] = y[:, 0], y[:, 1]
            self.r = self._rest()
        else:
            for i in (0, 1):  # predict over the period that ended, then correct
                x = self.phi[i] @ self.x[i] + self.gamma[i] @ np.array([tau[i], self.r[i]])
                self.x[i] = x + self.gain[i] @ (y[i] - x[[0, 3]])
            self.r = self._rest()
        (q1, w1, _, t1, n1, _), (q2, w2, _, t2, n2, _) = self.x.tolist()
        return (q1, q2), (w1, w2), (t1, t2), (n1, n2)


@dataclass
class ObservedIntegralFlexibleFeedbackLinearisation(IntegralFlexibleFeedbackLinearisation):
    """:class:`~controllers.flexible_robust.IntegralFlexibleFeedbackLinearisation` on the
    state a :class:`SpringKalmanFilter` estimates from the link and motor encoder angles.

    It reads only the angles (``q`` and ``motor_q``); the rates a sensor passes are
    ignored. The filter assumes encoders of ``resolution_rad`` (default 17 bits a turn,
    the studies' encoder) read every ``control_dt``, and the torque it commanded as the
    one applied (saturated: it clips its own torque to ``torque_limit``).

    Parameters
    ----------
    resolution_rad : float
        The encoders' quantum [rad], > 0: the filter's measurement noise, q²/12.
    process_noise : (float, float)
        The filter's process noise (:data:`DEFAULT_PROCESS_NOISE`).
    (others as :class:`~controllers.flexible_robust.IntegralFlexibleFeedbackLinearisation`)
    """

    resolution_rad: float = DEFAULT_RESOLUTION
    process_noise: tuple[float, float] = DEFAULT_PROCESS_NOISE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution_rad) and self.resolution_rad > 0):
            raise ValueError(f"resolution_rad must be > 0, got {self.resolution_rad!r}")
        noise = tuple(float(v) for v in self.process_noise)
        if len(noise) != 2 or not all(math.isfinite(v) and v > 0 for v in noise):
            raise ValueError(f"process_noise must be two numbers > 0, got {self.process_noise!r}")
        self.process_noise = noise  # type: ignore[assignment]
        super().__post_init__()
        self.filter = SpringKalmanFilter(
            self.model, self.joints, self.control_dt, self.resolution_rad, noise
        )

    def reset(self) -> None:
        super().reset()
        if hasattr(self, "filter"):
            self.filter.reset()

    def __call__(self, t, q, qd, motor_q, motor_qd) -> tuple[float, float]:
        held = self.held if self.held is not None else (0.0, 0.0)
        q_hat, qd_hat, th_hat, thd_hat = self.filter.update(q, motor_q, held)
        if self.held is None:  # at rest, the springs' torque (the parent's first call)
            qd_hat, thd_hat = (0.0, 0.0), (0.0, 0.0)
        self._measured = q
        return super().__call__(t, q_hat, qd_hat, th_hat, thd_hat)

    def _after(self, t, q, raw, tau) -> None:
        # the integral acts on the encoder's link angle, not the estimate: its rest state
        # is the target within the encoder's half count, whatever the filter's bias
        super()._after(t, self._measured, raw, tau)
