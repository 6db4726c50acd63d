"""Scenario files: TOML read with :mod:`tomllib` into frozen, validated configs.

A scenario is one closed-loop run: the arm, how the plant differs from it, the
controller, the reference, timing and seed. A file may ``extend`` another (paths
relative to the file); its tables are merged over the base's, key by key, so a family
of experiments shares one base and states only what differs. Every error names the
file and the key: ``runs/x.toml: controller.kp: must be >= 0, got -1``.

Schema (all keys optional except the reference)::

    extends = "base.toml"
    name = "theta1 step"
    duration = 10.0          # s
    control_dt = 0.001       # s, controller period (zero-order hold)
    timestep = 0.001         # s, physics step (RK4)
    seed = 0                 # measurement noise draws
    [sensor]                 # what the controller sees (docs/sensors.md); default: the truth
    resolution_rad = 0.0     # encoder quantum (2*pi / 2**17 for a 17-bit encoder)
    noise_std_rad = 0.0      # Gaussian noise on the measured angles
    delay_samples = 0        # transport delay, control periods
    velocity = "exact"       # or "difference", "filtered" (2nd-order Butterworth)
    cutoff_hz = 50.0         # velocity = "filtered": the low-pass's cut-off
    [arm]                    # the nominal arm = the controller's model
    m1 = 1.0  m2 = 1.0  l1 = 1.0  l2 = 1.0  g = 9.81   # [arm.links]: bending (docs/scenarios.md)
    [plant]                  # the simulated arm: the nominal one, maybe perturbed
    scale = { m1 = 1.2, g = 1.1 }   # uncertainty as factors on [arm]; k, j: on the
                             # joints' stiffness and rotor inertia (flexible plants)
    payload = 0.0            # kg point mass at the tip
    [plant.flexibility]      # present = Spong flexible joints, as the controllers model them
    k = [500, 500]  d = [1, 1]  j = [0.05, 0.05]
    start = "holding"        # springs holding the arm at rest at q0, or "relaxed"
    [plant.friction]         # joint friction, N m and rad/s (docs/model.md, "Friction")
    coulomb = [0.5, 0.2]  viscous = [0.1, 0.05]  breakaway = [0.6, 0.25]  stribeck_velocity = 0.1
    [[disturbance.step]]     # also .impulse (size in N m s) and .sine (amplitude, frequency)
    joint = 1  time = 2.0  size = 1.0   # N m from 2 s on (docs/model.md, "Disturbances")
    [controller]
    kind = "ctc"             # "ctc", "fuzzy_ctc" (7x7 rules), "fcm_ctc" (reduced rules);
                             # baselines: "pd_gravity", "ctc_integral", "fuzzy_pd";
                             # flexible joints: "motor_pd", "composite", "flexible_fl",
                             # "flexible_fl_integral" (with integral action),
                             # "flexible_fl_kalman" (that, from encoder angles only)
    kp = [4, 4]  kd = [2.4, 2.4]  torque_limit = 1e3
    ki = [2, 2]              # ctc_integral: integral gain, 1/s^3
                             # the field's laws: "adaptive_ctc" (Slotine-Li), "sliding_mode"
                             # (boundary layer), "ctc_dob" (CTC with a disturbance observer)
    gamma = [30, 10, 10, 300, 100]  # adaptive_ctc: adaptation gains, per parameter
    eta = [1.0, 0.5]  phi = "auto"     # sliding_mode: margin N m, layer half width rad/s
    observer_time = 0.013    # ctc_dob: the observer's time constant, s
    rule_base = "paper"      # fcm_ctc, fuzzy_pd: "paper", "designed", "default" or a path
    [controller.fuzzy]       # u = ku f(ke e, kde de); "auto": tied to the gains (docs/fuzzy.md)
    ke = "auto"  kde = "auto"  ku = "auto"  span = "auto"  authority = 1.0  mode = "add"
    engine = "exact"        # or "table": bilinear lookup, table_points = 201 per axis
    inference = "mamdani"   # the paper's; "continuous": our extension (docs/fuzzy.md)
    [reference.joint1]
    kind = "step"  initial = 0.0  final = 1.0
    [reference.joint2]
    kind = "ramp"  initial = 0.0  final = 0.5  duration = 2.0
    [initial]
    q = [0, 0]  qd = [0, 0]
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from twolink.arm.disturbance import Disturbance
from twolink.arm.params import ArmParams, Flexibility

# The rule bases by name and the fuzzy scaling rule live with the controllers that use them.
from twolink.controllers.fuzzy.rulebase import BUILTIN_RULE_BASES as BUILTIN_RULE_BASES
from twolink.controllers.fuzzy.rulebase import RULEBASE_DIR as RULEBASE_DIR
from twolink.controllers.fuzzy.rulebase import missing_rule_base
from twolink.controllers.fuzzy.rulebase import resolve_rule_base as resolve_rule_base
from twolink.controllers.fuzzy_ctc import DEFAULT_SPAN as DEFAULT_SPAN
from twolink.controllers.fuzzy_ctc import auto_fuzzy_scaling as auto_fuzzy_scaling
from twolink.controllers.fuzzy_ctc import linear_span as linear_span
from twolink.foundation.overrides import REPLACE as REPLACE  # re-exported: callers' old home
from twolink.foundation.overrides import merge as merge
from twolink.foundation.overrides import set_nested
from twolink.foundation.overrides import strip_replace as strip_replace
from twolink.foundation.references import ArmReference, make_reference, reference_params
from twolink.foundation.shipped import locate, locate_beside, shipped_hint
from twolink.simulation.field_keys import DEFAULTS as FIELD_DEFAULTS
from twolink.simulation.field_keys import (
    FIELD_KINDS,
    LINK_KINDS,
    check_field_keys,
    read_field_keys,
    write_field_keys,
)
from twolink.simulation.links_sim import FlexibleLinks, check_links, links_dict, read_links
from twolink.simulation.plant_table import ARM_SCALE_KEYS as ARM_SCALE_KEYS
from twolink.simulation.plant_table import JOINT_SCALE_KEYS as JOINT_SCALE_KEYS
from twolink.simulation.plant_table import SPRING_STARTS as SPRING_STARTS
from twolink.simulation.plant_table import PlantConfig as PlantConfig
from twolink.simulation.plant_table import disturbance_dict, nyquist, read_disturbance, read_plant
from twolink.simulation.sensor import VELOCITY_ESTIMATES, Sensor

# Controllers of flexible joints (controllers/flexible.py): they read the motor states and
# model the joints with [plant.flexibility], so they need a flexible plant.
FLEXIBLE_KINDS = (
    "motor_pd",
    "composite",
    "flexible_fl",
    "flexible_fl_integral",
    "flexible_fl_kalman",
)
BASE_KINDS = ("ctc", "fuzzy_ctc", "fcm_ctc", "pd_gravity", "ctc_integral", "fuzzy_pd")
CONTROLLER_KINDS = (*BASE_KINDS, *FIELD_KINDS, *FLEXIBLE_KINDS, *LINK_KINDS)
FUZZY_KINDS = ("fuzzy_ctc", "fcm_ctc", "fuzzy_pd")  # controllers with a fuzzy engine
RULE_BASE_KINDS = ("fcm_ctc", "fuzzy_pd")  # those whose rule base is the rule_base key
FUZZY_MODES = ("add", "replace")
FUZZY_ENGINES = ("exact", "table")  # [controller.fuzzy] engine: docs/fuzzy.md
# [controller.fuzzy] inference: the paper's Mamdani (min, max, centroid), or our continuous
# product-sum reading of the same rules (controllers/fuzzy/continuous.py, docs/fuzzy.md)
FUZZY_INFERENCES = ("mamdani", "continuous")


# The shipped rule bases, where twolink.controllers is installed (the repository's
# controllers/ in a checkout, twolink/controllers/ in a wheel)
class ConfigError(ValueError):
    """An invalid scenario: the message names the file and the key."""


@dataclass(frozen=True)
class FuzzyConfig:
    """Scaling of the fuzzy term: u = ku * engine(ke * e, kde * de), and how it joins CTC.

    In a scenario each of ``ke``, ``kde``, ``ku`` is a number or ``"auto"`` (the default),
    resolved when the scenario is read by :func:`auto_fuzzy_scaling` from the controller's
    gains, ``span`` and ``authority``; a resolved config holds numbers only.
    """

    ke: float = 1.0
    kde: float = 1.0
    ku: float = 4.0
    mode: str = "add"
    span: float = 1.0  # rad: E, the error that reaches the edge of the input universe
    authority: float = 1.0  # fuzzy full scale / PD term at full-scale error ("auto")
    engine: str = "exact"  # "exact" (the Mamdani engine) or "table" (bilinear lookup)
    table_points: int = 201  # engine = "table": grid points per axis
    inference: str = "mamdani"  # "mamdani" (the paper's) or "continuous" (our extension)


AUTO = "auto"


@dataclass(frozen=True)
class ControllerConfig:
    kind: str = "ctc"
    kp: tuple[float, float] = (4.0, 4.0)
    kd: tuple[float, float] = (2.4, 2.4)
    ki: tuple[float, float] = (2.0, 2.0)
    torque_limit: tuple[float, float] = (math.inf, math.inf)  # N m per joint
    rule_base: str = "paper"
    fuzzy: FuzzyConfig = FuzzyConfig()
    gamma: tuple[float, ...] = FIELD_DEFAULTS["gamma"]  # adaptive_ctc
    eta: tuple[float, float] = FIELD_DEFAULTS["eta"]  # sliding_mode
    phi: tuple[float, float] | None = None  # sliding_mode; None: "auto"
    observer_time: float = FIELD_DEFAULTS["observer_time"]  # ctc_dob
    ks: tuple[float, float] = FIELD_DEFAULTS["ks"]  # two_time_scale


@dataclass(frozen=True)
class Scenario:
    """One closed-loop experiment, fully resolved and validated."""

    name: str
    arm: ArmParams
    plant: PlantConfig
    controller: ControllerConfig
    reference: ArmReference
    duration: float = 10.0
    control_dt: float = 1e-3
    timestep: float = 1e-3
    seed: int = 0
    q0: tuple[float, float] = (0.0, 0.0)
    qd0: tuple[float, float] = (0.0, 0.0)
    source: str = ""
    sensor: Sensor = Sensor()
    disturbance: Disturbance | None = None  # torques on the links the controllers don't know
    links: FlexibleLinks | None = None  # [arm.links]: the nominal arm's links bend

    @property
    def plant_params(self) -> ArmParams:
        """The simulated arm's parameters: the nominal arm with the uncertainty factors."""
        scale = self.plant.scale
        return self.arm.scaled(**{k: v for k, v in scale.items() if k in ARM_SCALE_KEYS})

    @property
    def plant_joints(self) -> Flexibility | None:
        """The simulated arm's joints: ``[plant.flexibility]`` (the controllers' model)
        with the stiffness and rotor inertia scaled by ``[plant.scale]`` ``k`` and ``j``
        (the damping d as given); None for a rigid arm."""
        f = self.plant.flexibility
        if f is None:
            return None
        sk, sj = self.plant.scale.get("k", 1.0), self.plant.scale.get("j", 1.0)
        if sk == sj == 1.0:
            return f
        return Flexibility(k=tuple(k * sk for k in f.k), d=f.d, j=tuple(j * sj for j in f.j))

    def to_dict(self) -> dict[str, Any]:
        """The resolved config as plain data (what a run writes as ``config.toml``)."""
        plant: dict[str, Any] = {
            "scale": dict(self.plant.scale),
            "payload": self.plant.payload,
        }
        if self.plant.flexibility is not None:
            plant["flexibility"] = {k: list(v) for k, v in asdict(self.plant.flexibility).items()}
            plant["flexibility"]["start"] = self.plant.springs
        if self.plant.friction is not None:  # absent: digests stay as they were
            items = asdict(self.plant.friction).items()
            plant["friction"] = {k: list(v) if isinstance(v, tuple) else v for k, v in items}
        ctrl = asdict(self.controller)
        ctrl["kp"], ctrl["kd"], ctrl["ki"] = list(ctrl["kp"]), list(ctrl["kd"]), list(ctrl["ki"])
        if self.controller.fuzzy.engine == "exact":  # the default: digests stay as they were
            del ctrl["fuzzy"]["engine"], ctrl["fuzzy"]["table_points"]
        if self.controller.fuzzy.inference == "mamdani":
            del ctrl["fuzzy"]["inference"]
        write_field_keys(ctrl, self.controller.kind)
        return {
            "name": self.name,
            "duration": self.duration,
            "control_dt": self.control_dt,
            "timestep": self.timestep,
            "seed": self.seed,
            "arm": asdict(self.arm) | ({"links": links_dict(self.links)} if self.links else {}),
            "plant": plant,
            "controller": ctrl,
            "reference": {
                "joint1": reference_params(self.reference.joint1),
                "joint2": reference_params(self.reference.joint2),
            },
            "initial": {"q": list(self.q0), "qd": list(self.qd0)},
            **({} if self.sensor.ideal else {"sensor": asdict(self.sensor)}),
            **({"disturbance": disturbance_dict(self.disturbance)} if self.disturbance else {}),
        }


