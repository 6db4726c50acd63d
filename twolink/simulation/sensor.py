"""What the controller sees: joint sensors as a lab has them.

A :class:`Sensor` turns the true link angles and rates into measured ones, in this order,
at every control instant:

1. Gaussian noise of ``noise_std_rad`` on the angle (drawn by the caller, seeded);
2. the encoder's quantum ``resolution_rad``: the angle is rounded to the nearest count
   (a mid-tread quantiser, error within ±resolution/2; 0 = ideal);
3. the rate: ``"exact"`` (the true rate, as a tachometer would give it), ``"difference"``
   (the backward difference of the measured angles over one control period, the textbook
   encoder velocity) or ``"filtered"`` (that difference through a second-order Butterworth
   low-pass of cut-off ``cutoff_hz``, ``scipy.signal.butter(2, cutoff_hz, fs=1/dt)``,
   the "dirty derivative" of servo drives: flat in its pass band, −40 dB/decade on the
   quantisation noise of the difference);
4. a transport delay of ``delay_samples`` control periods on both (before the first
   sample arrives, the first sample is held).

The rotor encoders of the flexible-joint laws (``needs_motor``) are quantised, differenced
and delayed the same way, without the added noise (``noise_std_rad`` models the link-side
sensing). Metrics and records always use the true state.

Each reading is written once, as a kernel of elementwise arithmetic (:func:`_estimate`)
that runs on floats (the single-arm loop, one call per channel: a few µs a step) and on
per-arm arrays (the batch engine), the same operations in the same order, so the batch
equals the single-arm path bit for bit (``tests/test_sensor.py``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_CUTOFF_HZ",
    "ENCODER_BITS",
    "VELOCITY_ESTIMATES",
    "Sensor",
    "SensorReader",
    "encoder_resolution",
]

VELOCITY_ESTIMATES = ("exact", "difference", "filtered")
# The studies' encoder: 17 bits a turn (2^17 counts, 4.79e-5 rad), a common absolute encoder
# on the motor side of a small arm's joints (docs/sensors.md).
ENCODER_BITS = 17
# The velocity filter's cut-off: the rule and its evidence are in docs/sensors.md.
DEFAULT_CUTOFF_HZ = 50.0


def encoder_resolution(bits: int) -> float:
    """The quantum of an encoder of ``bits`` bits a turn [rad]."""
    return 2.0 * math.pi / 2**bits


@dataclass(frozen=True)
class Sensor:
    """The joint sensors of a scenario's ``[sensor]`` table (module docstring).

    Parameters
    ----------
    resolution_rad : float
        Encoder quantum [rad], >= 0 (0: ideal).
    noise_std_rad : float
        Standard deviation of Gaussian noise on the measured link angles [rad], >= 0.
    delay_samples : int
        Transport delay in control periods, >= 0.
    velocity : str
        ``"exact"``, ``"difference"`` or ``"filtered"``.
    cutoff_hz : float
        Cut-off of the velocity filter (``velocity = "filtered"``) [Hz], > 0 and below the
        Nyquist frequency of the control rate.
    """

    resolution_rad: float = 0.0
    noise_std_rad: float = 0.0
    delay_samples: int = 0
    velocity: str = "exact"
    cutoff_hz: float = DEFAULT_CUTOFF_HZ

    def __post_init__(self) -> None:
        for name in ("resolution_rad", "noise_std_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        if isinstance(self.delay_samples, bool) or not (
            isinstance(self.delay_samples, int) and self.delay_samples >= 0
        ):
            raise ValueError(f"delay_samples must be an integer >= 0, got {self.delay_samples!r}")
        if self.velocity not in VELOCITY_ESTIMATES:
            raise ValueError(
                f"velocity must be one of {list(VELOCITY_ESTIMATES)}, got {self.velocity!r}"
            )
        if not (math.isfinite(self.cutoff_hz) and self.cutoff_hz > 0):
            raise ValueError(f"cutoff_hz must be > 0, got {self.cutoff_hz!r}")

    @classmethod
    def encoder(
        cls,
        bits: int = ENCODER_BITS,
        velocity: str = "filtered",
        cutoff_hz: float = DEFAULT_CUTOFF_HZ,
        **others: Any,
    ) -> Sensor:
        """An encoder of ``bits`` bits a turn with the given rate estimate."""
        return cls(
            resolution_rad=encoder_resolution(bits),
            velocity=velocity,
            cutoff_hz=cutoff_hz,
            **others,
        )

    @property
    def ideal(self) -> bool:
        """True when the controller sees the true state (the default)."""
        return (
            self.resolution_rad == 0
            and self.noise_std_rad == 0
            and self.delay_samples == 0
            and self.velocity == "exact"
        )

    def velocity_filter(self, control_dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) of the velocity filter at the control rate (``scipy.signal.butter``)."""
        from scipy.signal import butter

        nyquist = 0.5 / control_dt
        if not self.cutoff_hz < nyquist:
            raise ValueError(
                f"cutoff_hz {self.cutoff_hz:g} must be below the Nyquist frequency "
                f"{nyquist:g} Hz of the control period {control_dt:g} s"
            )
        b, a = butter(2, self.cutoff_hz, fs=1.0 / control_dt)
        return b, a

    def reader(
        self, control_dt: float, noise: np.ndarray | None = None, batch: bool = False
    ) -> SensorReader:
        """A fresh reader (the sensor's state at rest) for one run or one batch."""
        return SensorReader(self, control_dt, noise, batch)

    def describe(self) -> str:
        """One line for reports: ``17-bit encoder (4.79e-05 rad), filtered velocity (50 Hz)``."""
        if self.ideal:
            return "ideal (true angles and rates)"
        parts = []
        if self.resolution_rad:
            bits = math.log2(2 * math.pi / self.resolution_rad)
            name = f"{bits:.0f}-bit encoder" if abs(bits - round(bits)) < 1e-9 else "encoder"
            parts.append(f"{name} ({self.resolution_rad:.3g} rad)")
        if self.noise_std_rad:
            parts.append(f"noise {self.noise_std_rad:.3g} rad")
        rate = {
            "exact": "exact velocity",
            "difference": "differenced velocity",
            "filtered": f"filtered velocity ({self.cutoff_hz:g} Hz Butterworth)",
        }[self.velocity]
        parts.append(rate)
        if self.delay_samples:
            parts.append(f"delay {self.delay_samples} samples")
        return ", ".join(parts)


