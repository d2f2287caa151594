"""The simulator API: scenario (+ sensor model, seed) in, recording out.

``simulate(scenario, model, seed)`` returns a :class:`SimResult` (truth, IMU,
GNSS, temperature, raw increments, BP3010 bytes); ``write_outputs`` writes the
rosbag2 bag, CSVs, truth CSV and ``bp3010.bin``.

Measurement model per sample (mean rates over the interval, SI)::

    measured = M (true + motion effects) + bias + sensor effects + stochastic terms
    increment = measured * dt, rounded to the LSB with the remainder carried

with M = I + diag(scale_factor) + misalignment. Motion effects are ``vibration`` and
``coning_sculling``; sensor effects the other entries of :data:`effects.SENSOR_EFFECTS`.
Time: CSVs use t from the trajectory start (0); the bag stamps t + :data:`BAG_EPOCH_S`.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from nav_core import recording
from nav_core.recording import GnssRecording, ImuRecording, Trajectory
from nav_core.sensor_model import SensorModel, load as load_model

from imu_sim import effects, errors, faults, kinematics
from imu_sim.gnss import GpsEffects, simulate_gnss
from imu_sim.scenario import (MAX_RATE_HZ, MAX_SAMPLES, Scenario, ScenarioError, build_trajectory,
                              load as load_scenario, temperature_profile)

LOG = logging.getLogger(__name__)

BAG_EPOCH_S = 1_700_000_000.0
"""Bag stamps are scenario time + this (2023-11-14T22:13:20Z), so /clock replay is unambiguous."""
MOTION_EFFECTS = ("vibration", "coning_sculling")
FORMATS = ("bag", "csv", "all")


@dataclass
class SimResult:
    """Everything one simulation made (SI; times from the trajectory start)."""

    truth: Trajectory
    imu: ImuRecording
    gnss: GnssRecording | None
    dtheta: np.ndarray
    dv: np.ndarray
    bp3010: bytes | None
    model: SensorModel
    physics: dict | None
    seed: int
    rate_hz: float
    error_terms: tuple = errors.TERMS
    info: dict = field(default_factory=dict)


def merge_physics(model_physics: dict | None, scenario_physics: dict | None) -> dict | None:
    """The model's physics section with the scenario's entries added (scenario wins); None if both are None."""
    if model_physics is None and scenario_physics is None:
        return None
    out = {k: dict(v or {}) for k, v in (model_physics or {}).items()}
    out.update({k: dict(v or {}) for k, v in (scenario_physics or {}).items()})
    return out


def _resolve_model(sc: Scenario, model) -> SensorModel:
    if isinstance(model, SensorModel):
        return model.copy()
    if model is not None:
        return load_model(model)
    if sc.sensor_model is not None:
        return load_model(sc.sensor_model)
    return SensorModel()


def imu_measurements(t, dt, dtheta, dv, model: SensorModel, physics, temp_c, seed: int, terms=errors.TERMS):
    """Measured increments (dtheta rad, dv m/s), each (n, 3), from exact increments and the error model."""
    gyro_true, accel_true = dtheta / dt, dv / dt
    ctx = effects.EffectContext(t, dt, gyro_true, accel_true, temp_c, seed)
    motion = {k: v for k, v in (physics or {}).items() if k in MOTION_EFFECTS}
    sensor = {k: v for k, v in (physics or {}).items() if k not in MOTION_EFFECTS}
    g_motion, a_motion = effects.sensor_errors(motion, ctx)
    g_sensor, a_sensor = effects.sensor_errors(sensor, ctx)
    out = []
    for name, true, mot, sen in (("gyro", gyro_true, g_motion, g_sensor), ("accel", accel_true, a_motion, a_sensor)):
        tri = model.triad(name)
        rate = (true + mot) @ errors.deterministic_matrix(tri, terms).T + sen
        if "bias" in terms:
            rate = rate + tri.bias
        rate = rate + errors.stochastic_rate(name, tri, t, dt, seed, terms)
        inc = rate * dt
        if "quantization" in terms and np.any(tri.quantization > 0):
            inc = errors.quantize_carry(inc, errors.quantization_lsb(tri))
        out.append(inc)
    return out[0], out[1]


def encode_bp3010(dtheta, dv):
    """BP3010 byte stream via imu_driver's codec (increments rounded to its LSBs, remainder carried)."""
    try:
        from imu_driver.bp3010_codec import FrameFormat, encode_stream
    except ImportError as err:
        LOG.warning("imu_driver.bp3010_codec not importable (%s): no BP3010 byte stream", err)
        return None
    fmt = FrameFormat()
    dth = errors.quantize_carry(dtheta, np.full(3, fmt.dtheta_lsb_rad))
    dvq = errors.quantize_carry(dv, np.full(3, fmt.dv_lsb_mps))
    return encode_stream(dth, dvq, fmt)


