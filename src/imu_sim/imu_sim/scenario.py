"""Scenario YAML: where, which trajectory, GPS settings, temperature; loaded and validated with clear errors.

Exactly one trajectory source: ``segments: [...]``, ``trajectory: <truth CSV>`` (or
``trajectory: paper_drive``), ``gnss_track: <file>``, ``static_segments: [...]``.
Paths are relative to the YAML file. See src/imu_sim/README.md for every key.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nav_core.params import did_you_mean, read_yaml_file, unknown_keys_error
from nav_core.recording import RecordingError, read_trajectory_csv
from nav_core.sensor_model import SensorModelError, validate_physics

from imu_sim import faults as faults_mod
from imu_sim import trajectory as traj_mod
from imu_sim.errors import TERMS
from imu_sim.gnss import GpsConfig

KNOWN_KEYS = {"name", "description", "latitude_deg", "longitude_deg", "height_m", "segments", "trajectory",
              "gnss_track", "static_segments", "yaw0_deg", "duration_s", "rate_hz", "gps", "gps_lever_arm_m",
              "temperature", "physics", "error_terms", "sensor_model", "seed", "notes", "faults",
              "attitude_tolerance_deg", "moves_known"}
SOURCES = ("segments", "trajectory", "gnss_track", "static_segments")
BUILTIN_TRAJECTORIES = ("paper_drive",)
SEGMENT_KEYS = {"stand": (), "cruise": (), "stop": (), "accelerate": ("speed_mps",), "turn": ("angle_deg",)}
"""Keys each segment type takes besides ``type`` and ``duration_s``."""
STATIC_KEYS = ("t0", "t1", "roll_deg", "pitch_deg", "yaw_deg", "rate_dps", "axis_body")
GPS_KEYS = ("rate_hz", "sigma_m", "status", "outages", "outage_mode", "enabled")
MAX_RATE_HZ = 10_000.0
"""Highest IMU rate simulated, Hz (MEMS IMUs output at most a few kHz)."""
MAX_DURATION_S = 86400.0
"""Longest scenario, s (a road drive is built on a 0.01 s grid first)."""
MAX_SAMPLES = 50_000_000
"""Most IMU samples one simulation makes (about 10 GB of working memory)."""


class ScenarioError(ValueError):
    """A scenario file or value is invalid; the message names the file and the field."""


@dataclass
class Scenario:
    """A validated scenario (SI units; degrees only in the datum fields, as in the YAML)."""

    source: str
    spec: object
    latitude_deg: float | None = None
    longitude_deg: float | None = None
    height_m: float = 0.0
    yaw0_deg: float = 0.0
    duration_s: float | None = None
    rate_hz: float = 64.0
    gps: GpsConfig = field(default_factory=GpsConfig)
    gps_lever_arm_m: np.ndarray | None = None
    temperature: dict | None = None
    physics: dict | None = None
    error_terms: tuple = TERMS
    sensor_model: Path | None = None
    seed: int | None = None
    faults: tuple = ()
    """Sensor faults injected into the IMU output (:mod:`imu_sim.faults`)."""
    name: str = "scenario"
    where: str = "<scenario>"
    attitude_tolerance_deg: float = 1.0
    """How far each static segment's fixture may be from its stated attitude (deg); the diagnosis treats it as a
    nuisance (:mod:`imu_sim.diagnose.fixture`)."""
    moves_known: bool = False
    """Whether the moves between static segments follow the simulator's own profile (a motorised fixture or table
    driven by this scenario); by default they are the operator's or the table controller's, and the diagnosis
    treats them as carrying no reference (:mod:`imu_sim.diagnose.unstated`)."""


def _num(data, key, where, default=None, positive=False, low=None, high=None, prefix=""):
    """A finite number (within [low, high]; > 0 with ``positive``), else ScenarioError naming file and field.

    ``prefix`` is the path of ``data`` in the file (``gps.``, ``segments[2].``).
    """
    value = data.get(key)
    if value is None:  # absent or null: the default
        return None if default is None else float(default)
    rng = f" in [{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}]"
    want = ("a number > 0" if positive else "a number") + (rng if low is not None or high is not None else "")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ScenarioError(f"{where}: {prefix}{key}: expected {want}, got {value!r}")
    if (positive and not value > 0) or (low is not None and value < low) or (high is not None and value > high):
        raise ScenarioError(f"{where}: {prefix}{key}: expected {want}, got {value!r}")
    return float(value)


def _vector(value, key, where, nonnegative=False, prefix=""):
    """A finite 3-vector (a scalar is broadcast), else ScenarioError naming the field."""
    try:
        arr = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    except (TypeError, ValueError):
        arr = None
    if arr is None or isinstance(value, bool) or not np.all(np.isfinite(arr)) or (nonnegative and np.any(arr < 0)):
        kind = "finite numbers >= 0" if nonnegative else "finite numbers"
        raise ScenarioError(f"{where}: {prefix}{key}: expected a number or [x, y, z] of {kind}, got {value!r}")
    return arr


def _check_keys(data, known, where):
    unknown = set(data) - set(known)
    if unknown:
        raise ScenarioError(unknown_keys_error(where, unknown, known))


def _gps(data, where) -> GpsConfig:
    if data is None:
        return GpsConfig()
    if data is False:
        return GpsConfig(enabled=False)
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: gps: expected a mapping (or false), got {data!r}")
    _check_keys(data, GPS_KEYS, f"{where}: gps")  # "file: gps: unknown key(s) ..."
    sub, pre = where, "gps."
    status = data.get("status", 0)
    if isinstance(status, bool) or status not in (-1, 0, 1, 2):
        raise ScenarioError(f"{sub}: {pre}status: expected one of [-1, 0, 1, 2] (NavSatStatus), got {status!r}")
    enabled = data.get("enabled", True)
    if not isinstance(enabled, bool):
        raise ScenarioError(f"{sub}: {pre}enabled: expected true or false, got {enabled!r}")
    cfg = GpsConfig(rate_hz=_num(data, "rate_hz", sub, 1.0, positive=True, high=100.0, prefix=pre),
                    status=int(status),
                    outage_mode=str(data.get("outage_mode", "nofix")), enabled=enabled)
    cfg.sigma_m = _vector(data.get("sigma_m", cfg.sigma_m), "sigma_m", sub, nonnegative=True, prefix=pre)
    outages = data.get("outages", [])
    if not isinstance(outages, list):
        raise ScenarioError(f"{sub}: {pre}outages: expected [[t0, t1], ...] in s, got {outages!r}")
    for i, o in enumerate(outages):
        ok = isinstance(o, (list, tuple)) and len(o) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in o)
        if not ok or not o[1] > o[0]:
            raise ScenarioError(f"{sub}: {pre}outages[{i}]: expected [t0, t1] in s with t1 > t0, got {o!r}")
    cfg.outages = [(float(a), float(b)) for a, b in outages]
    if cfg.outage_mode not in ("nofix", "drop"):
        raise ScenarioError(f"{sub}: {pre}outage_mode: expected 'nofix' or 'drop', got {cfg.outage_mode!r}")
    return cfg


def _segments(spec, where):
    """Check every road segment: its type, its keys, and each value's range."""
    for i, seg in enumerate(spec):
        pre = f"segments[{i}]."
        at = f"{where}: segments[{i}]"
        kind = seg.get("type")
        if not isinstance(kind, str) or kind not in SEGMENT_KEYS:
            raise ScenarioError(f"{at}.type: expected one of {list(SEGMENT_KEYS)}, got {kind!r}"
                                f"{did_you_mean(kind, SEGMENT_KEYS)}")
        known = ("type", "duration_s") + SEGMENT_KEYS[kind]
        unknown = set(seg) - set(known)
        if unknown:
            others = {k for keys in SEGMENT_KEYS.values() for k in keys} - set(known)
            name = sorted(unknown)[0]
            hint = (f" ({name} applies to another segment type)" if name in others
                    else did_you_mean(name, known))
            raise ScenarioError(f"{at} ({kind}): unknown key {name!r}{hint}; {kind} segments take {list(known)}")
        _num(seg, "duration_s", where, None, positive=True, high=MAX_DURATION_S, prefix=pre)
        if seg.get("duration_s") is None:
            raise ScenarioError(f"{at}.duration_s: required (a number > 0, s)")
        _num(seg, "speed_mps", where, None, low=0.0, high=350.0, prefix=pre)
        _num(seg, "angle_deg", where, None, low=-3600.0, high=3600.0, prefix=pre)
    total = sum(float(seg["duration_s"]) for seg in spec)
    if total > MAX_DURATION_S:
        raise ScenarioError(f"{where}: segments: {total:g} s in all; at most {MAX_DURATION_S:g} s")