# ----------------------------------------------------------------------------- reading


MAX_DEPTH = 32  # tables nested deeper are a mistake (tomllib would recurse past its limit)


def parse_set(items: Sequence[str]) -> dict[str, Any]:
    """``--set KEY=VALUE`` options as nested overrides: dotted keys make tables, values are
    TOML (``25``, ``[1, 2]``, ``true``, ``"text"``) or else plain strings."""
    out: dict[str, Any] = {}
    for item in items:
        if any(ch in item for ch in "\n\r\x00"):
            raise ConfigError(f"--set {item!r}: a line break or NUL in a value is not allowed")
        key, sep, text = item.partition("=")
        parts = key.strip().split(".")
        if not sep or not all(parts):
            raise ConfigError(f"--set {item!r}: expected KEY=VALUE, e.g. controller.kp=25")
        try:
            value = tomllib.loads(f"value = {text}")["value"]
        except tomllib.TOMLDecodeError:
            value = text
        except RecursionError:
            raise ConfigError(f"--set {key}: the value is nested too deep") from None
        if len(parts) > MAX_DEPTH:
            raise ConfigError(f"--set {key}: more than {MAX_DEPTH} dotted parts")
        set_nested(out, parts, value)
    return out


MAX_PHYSICS_STEPS = 1e8  # per run: 1e8 MuJoCo steps take about 15 min here
MAX_EXTENDS = 64  # a longer ``extends`` chain is a mistake, not a design
MAX_TOML_BYTES = 1 << 20  # 1 MiB: a scenario or study file is a few kB
# No number twolink reads means anything beyond this (kg, m, s, gains, N·m/rad): larger
# ones only overflow later, far from the key that caused it.
MAX_MAGNITUDE = 1e12
MAX_TABLE_POINTS = 2001  # per axis: 4e6 cells, ~100 MB of lookup table
MAX_DELAY_SAMPLES = 10_000  # [sensor] delay_samples: 10 s at 1 kHz, past any real loop
MIN_RESOLUTION_RAD = 1e-12  # [sensor] resolution_rad, when not 0: a 42-bit encoder
MIN_TIME_STEP = 1e-6  # s: timestep and control_dt; finer is not a control loop


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, following ``extends`` chains; errors name the file (and, for a
    missing or broken base, the file and key that point to it)."""
    path = locate(path)
    refuse_fis(path)
    chain: list[tuple[Path, dict[str, Any]]] = []
    while True:
        data = _read_one(path, chain[-1][0] if chain else None)
        chain.append((path, data))
        base = data.pop("extends", None)
        if base is None:
            break
        if not isinstance(base, str):
            raise ConfigError(f"{path}: extends: must be a file path, got {base!r}")
        if len(chain) > MAX_EXTENDS:
            raise ConfigError(f"{chain[0][0]}: extends: a chain of more than {MAX_EXTENDS} files")
        following = locate_beside(path.parent, base)  # beside the file, else shipped
        seen = [p.resolve() for p, _ in chain]
        if following.resolve() in seen:
            raise ConfigError(f"{path}: extends: {base} extends itself (cycle through {seen})")
        path = following
    merged: dict[str, Any] = {}
    for _, data in reversed(chain):
        merged = merge(merged, data)
    return merged


def _read_one(path: Path, referrer: Path | None) -> dict[str, Any]:
    where = f"{referrer}: extends: " if referrer is not None else ""
    if path.is_dir():
        raise ConfigError(f"{where}{path}: is a folder, not a TOML file")
    if path.exists() and not path.is_file():
        raise ConfigError(f"{where}{path}: is not a regular file (a pipe, a device)")
    if not path.is_file():
        hint = shipped_hint(path) if referrer is None else ""
        raise ConfigError(f"{where}{path}: no such file{hint}")
    if path.stat().st_size > MAX_TOML_BYTES:
        raise ConfigError(f"{where}{path}: larger than {MAX_TOML_BYTES} bytes")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(f"{path}: not valid TOML: nested too deep") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{where}{path}: cannot be read: {exc}") from None


# Keys found in one kind of this project's files and in no other, and what reads that
# kind: so a file given to the wrong command is named as such (tested for every kind of
# shipped file with every command: tests/test_bad_input_more.py).
FILE_KINDS = {
    "scenario": (("extends", "arm", "plant", "initial", "sensor"), "`twolink run FILE`"),
    "sweep": (("samples", "chunk_size"), "`twolink sweep FILE` (or `twolink regimes FILE`)"),
    "manifest": (("experiment", "variants", "claims_study"), "`twolink reproduce --manifest FILE`"),
    "design": (("clusters", "fuzzifier", "scenarios"), "`twolink design --config FILE`"),
    "gains": (("natural_frequencies", "damping_ratios"), "`twolink gains FILE`"),
    "calibration": (("popsize", "maxiter", "tables", "fcm"), "`twolink calibrate FILE`"),
    "calibration result": (
        ("objective", "evaluations", "digest"),
        "`twolink reproduce`, which reruns it as its manifest's `calibration` (`twolink "
        "calibrate` writes it)",
    ),
    "rule base": (("rule",), "`twolink coverage FILE`, `twolink fis FILE` or a scenario's "
                  "controller.rule_base"),
}  # fmt: skip
FIS_SUFFIX = ".fis"


def refuse_fis(path: str | Path) -> None:
    """A MATLAB ``.fis`` file (the one file kind here that is not TOML) where a TOML file
    belongs: say what takes it."""
    if Path(path).suffix.lower() == FIS_SUFFIX:
        raise ConfigError(
            f"{path}: this is a MATLAB .fis rule base, not a TOML file; it is for "
            f"`twolink coverage {path}` or a scenario's controller.rule_base"
        )


def file_kind(data: dict[str, Any]) -> str | None:
    """The kind of this project's files ``data`` (a TOML file's tables) is: the kind with
    the most of its own keys in it, None where none has any."""
    counts = {k: sum(key in data for key in keys) for k, (keys, _) in FILE_KINDS.items()}
    best = max(counts, key=counts.__getitem__)
    return best if counts[best] else None


def expect_kind(data: dict[str, Any], file: str | Path, kind: str) -> None:
    """Raise a :class:`ConfigError` that names what reads ``file`` when ``data`` (the file,
    read for ``kind``) is another kind of this project's files."""
    found = file_kind(data)
    if found is None or found == kind:
        return
    reader = FILE_KINDS[found][1].replace("FILE", str(file))
    raise ConfigError(f"{file}: this is a {found} file, not a {kind} file; it is for {reader}")