def simulate(scenario, model=None, seed: int | None = None, rate_hz: float | None = None,
             terms=None, with_bytes: bool = True, temp_c=None) -> SimResult:
    """Simulate a scenario (a :class:`Scenario` or a YAML path) with a sensor model (object, path or None).

    ``temp_c`` (n,) deg C, when given, replaces the scenario's temperature profile (a logged temperature).
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    seed = int(seed if seed is not None else (sc.seed if sc.seed is not None else 0))
    if seed < 0:
        raise ScenarioError(f"seed: expected an integer >= 0, got {seed}")
    rate = float(rate_hz if rate_hz is not None else sc.rate_hz)
    if not 0 < rate <= MAX_RATE_HZ:  # also NaN
        raise ScenarioError(f"rate_hz: expected a number in (0, {MAX_RATE_HZ:g}] Hz, got {rate_hz}")
    terms = tuple(terms) if terms is not None else sc.error_terms
    span = _planned_duration_s(sc)
    if span is not None and span * rate > MAX_SAMPLES:  # before building anything that large
        raise ScenarioError(f"{sc.where}: {span:.6g} s at rate_hz {rate:g} is {span * rate:.3g} IMU samples; "
                            f"at most {MAX_SAMPLES:.3g} (lower rate_hz or duration_s)")
    base = _resolve_model(sc, model)
    base.physics = merge_physics(base.physics, sc.physics)
    try:
        mdl = effects.apply_model_overrides(base)
        traj = build_trajectory(sc)
        return _simulate(sc, mdl, traj, seed, rate, terms, with_bytes, temp_c)
    except effects.EffectError as err:  # name the files the physics came from (same error type)
        source = f"{sc.where}" + (f" or {model}" if isinstance(model, (str, Path)) else "")
        raise effects.EffectError(f"{source}: {err}") from None


def _planned_duration_s(sc: Scenario) -> float | None:
    """The scenario's length (s) known before its trajectory is built, None when only the trajectory knows."""
    spans = []
    if sc.source == "segments":
        spans.append(sum(float(seg.get("duration_s", 0.0)) for seg in sc.spec))
    elif sc.source == "static_segments":
        spans.append(max(float(seg["t1"]) for seg in sc.spec))
    if sc.duration_s is not None:
        spans.append(sc.duration_s)
    return min(spans) if spans else None


