"""The sensor-model YAML: one schema read by the calibration, the denoiser, the filter and the simulator.

Measurement model of each triad (gyro in rad/s, accel in m/s^2)::

    measured = (I + diag(scale_factor) + misalignment) @ true + bias + noise

``misalignment`` is a 3x3 small-angle matrix with a zero diagonal (rad).
Stochastic terms are the five Allan-variance coefficients, SI units per axis:

=====================  ===================  ====================
term                   gyro                 accel
=====================  ===================  ====================
quantization Q         rad                  m/s
white_noise N          rad/sqrt(s)          m/s/sqrt(s)
bias_instability B     rad/s                m/s^2
bias_correlation_time  s                    s
rate_random_walk K     rad/s/sqrt(s)        m/s^2/sqrt(s)
rate_ramp R            rad/s^2              m/s^3
=====================  ===================  ====================

A value of 0 means the term is absent. ``bias_correlation_time`` > 0 makes the
bias instability a first-order Gauss-Markov process with that correlation time
(its steady-state sigma is ``bias_instability``); 0 means flicker (1/f) noise.
Each term may carry a 95 % interval per axis (``interval_95``, shape (3, 2)).
A stochastic term may carry ``identifiable`` per axis (3 booleans): ``false``
means the record could not identify the term and ``value`` is the 95 % upper
bound of its interval, not an estimate (written by ``imu_calib``).

The ``physics`` section maps names of :data:`EFFECTS` to their parameters
(a mapping, possibly empty for the physical default): the effects the
simulation includes. No ``physics`` section means a naive simulation.
"""
from __future__ import annotations

import copy
import datetime as _dt
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from nav_core.params import read_yaml_file, unknown_keys_error

SCHEMA_VERSION = 1
TOP_KEYS = ("sensor_model_version", "sample_rate_hz", "provenance", "gyro", "accel", "physics")
MAX_SAMPLE_RATE_HZ = 1e5
ENTRY_KEYS = {"value", "interval_95", "identifiable"}
"""Keys of one term's entry (``identifiable``: see above)."""

VECTOR_TERMS = ("bias", "scale_factor", "quantization", "white_noise", "bias_instability",
                "bias_correlation_time", "rate_random_walk", "rate_ramp")
"""Per-axis terms, each a 3-vector."""

TRIADS = ("gyro", "accel")

UNITS = {
    "gyro": {"bias": "rad/s", "scale_factor": "1", "misalignment": "rad", "quantization": "rad",
             "white_noise": "rad/sqrt(s)", "bias_instability": "rad/s", "bias_correlation_time": "s",
             "rate_random_walk": "rad/s/sqrt(s)", "rate_ramp": "rad/s^2"},
    "accel": {"bias": "m/s^2", "scale_factor": "1", "misalignment": "rad", "quantization": "m/s",
              "white_noise": "m/s/sqrt(s)", "bias_instability": "m/s^2", "bias_correlation_time": "s",
              "rate_random_walk": "m/s^2/sqrt(s)", "rate_ramp": "m/s^3"},
}

EFFECTS = ("earth_rotation", "gravity_model", "gyro_g_sensitivity", "temperature_bias", "warmup_drift",
           "scale_factor", "axis_misalignment", "vibration", "quantization", "gauss_markov_bias",
           "bias_random_walk", "gps_lever_arm", "gps_latency", "colored_gps_noise", "coning_sculling",
           "coriolis")
"""The effect vocabulary of the sim-versus-real diagnosis (``../shared/DESIGN.md``)."""


class SensorModelError(ValueError):
    """A sensor-model file or value is invalid; the message names the file and the field."""


