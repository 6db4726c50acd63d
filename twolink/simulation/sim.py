"""The closed loop: a controller against a MuJoCo plant, and the recorded trajectory.

The controller runs at a fixed rate with zero-order hold: it is called every
``control_dt`` with the measured link state, and its torques are held over the
physics substeps until the next call. A run stops early, keeping what it computed,
when the state or torque becomes non-finite or leaves sane bounds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twolink.arm.plant import Plant, warning_notes
from twolink.controllers.base import Controller
from twolink.foundation import steplog
from twolink.foundation.io import atomic_path
from twolink.simulation.sensor import Sensor

if TYPE_CHECKING:
    import pandas as pd

STATUS_OK = "ok"
STATUS_DIVERGED = "diverged"


@dataclass(frozen=True)
class Bounds:
    """What counts as a runaway: beyond these the run stops as diverged."""

    angle: float = 100.0  # rad: ~16 turns, far past any reference
    rate: float = 1e3  # rad/s
    torque: float = 1e6  # N m


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A recorded closed-loop run, sampled at the control instants.

    Sample k is the state measured at ``t[k]`` and the torque the controller chose
    then. Arrays of pairs have shape (N, 2), columns joint 1 and joint 2.

    Attributes
    ----------
    t : (N,) times [s]
    q, qd : link angles [rad] and rates [rad/s]
    q_ref, qd_ref, qdd_ref : reference position, velocity, acceleration
    tau : torques [N m]
    motor_q : rotor angles of the flexible arm (N, 2), or an empty (0, 2) array
    status : "ok" or "diverged"
    message : why a run stopped early ("" if it did not)
    warnings : MuJoCo's warnings during the run, in words (an unstable step; empty if none)
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    qdd_ref: np.ndarray
    tau: np.ndarray
    motor_q: np.ndarray
    status: str = STATUS_OK
    message: str = ""
    warnings: tuple[str, ...] = ()

    @property
    def e(self) -> np.ndarray:
        """Tracking error q_ref - q."""
        return self.q_ref - self.q

    @property
    def de(self) -> np.ndarray:
        """Error rate qd_ref - qd."""
        return self.qd_ref - self.qd

    @property
    def twist(self) -> np.ndarray:
        """Spring twist φ − θ of the flexible arm (rotor minus link angle), (N, 2); an
        empty (0, 2) array for the rigid arm."""
        return self.motor_q - self.q if len(self.motor_q) else np.empty((0, 2))

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK

    def save(self, path: str | Path) -> None:
        """Write to ``.npz`` atomically."""
        arrays = {f.name: getattr(self, f.name) for f in fields(self)}
        if not self.warnings:  # a run without MuJoCo's warnings: the file as before
            del arrays["warnings"]
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        with np.load(path) as data:
            kwargs = {f.name: data[f.name] for f in fields(cls) if f.name in data}
        kwargs["status"] = str(kwargs["status"])
        kwargs["warnings"] = tuple(str(w) for w in kwargs.get("warnings", ()))
        kwargs["message"] = str(kwargs["message"])
        return cls(**kwargs)

    def to_dataframe(self) -> pd.DataFrame:
        """Every signal as a column, indexed by time ``time_s``: ``joint1_angle_rad``,
        ``joint1_reference_rad``, ``joint1_error_rad``, ``joint1_torque_Nm``, ... (the
        names of :func:`twolink.tracing.read_recording`'s columns and of the recordings'
        entities ``joint1/angle``, ...: docs/tracing.md, "One naming"); the flexible arm's
        rotor angles as ``joint1_motor_angle_rad``, ...

        Examples
        --------
        >>> df = trajectory.to_dataframe()                                # doctest: +SKIP
        >>> df[["joint1_angle_rad", "joint1_reference_rad"]].plot()       # doctest: +SKIP
        """
        import pandas as pd

        from twolink.simulation.vocabulary import TIME_COLUMN, signal_column

        signals = {
            "angle": self.q,
            "reference": self.q_ref,
            "rate": self.qd,
            "reference_rate": self.qd_ref,
            "error": self.e,
            "error_rate": self.de,
            "torque": self.tau,
        }
        if len(self.motor_q):
            signals["motor_angle"] = self.motor_q
        columns = {
            signal_column(j, leaf): values[:, j - 1]
            for j in (1, 2)
            for leaf, values in signals.items()
        }
        return pd.DataFrame(columns, index=pd.Index(self.t, name=TIME_COLUMN))

    def equals(self, other: Trajectory) -> bool:
        """Bit-for-bit equality of every array and the status."""
        return all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self)
        )


def state_message(t: float, q1: float, q2: float, w1: float, w2: float) -> str:
    return f"state out of bounds at t={t:.4f} s: q=({q1:.4g}, {q2:.4g}), qd=({w1:.4g}, {w2:.4g})"


def torque_message(t: float, tau1: float, tau2: float) -> str:
    return f"torque out of bounds at t={t:.4f} s: tau=({tau1:.4g}, {tau2:.4g})"


def control_steps(duration: float, control_dt: float, timestep: float) -> tuple[int, int]:
    """(control periods in ``duration``, physics substeps per period), or ValueError."""
    substeps = round(control_dt / timestep)
    if substeps < 1 or not math.isclose(substeps * timestep, control_dt, rel_tol=1e-9):
        raise ValueError(
            f"control_dt {control_dt} must be a whole multiple of the timestep {timestep}"
        )
    if not duration > 0:
        raise ValueError(f"duration must be > 0, got {duration}")
    return round(duration / control_dt), substeps


def simulate(
    plant: Plant,
    controller: Controller,
    duration: float,
    control_dt: float = 1e-3,
    q0: tuple[float, float] = (0.0, 0.0),
    qd0: tuple[float, float] = (0.0, 0.0),
    bounds: Bounds = Bounds(),
    noise: np.ndarray | None = None,
    motor_q0: tuple[float, float] | None = None,
    sensor: Sensor | None = None,
) -> Trajectory:
    """Run ``controller`` against ``plant`` for ``duration`` seconds.

    Parameters
    ----------
    plant : Plant
        The MuJoCo plant; it is reset to (q0, qd0), its rotors at ``motor_q0``.
    controller : Controller
        Called every ``control_dt`` seconds; its torques are held in between. One whose
        ``needs_motor`` is true is called ``controller(t, q, qd, motor_q, motor_qd)`` with
        the rotor angles and rates too (flexible plants only; noise is on link angles).
    duration, control_dt : float
        Length of the run and control period [s]; ``control_dt`` must be a whole
        number of physics timesteps.
    q0, qd0 : pair of float
        Initial link angles and rates.
    bounds : Bounds
        Past these (or at a non-finite value) the run stops with status "diverged".
    noise : ndarray (N + 1, 2), optional
        Measurement noise added to the angles the controller sees (not to the
        recorded state), one row per control instant.
    motor_q0 : pair of float, optional
        Initial rotor angles of a flexible plant (default: at the links, springs relaxed);
        :func:`twolink.arm.plant.holding_motor_q` (``q0 + K⁻¹ G(q0)``) starts the arm at rest
        holding itself up, as a scenario's ``start = "holding"`` does.
    sensor : Sensor, optional
        What the controller sees (:mod:`twolink.simulation.sensor`): quantised, delayed
        angles and estimated rates, with ``noise`` added to the angles; the rotor angles of
        a flexible plant go through the same sensor without the noise. Default: the true
        state (plus ``noise``). The records hold the true state either way.

    Returns
    -------
    Trajectory
        Samples at t = 0, control_dt, ..., duration; a run that diverged ends at the
        sample where it did (its out-of-bounds torque, or NaN torque where the state left
        its bounds), so even one that diverges at once has one sample.
    """
    if not isinstance(plant, Plant):  # an ArmParams (the arm, not yet a model), a model
        raise TypeError(
            f"simulate: plant must be a twolink.arm.plant.Plant (the MuJoCo arm: "
            f"Plant.build(arm_params)), got {type(plant).__name__}"
        )
    if not callable(controller) or not callable(getattr(controller, "reset", None)):
        raise TypeError(
            "simulate: controller must be a controller (reset() and controller(t, q, qd) -> "
            f"tau: twolink.controllers), got {type(controller).__name__}"
        )
    n, substeps = control_steps(duration, control_dt, plant.dt)
    ask = _asking(plant, controller, n, control_dt, noise, sensor)
    plant.reset(q0, qd0, motor_q=motor_q0)
    controller.reset()
    started = time.time()
    records = _run(plant, ask, n, substeps, control_dt, bounds)
    traj = _trajectory(*records, controller, warnings=tuple(warning_notes(plant.data)))
    if steplog.enabled():  # the run in the step log: its control periods, all stepped
        kept = np.array([len(traj.t)])
        digest = [steplog.arm_digest(traj.q, traj.tau)]
        steplog.record("single", started, (kept[0] - 1) * substeps, kept, substeps, digest)
    return traj


def _run(
    plant: Plant,
    ask: Callable[[int, float, float, float, float, float], tuple[float, float]],
    n: int,
    substeps: int,
    control_dt: float,
    bounds: Bounds,
) -> tuple[list[tuple[float, ...]], list[tuple[float, float]], str, str]:
    """:func:`simulate`'s loop from the reset plant: ``(rows, rotor angles, status,
    message)``, a row ``(t, q1, q2, w1, w2, tau1, tau2)`` per control instant."""
    qpos, qvel = plant.data.qpos, plant.data.qvel
    step = plant.step
    qmax, wmax, tmax = bounds.angle, bounds.rate, bounds.torque
    rows: list[tuple[float, ...]] = []
    motor: list[tuple[float, float]] = []

    def record(row: tuple[float, ...]) -> None:  # a sample, and the rotors' angles if any
        rows.append(row)
        if plant.flexible:
            motor.append((float(qpos[2]), float(qpos[3])))

    status, message = STATUS_OK, ""
    for k in range(n + 1):
        t = k * control_dt
        q1, q2, w1, w2 = float(qpos[0]), float(qpos[1]), float(qvel[0]), float(qvel[1])
        # NaN fails every comparison, so this also catches non-finite states.
        if not (abs(q1) < qmax and abs(q2) < qmax and abs(w1) < wmax and abs(w2) < wmax):
            status, message = STATUS_DIVERGED, state_message(t, q1, q2, w1, w2)
            if not rows:  # keep the one state there is (no torque was asked for)
                record((t, q1, q2, w1, w2, math.nan, math.nan))
            break
        tau1, tau2 = ask(k, t, q1, q2, w1, w2)
        record((t, q1, q2, w1, w2, tau1, tau2))
        if not (abs(tau1) < tmax and abs(tau2) < tmax):
            # Kept: the state measured and the torque the controller asked for (not applied).
            status, message = STATUS_DIVERGED, torque_message(t, tau1, tau2)
            break
        if k == n:
            break
        for _ in range(substeps):
            step(tau1, tau2)
    return rows, motor, status, message


def _asking(
    plant: Plant,
    controller: Controller,
    n: int,
    control_dt: float,
    noise: np.ndarray | None,
    sensor: Sensor | None,
) -> Callable[[int, float, float, float, float, float], tuple[float, float]]:
    """Checks of :func:`simulate`'s inputs, and how its loop asks the controller for the
    torques at control instant k: ``ask(k, t, q1, q2, w1, w2) -> (tau1, tau2)``, the state
    seen through the sensor (or with the noise added), the rotors' read from the plant's
    data where the controller reads them."""
    # A controller of flexible joints (controllers/flexible.py) also reads the rotors.
    needs_motor = bool(getattr(controller, "needs_motor", False))
    if needs_motor and not plant.flexible:
        raise ValueError(
            f"{type(controller).__name__} reads the motor states of flexible joints; "
            "this plant is rigid (build it with a Flexibility)"
        )
    if noise is not None and np.shape(noise) != (n + 1, 2):
        raise ValueError(f"noise must have shape {(n + 1, 2)}, got {np.shape(noise)}")
    reader = motor_reader = None
    if sensor is not None and not sensor.ideal:
        reader = sensor.reader(control_dt, noise)
        if needs_motor:
            motor_reader = sensor.reader(control_dt)
        noise = None
    noise_rows = None if noise is None else noise.tolist()
    qpos, qvel = plant.data.qpos, plant.data.qvel

    def ask(k: int, t: float, q1: float, q2: float, w1: float, w2: float):
        seen, rates = (q1, q2), (w1, w2)
        if reader is not None:
            seen, rates = reader(k, seen, rates)
        elif noise_rows is not None:
            n1, n2 = noise_rows[k]
            seen = (q1 + n1, q2 + n2)
        if needs_motor:
            motor_q = (float(qpos[2]), float(qpos[3]))
            motor_qd = (float(qvel[2]), float(qvel[3]))
            if motor_reader is not None:
                motor_q, motor_qd = motor_reader(k, motor_q, motor_qd)
            return controller(t, seen, rates, motor_q, motor_qd)
        return controller(t, seen, rates)

    return ask


def _trajectory(
    rows: list[tuple[float, ...]],
    motor: list[tuple[float, float]],
    status: str,
    message: str,
    controller: Controller,
    warnings: tuple[str, ...] = (),
) -> Trajectory:
    """The records of :func:`simulate`'s loop as a Trajectory, with the reference and
    MuJoCo's warnings during the run (the plant's data is reset with it: this run's)."""
    rec = np.array(rows, dtype=float).reshape(-1, 7)
    t = rec[:, 0]
    q_ref, qd_ref, qdd_ref = controller.reference.sample(t)
    return Trajectory(
        t=t,
        q=rec[:, 1:3],
        qd=rec[:, 3:5],
        q_ref=q_ref.reshape(-1, 2),
        qd_ref=qd_ref.reshape(-1, 2),
        qdd_ref=qdd_ref.reshape(-1, 2),
        tau=rec[:, 5:7],
        motor_q=np.array(motor, dtype=float).reshape(-1, 2),
        status=status,
        message=message,
        warnings=warnings,
    )