def _estimate(x, previous, z1, z2, coefficients, control_dt):
    """The rate of a measured angle ``x`` given the last one: the backward difference, and
    with ``coefficients`` (b0, b1, b2, a1, a2) that difference through the biquad in
    transposed direct form II (scipy.signal.lfilter's). Floats or arrays alike."""
    rate = (x - previous) / control_dt
    if coefficients is None:
        return rate, z1, z2
    b0, b1, b2, a1, a2 = coefficients
    y = b0 * rate + z1
    return y, b1 * rate - a1 * y + z2, b2 * rate - a2 * y


# The batch reading, step by step, written once for every array backend: the numpy batch
# engine's reader below and the accelerator backend (twolink.simulation.mjx_engine) call
# these with their namespace ``xp``; ``reader`` is a SensorReader (its quantum, rate
# estimate and control period) and the rate state (previous angle, z1, z2) is passed in
# and returned, so that a compiled loop can carry it.


def measured_angles(reader: SensorReader, x: Any, xp: Any) -> Any:
    """The encoder's angles from the (noisy) true ones: rounded to the nearest count."""
    if reader.quantum:
        return xp.round(x / reader.quantum) * reader.quantum
    return x


def initial_rate_state(reader: SensorReader, x: Any, xp: Any) -> Any:
    """The rate estimate's state before the first reading ``x``: at rest there."""
    return None if reader.exact else (x, xp.zeros_like(x), xp.zeros_like(x))


def measured_rates(reader: SensorReader, x: Any, qd: Any, state: Any) -> tuple[Any, Any]:
    """The rates the controller sees and the estimate's next state."""
    if reader.exact:
        return qd, state
    rate, z1, z2 = _estimate(x, *state, reader.coefficients, reader.dt)
    return rate, (x, z1, z2)


class SensorReader:
    """A sensor's state over one run: ``reader(k, q, qd)`` is what the controller sees at
    control instant k. Single-arm (``batch=False``): q, qd are pairs of floats and so is
    the answer; batch: arrays (N, m), answered as arrays."""

    def __init__(
        self, sensor: Sensor, control_dt: float, noise: np.ndarray | None, batch: bool
    ) -> None:
        self.sensor = sensor
        self.dt = control_dt
        self.noise = None if noise is None else (noise if batch else noise.tolist())
        self.batch = batch
        self.quantum = sensor.resolution_rad
        self.exact = sensor.velocity == "exact"
        self.coefficients = None
        if sensor.velocity == "filtered":
            b, a = sensor.velocity_filter(control_dt)
            # Python floats: numpy scalars would slow the single-arm loop several times.
            self.coefficients = tuple(float(c) for c in (b[0], b[1], b[2], a[1], a[2]))
        self.state: Any = None  # per channel (previous angle, z1, z2), set at the first call
        self.delayed: deque | None = deque(maxlen=sensor.delay_samples + 1)

    def __call__(self, k: int, q, qd):
        if not self.batch:
            return self._pair(k, q, qd)
        x = measured_angles(self, q if self.noise is None else q + self.noise[k], np)
        if self.state is None:
            self.state = initial_rate_state(self, x, np)
        rate, self.state = measured_rates(self, x, qd, self.state)
        return self._delay(x, rate)

    def _pair(self, k: int, q, qd):
        """The single-arm form: two channels as floats, written out (a loop over the
        channels costs a third of a control step)."""
        x1, x2 = q
        if self.noise is not None:
            n1, n2 = self.noise[k]
            x1, x2 = x1 + n1, x2 + n2
        if self.quantum:
            quantum = self.quantum
            x1, x2 = round(x1 / quantum) * quantum, round(x2 / quantum) * quantum
        rate = qd
        if not self.exact:
            if self.state is None:
                self.state = ((x1, 0.0, 0.0), (x2, 0.0, 0.0))
            s1, s2 = self.state
            r1, y1, z1 = _estimate(x1, *s1, self.coefficients, self.dt)
            r2, y2, z2 = _estimate(x2, *s2, self.coefficients, self.dt)
            self.state = ((x1, y1, z1), (x2, y2, z2))
            rate = (r1, r2)
        return self._delay((x1, x2), rate)

    def _delay(self, x, rate):
        if not self.sensor.delay_samples:
            return x, rate
        self.delayed.append((x, rate))
        return self.delayed[0]