class TomlTable:
    """Reads one TOML table, checking types; ``done()`` rejects keys nobody read.

    Every error names the file and the dotted key. Shared by all the project's TOML
    readers (scenarios, designs, reproduction manifests, sweeps).
    """

    def __init__(self, data: Any, where: str, file: str):
        self.where, self.file = where, file
        if not isinstance(data, dict):
            self.fail("", f"must be a table, got {data!r}")
        self.data = dict(data)
        self.read: set[str] = set()

    def fail(self, key: str, problem: str):
        name = f"{self.where}.{key}" if self.where and key else self.where or key
        raise ConfigError(f"{self.file}: {name}: {problem}")

    def raw(self, key: str, default: Any = None) -> Any:
        self.read.add(key)
        return self.data.get(key, default)

    def number(self, key: str, default: float, **checks: Any) -> float:
        return self._checked(key, self.raw(key, default), **checks)

    def pair(self, key: str, default: tuple[float, float], **checks: Any) -> tuple[float, float]:
        value = self.raw(key, default)
        if isinstance(value, int | float) and not isinstance(value, bool):
            value = (value, value)
        if not isinstance(value, list | tuple) or len(value) != 2:
            self.fail(key, f"must be a number or a list of 2 numbers, got {value!r}")
        return self._checked(key, value[0], **checks), self._checked(key, value[1], **checks)

    def as_float(self, key: str, value: Any) -> float:
        """``value`` (of ``key``) as a float: a number (not a bool) that a float holds,
        else the one-line error; any float, NaN and inf included."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(key, f"must be a number, got {value!r}")
        try:
            return float(value)
        except OverflowError:
            self.fail(
                key,
                f"must be a number a float can hold, got an integer of {len(str(value))} digits",
            )

    def _checked(
        self,
        key: str,
        value: Any,
        *,
        minimum: float | None = None,
        positive: bool = False,
        allow_inf: bool = False,
        allow_nan: bool = False,
    ) -> float:
        value = self.as_float(key, value)
        if (math.isnan(value) and not allow_nan) or (math.isinf(value) and not allow_inf):
            self.fail(key, f"must be finite, got {value!r}")
        if math.isfinite(value) and abs(value) > MAX_MAGNITUDE:
            self.fail(key, f"must be at most {MAX_MAGNITUDE:g} in size, got {value!r}")
        if positive and not value > 0:
            self.fail(key, f"must be > 0, got {value!r}")
        if minimum is not None and value < minimum:
            self.fail(key, f"must be >= {minimum}, got {value!r}")
        return float(value)

    def string(self, key: str, default: str, choices: tuple[str, ...] | None = None) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str):
            self.fail(key, f"must be a string, got {value!r}")
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {list(choices)}, got {value!r}")
        return value

    def integer(self, key: str, default: int) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            self.fail(key, f"must be an integer >= 0, got {value!r}")
        return value

    def table(self, key: str) -> TomlTable:
        where = f"{self.where}.{key}" if self.where else key
        return TomlTable(self.raw(key, {}), where, self.file)

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.read)
        if unknown:
            self.fail(unknown[0], f"unknown key (known here: {sorted(self.read)})")


def _arm(t: TomlTable) -> tuple[ArmParams, FlexibleLinks | None]:
    d = ArmParams()
    arm = ArmParams(
        m1=t.number("m1", d.m1, positive=True),
        m2=t.number("m2", d.m2, positive=True),
        l1=t.number("l1", d.l1, positive=True),
        l2=t.number("l2", d.l2, positive=True),
        g=t.number("g", d.g),
    )
    return arm, read_links(t, arm)


def _sensor(t: TomlTable) -> Sensor:
    d = Sensor()
    sensor = Sensor(
        resolution_rad=t.number("resolution_rad", d.resolution_rad, minimum=0.0),
        noise_std_rad=t.number("noise_std_rad", d.noise_std_rad, minimum=0.0),
        delay_samples=t.integer("delay_samples", d.delay_samples),
        velocity=t.string("velocity", d.velocity, VELOCITY_ESTIMATES),
        cutoff_hz=t.number("cutoff_hz", d.cutoff_hz, positive=True),
    )
    if 0 < sensor.resolution_rad < MIN_RESOLUTION_RAD:  # 5e-324: every count overflows
        t.fail("resolution_rad", f"0 or >= {MIN_RESOLUTION_RAD:g}, not {sensor.resolution_rad}")
    if sensor.delay_samples > MAX_DELAY_SAMPLES:
        t.fail("delay_samples", f"must be at most {MAX_DELAY_SAMPLES}, got {sensor.delay_samples}")
    t.done()
    return sensor


def controller_from_table(t: TomlTable, arm: ArmParams | None = None) -> ControllerConfig:
    """A ``[controller]`` table (or overrides of one) validated; errors name ``t``'s file.
    ``arm`` (default: the default arm) is the model that an "auto" fuzzy span reads."""
    d = ControllerConfig()
    kind = t.string("kind", d.kind, CONTROLLER_KINDS)
    kp = t.pair("kp", d.kp, minimum=0.0)
    kd = t.pair("kd", d.kd, minimum=0.0)
    limit = t.pair("torque_limit", d.torque_limit, positive=True, allow_inf=True)
    fuzzy = _fuzzy(t.table("fuzzy"), kind, kp, limit, arm or ArmParams())
    ctrl = ControllerConfig(
        kind=kind,
        kp=kp,
        kd=kd,
        ki=t.pair("ki", d.ki, minimum=0.0),
        torque_limit=t.pair("torque_limit", d.torque_limit, positive=True, allow_inf=True),
        rule_base=t.string("rule_base", d.rule_base),
        fuzzy=fuzzy,
        **read_field_keys(t),
    )
    t.done()
    return ctrl


def _fuzzy(
    f: TomlTable,
    kind: str,
    kp: Sequence[float],
    limit: Sequence[float],
    arm: ArmParams,
) -> FuzzyConfig:
    """``[controller.fuzzy]`` with its "auto" scalings resolved from the gains."""
    fd = FuzzyConfig()
    span = _auto_or_number(f, "span", positive=True)
    if span is None:
        span = linear_span(arm, kp, limit)
    authority = f.number("authority", fd.authority, minimum=0.0)
    given = {
        "ke": _auto_or_number(f, "ke", positive=True),
        "kde": _auto_or_number(f, "kde", positive=True),
        "ku": _auto_or_number(f, "ku", minimum=0.0),
    }
    try:
        ke, kde, ku = auto_fuzzy_scaling(kp, span, authority, **given)
    except ValueError as exc:
        if kind in FUZZY_KINDS:
            auto = next(k for k in ("kde", "ku") if given[k] is None)
            f.fail(auto, f'"auto" {exc} (or give {auto} as a number)')
        ke, kde, ku = fd.ke, fd.kde, fd.ku  # a controller without a fuzzy term: unused
    fuzzy = FuzzyConfig(
        ke=ke,
        kde=kde,
        ku=ku,
        mode=f.string("mode", fd.mode, FUZZY_MODES),
        span=span,
        authority=authority,
        engine=f.string("engine", fd.engine, FUZZY_ENGINES),
        table_points=f.integer("table_points", fd.table_points),
        inference=f.string("inference", fd.inference, FUZZY_INFERENCES),
    )
    if not 2 <= fuzzy.table_points <= MAX_TABLE_POINTS:
        f.fail("table_points", f"must be 2 to {MAX_TABLE_POINTS}, got {fuzzy.table_points}")
    if kind not in FUZZY_KINDS and fuzzy.inference != fd.inference:  # it would be ignored
        f.fail("inference", f"{fuzzy.inference!r}: a {kind!r} controller has no fuzzy term")
    if fuzzy.engine == "table" and fuzzy.inference == "continuous":  # docs/scenarios.md
        f.fail("engine", '"table" (a lookup of the Mamdani engine) with inference = "continuous"')
    f.done()
    return fuzzy


def _auto_or_number(t: TomlTable, key: str, **checks: Any) -> float | None:
    """A fuzzy scaling key: a checked number, or None for "auto" (its default)."""
    value = t.raw(key, AUTO)
    if value == AUTO:
        return None
    if isinstance(value, str):
        t.fail(key, f'must be a number or "auto", got {value!r}')
    return t.number(key, 0.0, **checks)


def _reference(t: TomlTable, arm: ArmParams) -> ArmReference:
    joints = []
    for name in ("joint1", "joint2"):
        j = t.table(name)
        params = dict(j.data)
        kind = params.pop("kind", None)
        if kind is None:
            j.fail("kind", "missing (one of step, ramp, sine, quintic, septic, multisine, circle)")
        if kind == "circle":  # the tip's circle through the model arm's kinematics
            params = {"l1": arm.l1, "l2": arm.l2, "joint": int(name[-1]), **params}
        try:
            joints.append(make_reference(kind, **params))
        except (ValueError, TypeError) as exc:
            j.fail("", str(exc))
        if kind == "circle" and joints[-1].joint != int(name[-1]):
            j.fail("joint", f"must be {name[-1]} in [reference.{name}], got {params['joint']!r}")
    t.done()
    circles = [j for j in joints if j.kind == "circle"]
    if circles and (len(circles) == 1 or replace(circles[0], joint=2.0) != circles[1]):
        t.fail("joint2", "a circle of the tip must be the same circle for both joints")
    return ArmReference(*joints)


def scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> Scenario:
    """Validate plain data (as read from TOML) into a :class:`Scenario`."""
    data = strip_replace(data)
    top = TomlTable(data, "", source)
    if "reference" not in data:
        top.fail("reference", "missing: a scenario needs [reference.joint1] and .joint2")
    initial = top.table("initial")
    arm, links = _arm(top.table("arm"))
    scenario = Scenario(
        name=top.string("name", Path(source).stem),
        arm=arm,
        plant=read_plant(top.table("plant")),
        controller=controller_from_table(top.table("controller"), arm),
        reference=_reference(top.table("reference"), arm),
        duration=top.number("duration", 10.0, positive=True),
        control_dt=top.number("control_dt", 1e-3, positive=True, minimum=MIN_TIME_STEP),
        timestep=top.number("timestep", 1e-3, positive=True, minimum=MIN_TIME_STEP),
        seed=top.integer("seed", 0),
        q0=initial.pair("q", (0.0, 0.0)),
        qd0=initial.pair("qd", (0.0, 0.0)),
        source=source,
        sensor=_sensor(top.table("sensor")),
        disturbance=read_disturbance(top.table("disturbance")) if "disturbance" in data else None,
    )
    initial.done()
    top.done()
    if scenario.sensor.velocity == "filtered":
        try:
            scenario.sensor.velocity_filter(scenario.control_dt)
        except ValueError as exc:
            top.fail("sensor.cutoff_hz", str(exc))
    steps = scenario.control_dt / scenario.timestep
    if abs(steps - round(steps)) > 1e-9 * steps or round(steps) < 1:
        top.fail("control_dt", f"must be a whole multiple of timestep {scenario.timestep}")
    if scenario.duration < scenario.control_dt:
        top.fail("duration", f"must be at least control_dt {scenario.control_dt}")
    if scenario.duration / scenario.timestep > MAX_PHYSICS_STEPS:
        top.fail(
            "duration",
            f"{scenario.duration:g} s at a timestep of {scenario.timestep:g} s is "
            f"{scenario.duration / scenario.timestep:.3g} physics steps; the limit is "
            f"{MAX_PHYSICS_STEPS:.0e} (about 15 min of computing) per run",
        )
    try:
        scenario.plant_params  # noqa: B018 - the scaled arm must be valid too
    except ValueError as exc:
        top.fail("plant.scale", str(exc))
    _check_rule_base(top, scenario)
    scenario = check_links(top, replace(scenario, links=links), FLEXIBLE_KINDS)
    check_field_keys(top, scenario)
    nyquist(top, scenario)  # a sine disturbance the physics step can carry
    if scenario.controller.kind in FLEXIBLE_KINDS and scenario.plant.flexibility is None:
        top.fail(
            "controller.kind",
            f"{scenario.controller.kind!r} reads the motors of flexible joints and models them "
            "with [plant.flexibility], which this scenario lacks (a rigid arm)",
        )
    return scenario


def _check_rule_base(top: TomlTable, s: Scenario) -> None:
    # A rule-base file that is missing or broken is bad input, found before any run.
    name = s.controller.rule_base
    if s.controller.kind not in RULE_BASE_KINDS or name in BUILTIN_RULE_BASES:
        return
    path = resolve_rule_base(name, s.source)
    if not path.is_file():
        top.fail("controller.rule_base", missing_rule_base(name, path))
    from twolink.controllers.fuzzy.continuous import ContinuousEngine
    from twolink.controllers.fuzzy.fis.matlab import rule_base_engine

    try:
        engine = rule_base_engine(path)  # TOML labels must be the engine's; any 2-input .fis
        if s.controller.fuzzy.inference == "continuous":
            ContinuousEngine(engine)  # says so where the file is not a triangular partition
    except (ValueError, OSError) as exc:
        message = str(exc)
        top.fail("controller.rule_base", message if str(path) in message else f"{path}: {message}")


def load_scenario(path: str | Path, overrides: dict[str, Any] | None = None) -> Scenario:
    """Read and validate a scenario file, with optional overrides merged on top. ``path``
    is a file or a shipped scenario's name (``paper/theta1_step``; a real path wins)."""
    path = locate(path)
    data = read_toml(path)
    expect_kind(data, path, "scenario")
    if overrides:
        data = merge(data, overrides)
    return scenario_from_dict(data, str(path))
