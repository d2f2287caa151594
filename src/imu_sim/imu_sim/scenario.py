"""Scenario YAML: where, which trajectory, GPS settings, temperature; loaded and validated with clear errors.

Exactly one trajectory source: ``segments: [...]``, ``trajectory: <truth CSV>`` (or
``trajectory: paper_drive``), ``gnss_track: <file>``, ``static_segments: [...]``.
Paths are relative to the YAML file. See src/imu_sim/README.md for every key.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from nav_core.recording import RecordingError, read_trajectory_csv
from nav_core.sensor_model import SensorModelError, validate_physics

from imu_sim import trajectory as traj_mod
from imu_sim.errors import TERMS
from imu_sim.gnss import GpsConfig

KNOWN_KEYS = {"name", "description", "latitude_deg", "longitude_deg", "height_m", "segments", "trajectory",
              "gnss_track", "static_segments", "yaw0_deg", "duration_s", "rate_hz", "gps", "gps_lever_arm_m",
              "temperature", "physics", "error_terms", "sensor_model", "seed", "notes"}
SOURCES = ("segments", "trajectory", "gnss_track", "static_segments")
BUILTIN_TRAJECTORIES = ("paper_drive",)


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
    name: str = "scenario"
    where: str = "<scenario>"


def _num(data, key, where, default=None, positive=False):
    value = data.get(key, default)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: {key}: expected a number, got {value!r}")
    if positive and not value > 0:
        raise ScenarioError(f"{where}: {key}: must be > 0, got {value!r}")
    return float(value)


def _gps(data, where) -> GpsConfig:
    if data is None:
        return GpsConfig()
    if data is False:
        return GpsConfig(enabled=False)
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: gps: expected a mapping")
    unknown = set(data) - {"rate_hz", "sigma_m", "status", "outages", "outage_mode", "enabled"}
    if unknown:
        raise ScenarioError(f"{where}: gps: unknown key(s) {sorted(unknown)}")
    cfg = GpsConfig(rate_hz=_num(data, "rate_hz", f"{where}: gps", 1.0, positive=True),
                    status=int(data.get("status", 0)), outage_mode=str(data.get("outage_mode", "nofix")),
                    enabled=bool(data.get("enabled", True)))
    try:
        cfg.sigma_m = np.broadcast_to(np.asarray(data.get("sigma_m", cfg.sigma_m), float), (3,)).copy()
        cfg.outages = [tuple(map(float, o)) for o in data.get("outages", [])]
    except (TypeError, ValueError) as err:
        raise ScenarioError(f"{where}: gps: sigma_m must be a number or [e, n, u]; outages [[t0, t1], ...] ({err})")
    if any(len(o) != 2 or o[1] <= o[0] for o in cfg.outages):
        raise ScenarioError(f"{where}: gps.outages: each must be [t0, t1] with t1 > t0")
    if cfg.outage_mode not in ("nofix", "drop"):
        raise ScenarioError(f"{where}: gps.outage_mode: 'nofix' or 'drop', got {cfg.outage_mode!r}")
    return cfg


def from_dict(data, where: str = "<scenario>", base_dir: Path = Path(".")) -> Scenario:
    """Validate a scenario mapping; relative paths resolve against ``base_dir``."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: expected a mapping at the top level")
    unknown = set(data) - KNOWN_KEYS
    if unknown:
        raise ScenarioError(f"{where}: unknown key(s) {sorted(unknown)}; known: {sorted(KNOWN_KEYS)}")
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
    sc = Scenario(source=source, spec=spec, where=where, name=str(data.get("name", Path(where).stem)))
    sc.latitude_deg = _num(data, "latitude_deg", where)
    sc.longitude_deg = _num(data, "longitude_deg", where)
    sc.height_m = _num(data, "height_m", where, 0.0)
    if source in ("segments", "static_segments") and (sc.latitude_deg is None or sc.longitude_deg is None):
        raise ScenarioError(f"{where}: latitude_deg and longitude_deg are required with {source}")
    if sc.latitude_deg is not None and not -90 <= sc.latitude_deg <= 90:
        raise ScenarioError(f"{where}: latitude_deg: must be within [-90, 90], got {sc.latitude_deg}")
    sc.yaw0_deg = _num(data, "yaw0_deg", where, 0.0)
    sc.duration_s = _num(data, "duration_s", where, None, positive=True)
    sc.rate_hz = _num(data, "rate_hz", where, 64.0, positive=True)
    sc.gps = _gps(data.get("gps"), where)
    if data.get("gps_lever_arm_m") is not None:
        try:
            sc.gps_lever_arm_m = np.broadcast_to(np.asarray(data["gps_lever_arm_m"], float), (3,)).copy()
        except (TypeError, ValueError) as err:
            raise ScenarioError(f"{where}: gps_lever_arm_m: expected [x, y, z] in m ({err})") from err
    sc.temperature = _temperature(data.get("temperature"), where)
    sc.physics = _physics(data.get("physics"), where)
    terms = data.get("error_terms")
    if terms is not None:
        bad = [t for t in terms if t not in TERMS]
        if bad:
            raise ScenarioError(f"{where}: error_terms: unknown {bad}; known: {TERMS}")
        sc.error_terms = tuple(terms)
    if data.get("sensor_model"):
        sc.sensor_model = (base_dir / str(data["sensor_model"])).resolve()
    if data.get("seed") is not None:
        sc.seed = int(data["seed"])
    return sc


def _temperature(data, where):
    if data is None:
        return None
    if isinstance(data, (int, float)) and not isinstance(data, bool):
        return {"start_c": float(data), "end_c": float(data), "time_constant_s": 1.0}
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: temperature: a number (deg C) or {{start_c, end_c, time_constant_s}}")
    unknown = set(data) - {"start_c", "end_c", "time_constant_s"}
    if unknown:
        raise ScenarioError(f"{where}: temperature: unknown key(s) {sorted(unknown)}")
    start = _num(data, "start_c", f"{where}: temperature", 25.0)
    return {"start_c": start, "end_c": _num(data, "end_c", f"{where}: temperature", start),
            "time_constant_s": _num(data, "time_constant_s", f"{where}: temperature", 600.0, positive=True)}


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
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ScenarioError(f"{path}: scenario file not found") from None
    except yaml.YAMLError as err:
        raise ScenarioError(f"{path}: not valid YAML: {err}") from err
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
    truth = read_trajectory_csv(sc.spec, strict=True)
    frame = None
    if sc.latitude_deg is not None and sc.longitude_deg is not None:
        from nav_core.earth import LocalFrame
        frame = LocalFrame(sc.latitude_deg, sc.longitude_deg, sc.height_m)
    return traj_mod.truth_csv_trajectory(truth, frame)