def _static_segments(spec, where):
    for i, seg in enumerate(spec):
        pre = f"static_segments[{i}]."
        _check_keys(seg, STATIC_KEYS, f"{where}: static_segments[{i}]")
        for key in ("t0", "t1"):
            if seg.get(key) is None:
                raise ScenarioError(f"{where}: {pre}{key}: required (a number, s)")
            _num(seg, key, where, low=0.0, high=MAX_DURATION_S, prefix=pre)
        for key in ("roll_deg", "pitch_deg", "yaw_deg"):
            _num(seg, key, where, None, low=-360.0, high=360.0, prefix=pre)
        _num(seg, "rate_dps", where, None, low=-1e5, high=1e5, prefix=pre)
        if "axis_body" in seg and not np.linalg.norm(_vector(seg["axis_body"], "axis_body", where, prefix=pre)) > 0:
            raise ScenarioError(f"{where}: {pre}axis_body: must not be [0, 0, 0]")


def _seed(value, where):
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ScenarioError(f"{where}: seed: expected an integer >= 0, got {value!r}")
    return value


def from_dict(data, where: str = "<scenario>", base_dir: Path = Path(".")) -> Scenario:
    """Validate a scenario mapping; relative paths resolve against ``base_dir``."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: expected a mapping at the top level")
    _check_keys(data, KNOWN_KEYS, where)
    given = [k for k in SOURCES if data.get(k) is not None]
    if len(given) != 1:
        raise ScenarioError(f"{where}: give exactly one trajectory source of {SOURCES}, got {given or 'none'}")
    source = given[0]
    spec = data[source]
    if source in ("trajectory", "gnss_track"):
        if not isinstance(spec, str):
            raise ScenarioError(f"{where}: {source}: expected a file path (string), got {spec!r}")
        if not (source == "trajectory" and spec in BUILTIN_TRAJECTORIES):
            spec = (base_dir / spec).resolve()
            if not spec.exists():
                raise ScenarioError(f"{where}: {source}: file not found: {spec}")
    elif not isinstance(spec, list) or not spec or not all(isinstance(s, dict) for s in spec):
        raise ScenarioError(f"{where}: {source}: expected a non-empty list of mappings")
    elif source == "segments":
        _segments(spec, where)
    else:
        _static_segments(spec, where)
    sc = Scenario(source=source, spec=spec, where=where, name=str(data.get("name", Path(where).stem)))
    sc.latitude_deg = _num(data, "latitude_deg", where, low=-90.0, high=90.0)
    sc.longitude_deg = _num(data, "longitude_deg", where, low=-180.0, high=360.0)
    sc.height_m = _num(data, "height_m", where, 0.0, low=-12_000.0, high=100_000.0)
    if source in ("segments", "static_segments") and (sc.latitude_deg is None or sc.longitude_deg is None):
        raise ScenarioError(f"{where}: latitude_deg and longitude_deg are required with {source}")
    sc.yaw0_deg = _num(data, "yaw0_deg", where, 0.0, low=-360.0, high=360.0)
    sc.attitude_tolerance_deg = _num(data, "attitude_tolerance_deg", where, 1.0, low=0.0, high=90.0)
    sc.moves_known = data.get("moves_known", False)
    if not isinstance(sc.moves_known, bool):
        raise ScenarioError(f"{where}: moves_known: expected true or false, got {sc.moves_known!r}")
    sc.duration_s = _num(data, "duration_s", where, None, positive=True, high=MAX_DURATION_S)
    sc.rate_hz = _num(data, "rate_hz", where, 64.0, positive=True, high=MAX_RATE_HZ)
    sc.gps = _gps(data.get("gps"), where)
    if data.get("gps_lever_arm_m") is not None:
        sc.gps_lever_arm_m = _vector(data["gps_lever_arm_m"], "gps_lever_arm_m", where)
    sc.temperature = _temperature(data.get("temperature"), where)
    sc.physics = _physics(data.get("physics"), where)
    terms = data.get("error_terms")
    if terms is not None:
        if not isinstance(terms, list):
            raise ScenarioError(f"{where}: error_terms: expected a list of {list(TERMS)}, got {terms!r}")
        bad = [t for t in terms if t not in TERMS]
        if bad:
            raise ScenarioError(f"{where}: error_terms: unknown {bad}{did_you_mean(bad[0], TERMS)}; "
                                f"known: {list(TERMS)}")
        sc.error_terms = tuple(terms)
    if data.get("sensor_model"):
        sc.sensor_model = (base_dir / str(data["sensor_model"])).resolve()
        if not sc.sensor_model.exists():
            raise ScenarioError(f"{where}: sensor_model: file not found: {sc.sensor_model}")
    sc.seed = _seed(data.get("seed"), where)
    try:
        sc.faults = faults_mod.parse(data.get("faults"), where)
    except faults_mod.FaultError as err:
        raise ScenarioError(str(err)) from None
    return sc


def _temperature(data, where):
    if data is None:
        return None
    if isinstance(data, (int, float)) and not isinstance(data, bool):
        value = _num({"temperature": data}, "temperature", where, low=-100.0, high=200.0)
        return {"start_c": value, "end_c": value, "time_constant_s": 1.0}
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: temperature: a number (deg C) or {{start_c, end_c, time_constant_s}}")
    _check_keys(data, ("start_c", "end_c", "time_constant_s"), f"{where}: temperature")
    pre = "temperature."
    start = _num(data, "start_c", where, 25.0, low=-100.0, high=200.0, prefix=pre)
    return {"start_c": start, "end_c": _num(data, "end_c", where, start, low=-100.0, high=200.0, prefix=pre),
            "time_constant_s": _num(data, "time_constant_s", where, 600.0, positive=True, prefix=pre)}


def _physics(data, where):
    if data is None:
        return None
    try:
        return validate_physics(data, where)
    except SensorModelError as err:
        raise ScenarioError(str(err)) from None


def load(path) -> Scenario:
    """Read and validate a scenario YAML file."""
    path = Path(path)
    data = read_yaml_file(path, ScenarioError, "scenario file")
    return from_dict(data, where=str(path), base_dir=path.parent)


def temperature_profile(sc: Scenario, t: np.ndarray):
    """Temperature (deg C) at times t (s): end + (start - end) exp(-t / time_constant); None if unset."""
    if sc.temperature is None:
        return None
    p = sc.temperature
    return p["end_c"] + (p["start_c"] - p["end_c"]) * np.exp(-(t - t[0]) / p["time_constant_s"])


def build_trajectory(sc: Scenario) -> traj_mod.TruthTrajectory:
    """The truth trajectory of a scenario (cropped to ``duration_s`` when given)."""
    try:
        traj = _build(sc)
    except (ValueError, RecordingError) as err:
        if isinstance(err, ScenarioError):
            raise
        raise ScenarioError(f"{sc.where}: {sc.source}: {err}") from err
    if sc.duration_s is not None:
        traj.t1 = min(traj.t1, traj.t0 + sc.duration_s)
    return traj


def _build(sc: Scenario):
    if sc.source == "segments":
        return traj_mod.segments_trajectory(sc.spec, sc.latitude_deg, sc.longitude_deg, sc.height_m, sc.yaw0_deg)
    if sc.source == "static_segments":
        return traj_mod.static_trajectory(sc.spec, sc.latitude_deg, sc.longitude_deg, sc.height_m)
    if sc.source == "gnss_track":
        return traj_mod.gnss_track_trajectory(sc.spec, sc.duration_s)
    if sc.spec == "paper_drive":
        datum = {k: v for k, v in (("lat0_deg", sc.latitude_deg), ("lon0_deg", sc.longitude_deg),
                                   ("h0_m", sc.height_m)) if v is not None}
        return traj_mod.paper_drive(**datum)
    truth = _check_truth_rows(read_trajectory_csv(sc.spec, strict=True), sc.spec)
    frame = None
    if sc.latitude_deg is not None and sc.longitude_deg is not None:
        from nav_core.earth import LocalFrame
        frame = LocalFrame(sc.latitude_deg, sc.longitude_deg, sc.height_m)
    return traj_mod.truth_csv_trajectory(truth, frame)


def _check_truth_rows(truth, path):
    """The truth without exact repeats of a row; ValueError naming the file, line and column of the first row the
    splines cannot take: a value that is not a finite number, or a time not after the row before with other
    values (read strictly: line = row + 2)."""
    columns = {"t": truth.t, "lat_deg": truth.lat, "lon_deg": truth.lon, "h_m": truth.h, "roll_deg": truth.roll,
               "pitch_deg": truth.pitch, "yaw_deg": truth.yaw}
    for name, values in columns.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            raise ValueError(f"{path}: line {bad[0] + 2}: column {name!r} is not a finite number "
                             f"({len(bad)} row(s)); the truth needs every value")
    table = np.column_stack(list(columns.values()))
    repeat = np.concatenate(([False], np.all(table[1:] == table[:-1], axis=1)))  # a row written twice: harmless
    back = np.flatnonzero((np.diff(truth.t) <= 0) & ~repeat[1:])
    if len(back):
        k = int(back[0])
        raise ValueError(f"{path}: line {k + 3}: t = {truth.t[k + 1]:.9g} s is not after line {k + 2}'s "
                         f"{truth.t[k]:.9g} s ({len(back)} such row(s)); the truth must go forward in time")
    if not repeat.any():
        return truth
    keep = ~repeat
    return dataclasses.replace(
        truth, t=truth.t[keep], lat=truth.lat[keep], lon=truth.lon[keep], h=truth.h[keep], roll=truth.roll[keep],
        pitch=truth.pitch[keep], yaw=truth.yaw[keep],
        velocity_n=None if truth.velocity_n is None else truth.velocity_n[keep],
        extra={k: v[keep] for k, v in truth.extra.items()})