@dataclass
class TriadModel:
    """Deterministic and stochastic error terms of one sensor triad (SI units, see module doc)."""

    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale_factor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    misalignment: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    quantization: np.ndarray = field(default_factory=lambda: np.zeros(3))
    white_noise: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_instability: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_correlation_time: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_random_walk: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_ramp: np.ndarray = field(default_factory=lambda: np.zeros(3))
    intervals: dict = field(default_factory=dict)
    """Term name -> 95 % interval array, shape (3, 2) ((3, 3, 2) for misalignment)."""
    identifiable: dict = field(default_factory=dict)
    """Term name -> (3,) bools; False: the value is the 95 % upper bound of a term the record did not identify."""
    info: dict = field(default_factory=dict)
    """Free-form fit information (goodness of fit, slope readings), written as is."""

    def matrix(self) -> np.ndarray:
        """The 3x3 matrix ``I + diag(scale_factor) + misalignment``."""
        return np.eye(3) + np.diag(self.scale_factor) + self.misalignment

    def correct(self, measured: np.ndarray) -> np.ndarray:
        """Invert the deterministic model: true values, shape (n, 3), from measured ones (same units)."""
        return np.linalg.solve(self.matrix(), (np.asarray(measured) - self.bias).T).T

    def apply(self, true: np.ndarray) -> np.ndarray:
        """Apply the deterministic model (no noise) to true values, shape (n, 3)."""
        return np.asarray(true) @ self.matrix().T + self.bias


@dataclass
class SensorModel:
    """A whole IMU model: gyro and accel triads, sample rate, provenance, simulated physics."""

    gyro: TriadModel = field(default_factory=TriadModel)
    accel: TriadModel = field(default_factory=TriadModel)
    sample_rate_hz: float = 64.0
    provenance: dict = field(default_factory=dict)
    physics: dict | None = None
    """Effect name -> parameters; None for a naive simulation (no section)."""

    def triad(self, name: str) -> TriadModel:
        """The triad called ``gyro`` or ``accel``."""
        if name not in TRIADS:
            raise KeyError(f"unknown triad {name!r}; expected one of {TRIADS}")
        return getattr(self, name)

    def copy(self) -> SensorModel:
        """A deep copy."""
        return copy.deepcopy(self)

    def with_physics(self, effect: str, **parameters) -> SensorModel:
        """A copy with ``effect`` added to (or replaced in) the physics section."""
        if effect not in EFFECTS:
            raise SensorModelError(f"physics: unknown effect {effect!r}; the vocabulary is {EFFECTS}")
        out = self.copy()
        out.physics = dict(out.physics or {})
        out.physics[effect] = _to_builtin(parameters)
        return out

    def has_physics(self, effect: str) -> bool:
        """Whether the simulation includes ``effect``."""
        return bool(self.physics) and effect in self.physics

    def to_dict(self) -> dict:
        """Plain YAML-ready mapping."""
        out = {"sensor_model_version": SCHEMA_VERSION, "sample_rate_hz": float(self.sample_rate_hz),
               "provenance": _to_builtin(self.provenance)}
        for name in TRIADS:
            out[name] = _triad_to_dict(name, self.triad(name))
        if self.physics is not None:
            out["physics"] = {k: _to_builtin(v or {}) for k, v in self.physics.items()}
        return out

    def to_kalibr(self, rostopic: str = "/imu/data_raw") -> dict:
        """Kalibr ``imu.yaml`` keys (worst axis): noise densities per sqrt(Hz), random walks per sqrt(Hz)."""
        return {
            "rostopic": rostopic,
            "update_rate": float(self.sample_rate_hz),
            # rad/s/sqrt(Hz) equals rad/sqrt(s): same numbers as our white noise N.
            "gyroscope_noise_density": float(np.max(self.gyro.white_noise)),
            "gyroscope_random_walk": float(np.max(self.gyro.rate_random_walk)),
            "accelerometer_noise_density": float(np.max(self.accel.white_noise)),
            "accelerometer_random_walk": float(np.max(self.accel.rate_random_walk)),
        }


def corrector(tri: TriadModel):
    """A callable equal to ``tri.correct`` (values (n, 3) or (3,)), with the matrix inverted once.

    For hot per-sample paths (a node correcting one message at a time), where
    ``np.linalg.solve`` per call costs more than the rest of the work.
    """
    inverse_t = np.linalg.inv(tri.matrix()).T
    bias = np.array(tri.bias, dtype=float)

    def correct(measured: np.ndarray) -> np.ndarray:
        return (np.asarray(measured, dtype=float) - bias) @ inverse_t
    return correct