def _simulate(sc, mdl, traj, seed, rate, terms, with_bytes, temp_c) -> SimResult:
    n = traj.duration * rate
    if n > MAX_SAMPLES:
        raise ScenarioError(f"{sc.where}: {traj.duration:.6g} s at rate_hz {rate:g} is {n:.3g} IMU samples; "
                            f"at most {MAX_SAMPLES:.3g} (lower rate_hz or duration_s)")
    dt = 1.0 / rate
    t = kinematics.sample_times(traj, rate)
    dtheta0, dv0 = kinematics.increments(traj, t, dt, kinematics.Physics.from_effects(mdl.physics))
    temp = temperature_profile(sc, t) if temp_c is None else _fit_length(np.asarray(temp_c, float), len(t))
    dtheta, dv = imu_measurements(t, dt, dtheta0, dv0, mdl, mdl.physics, temp, seed, terms)
    t_rel = t - traj.t0
    if sc.faults:  # after the sensor's own errors, as a failing unit adds them
        rates = faults.apply(sc.faults, t_rel, np.hstack([dtheta, dv]) / dt, np.random.default_rng([seed, 26]))
        dtheta, dv = rates[:, :3] * dt, rates[:, 3:] * dt
    imu = ImuRecording(t_rel, dtheta / dt, dv / dt, temp, source=f"imu_sim:{sc.name}")
    gnss = None
    if sc.gps.enabled:
        gnss = simulate_gnss(traj, sc.gps, GpsEffects.from_physics(mdl.physics, sc.gps_lever_arm_m), seed)
        gnss.t = gnss.t - traj.t0
    truth = traj.sample(traj.t0 + dt * np.arange(len(t) + 1))
    truth.t = truth.t - traj.t0
    data = encode_bp3010(dtheta, dv) if with_bytes else None
    info = {"scenario": sc.where, "name": sc.name, "seed": seed, "rate_hz": rate, "error_terms": list(terms),
            "physics": mdl.physics, "bag_epoch_s": BAG_EPOCH_S, "duration_s": float(traj.duration),
            "time_convention": "sample k covers (t_k - dt, t_k]; CSV t from 0, bag stamp = t + bag_epoch_s"}
    return SimResult(truth, imu, gnss, dtheta, dv, data, mdl, mdl.physics, seed, rate, terms, info)


def _fit_length(values: np.ndarray, n: int) -> np.ndarray:
    """``values`` cut or padded (last value held) to length n."""
    if len(values) >= n:
        return values[:n]
    return np.concatenate([values, np.full(n - len(values), values[-1])])


def _shift(rec, offset):
    out = type(rec)(**{k: getattr(rec, k) for k in rec.__dataclass_fields__})
    out.t = rec.t + offset
    return out


def write_outputs(res: SimResult, out_dir, fmt: str = "all", storage: str = "sqlite3") -> dict:
    """Write the recording; returns name -> path. ``fmt``: bag, csv or all (bp3010.bin and truth always)."""
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {FORMATS}, got {fmt!r}")
    out = Path(out_dir)
    names = ["truth.csv", "sim_info.yaml"] + (["bp3010.bin"] if res.bp3010 is not None else [])
    names += (["imu.csv", "gnss.csv"] if fmt in ("csv", "all") else []) + (["bag"] if fmt in ("bag", "all") else [])
    existing = [n for n in names if (out / n).exists()]
    if existing:  # checked before writing anything: never a folder that mixes two simulations
        raise FileExistsError(f"{out}: already holds {existing}; choose a new --out folder (or --force)")
    out.mkdir(parents=True, exist_ok=True)
    paths = {"truth": recording.write_trajectory_csv(out / "truth.csv", res.truth)}
    if fmt in ("csv", "all"):
        paths["imu_csv"] = recording.write_imu_csv(out / "imu.csv", res.imu)
        if res.gnss is not None:
            paths["gnss_csv"] = recording.write_gnss_csv(out / "gnss.csv", res.gnss)
    if fmt in ("bag", "all"):
        bag = out / "bag"
        gnss = _shift(res.gnss, BAG_EPOCH_S) if res.gnss is not None else None
        paths["bag"] = recording.write_bag(bag, _shift(res.imu, BAG_EPOCH_S), gnss, storage=storage)
    if res.bp3010 is not None:
        (out / "bp3010.bin").write_bytes(res.bp3010)
        paths["bp3010"] = out / "bp3010.bin"
    info = dict(res.info, outputs={k: str(Path(v).name) for k, v in paths.items()})
    (out / "sim_info.yaml").write_text(yaml.safe_dump(_plain(info), sort_keys=False))
    paths["info"] = out / "sim_info.yaml"
    return paths


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