def _to_builtin(obj):
    """Numpy scalars and arrays to plain Python for YAML."""
    if isinstance(obj, dict):
        return {str(k): _to_builtin(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_to_builtin(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _to_builtin(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _triad_to_dict(name: str, tri: TriadModel) -> dict:
    out = {"units": dict(UNITS[name])}
    for term in VECTOR_TERMS + ("misalignment",):
        entry = {"value": _to_builtin(getattr(tri, term))}
        if term in tri.intervals and tri.intervals[term] is not None:
            entry["interval_95"] = _to_builtin(tri.intervals[term])
        if term in tri.identifiable:
            entry["identifiable"] = [bool(v) for v in tri.identifiable[term]]
        out[term] = entry
    if tri.info:
        out["info"] = _to_builtin(tri.info)
    return out


def _array(value, shape, where: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise SensorModelError(f"{where}: expected numbers, got {value!r}") from err
    if arr.shape != shape:
        raise SensorModelError(f"{where}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise SensorModelError(f"{where}: values must be finite, got {value!r}")
    return arr


def _triad_from_dict(name: str, data, where: str) -> TriadModel:
    if data is None:
        return TriadModel()
    if not isinstance(data, dict):
        raise SensorModelError(f"{where}.{name}: expected a mapping, got {type(data).__name__}")
    tri = TriadModel()
    known = set(VECTOR_TERMS) | {"misalignment", "units", "info"}
    unknown = set(data) - known
    if unknown:
        raise SensorModelError(unknown_keys_error(f"{where}.{name}", unknown, known))
    for term in VECTOR_TERMS + ("misalignment",):
        shape = (3, 3) if term == "misalignment" else (3,)
        entry = data.get(term)
        if entry is None:
            continue
        if not isinstance(entry, dict) or "value" not in entry:
            raise SensorModelError(f"{where}.{name}.{term}: expected a mapping with 'value'")
        if set(entry) - ENTRY_KEYS:
            raise SensorModelError(unknown_keys_error(f"{where}.{name}.{term}", set(entry) - ENTRY_KEYS, ENTRY_KEYS))
        if entry["value"] is None:
            continue
        setattr(tri, term, _array(entry["value"], shape, f"{where}.{name}.{term}.value"))
        if entry.get("interval_95") is not None:
            tri.intervals[term] = _array(entry["interval_95"], shape + (2,),
                                         f"{where}.{name}.{term}.interval_95")
        if entry.get("identifiable") is not None:
            flags = entry["identifiable"]
            if not (isinstance(flags, list) and len(flags) == 3 and all(isinstance(v, bool) for v in flags)):
                raise SensorModelError(f"{where}.{name}.{term}.identifiable: expected 3 booleans, got {flags!r}")
            tri.identifiable[term] = np.array(flags)
    _check_nonnegative(tri, name, where)
    term_units = data.get("units")
    if term_units is not None and not isinstance(term_units, dict):
        raise SensorModelError(f"{where}.{name}.units: expected a mapping of term -> unit, got {term_units!r}")
    if term_units:
        for key, unit in term_units.items():
            if UNITS[name].get(key) not in (None, unit):
                raise SensorModelError(f"{where}.{name}.units.{key}: file says {unit!r}, "
                                       f"this schema uses {UNITS[name][key]!r}")
    if data.get("info") is not None and not isinstance(data["info"], dict):
        raise SensorModelError(f"{where}.{name}.info: expected a mapping, got {data['info']!r}")
    tri.info = dict(data.get("info") or {})
    return tri


def _check_nonnegative(tri: TriadModel, name: str, where: str) -> None:
    if np.any(tri.scale_factor <= -1.0):  # the model matrix would flip or vanish on that axis
        raise SensorModelError(f"{where}.{name}.scale_factor.value: must be > -1 on every axis, "
                               f"got {tri.scale_factor}")
    for term in ("quantization", "white_noise", "bias_instability", "bias_correlation_time",
                 "rate_random_walk", "rate_ramp"):
        if np.any(getattr(tri, term) < 0):
            raise SensorModelError(f"{where}.{name}.{term}.value: must be >= 0, got {getattr(tri, term)}")


def from_dict(data, where: str = "<sensor model>") -> SensorModel:
    """Validate and build a :class:`SensorModel`; errors name ``where`` and the field."""
    if not isinstance(data, dict):
        raise SensorModelError(f"{where}: expected a mapping at the top level")
    if set(data) - set(TOP_KEYS):
        raise SensorModelError(unknown_keys_error(where, set(data) - set(TOP_KEYS), TOP_KEYS))
    version = data.get("sensor_model_version", SCHEMA_VERSION)
    if version != SCHEMA_VERSION:
        raise SensorModelError(f"{where}: sensor_model_version {version!r} is not supported "
                               f"(this code reads {SCHEMA_VERSION})")
    rate = data.get("sample_rate_hz", 64.0)
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= MAX_SAMPLE_RATE_HZ:
        raise SensorModelError(f"{where}.sample_rate_hz: expected a number in (0, {MAX_SAMPLE_RATE_HZ:g}] Hz, "
                               f"got {rate!r}")
    for section in ("provenance",):
        if data.get(section) is not None and not isinstance(data[section], dict):
            raise SensorModelError(f"{where}.{section}: expected a mapping, got {data[section]!r}")
    physics = data.get("physics", None)
    if "physics" in data:
        physics = validate_physics(physics, where)
    return SensorModel(gyro=_triad_from_dict("gyro", data.get("gyro"), where),
                       accel=_triad_from_dict("accel", data.get("accel"), where),
                       sample_rate_hz=float(rate), provenance=dict(data.get("provenance") or {}),
                       physics=physics)


def validate_physics(physics, where: str) -> dict:
    """A ``physics`` section (mapping, or a list of names for physical defaults) checked against
    :data:`EFFECTS`; returns effect -> parameters. Errors name ``where`` and the effect."""
    if physics is None:
        return {}
    if isinstance(physics, list):  # a bare list of names: physical defaults
        physics = {name: {} for name in physics}
    if not isinstance(physics, dict):
        raise SensorModelError(f"{where}.physics: expected a mapping of effect -> parameters")
    for effect, params in physics.items():
        if effect not in EFFECTS:
            raise SensorModelError(f"{where}.physics.{effect}: unknown effect; the vocabulary is "
                                   f"{', '.join(EFFECTS)}")
        if params is not None and not isinstance(params, dict):
            raise SensorModelError(f"{where}.physics.{effect}: parameters must be a mapping")
    return {k: dict(v or {}) for k, v in physics.items()}


def load(path) -> SensorModel:
    """Read and validate a sensor-model YAML file."""
    data = read_yaml_file(path, SensorModelError, "sensor-model file")
    return from_dict(data, where=str(path))


def save(model: SensorModel, path) -> Path:
    """Write ``model`` as YAML to ``path`` (parent folders created)."""
    from nav_core.outputs import atomic_write_text  # never a half-written model
    return atomic_write_text(path, yaml.safe_dump(model.to_dict(), sort_keys=False, width=100))


def save_kalibr(model: SensorModel, path, rostopic: str = "/imu/data_raw") -> Path:
    """Write Kalibr's ``imu.yaml`` for ``model``."""
    from nav_core.outputs import atomic_write_text
    return atomic_write_text(path, yaml.safe_dump(model.to_kalibr(rostopic), sort_keys=False))


def _created_utc() -> str:
    """Now (or ``SOURCE_DATE_EPOCH``, seconds since 1970) in UTC, ISO 8601 to the second."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    when = _dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc) if epoch.isdigit() else None
    return (when or _dt.datetime.now(_dt.timezone.utc)).isoformat(timespec="seconds")


def stamp_provenance(model: SensorModel, tool: str, source: str, **extra) -> None:
    """Record which tool made ``model`` from which source, and when (UTC; ``SOURCE_DATE_EPOCH`` when set, as
    reproducible builds do, so that two runs on the same input write the same bytes)."""
    model.provenance.update({"tool": tool, "source": str(source), "created_utc": _created_utc(),
                             **_to_builtin(extra)})
