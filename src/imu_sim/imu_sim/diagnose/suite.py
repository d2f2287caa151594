"""Concealed-effect Monte Carlo: one effect present below the per-sample noise, the model without it.

Each case simulates a "real" recording (model + one effect, seed s) of a static multi-position
and rate-table sequence, diagnoses it against the model without the effect, and scores:
right name first, interval coverage of the true parameters, held-out fit improvement.
Null cases (nothing missing; a single static orientation where Earth rotation and
normal gravity are present but cannot be identified) give the false-alarm rate, and
their statistics calibrate the per-effect threshold factors.
"""
from __future__ import annotations

import copy

import numpy as np

from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose.case import CHANNELS, make_case
from imu_sim.diagnose.engine import diagnose
from imu_sim.scenario import from_dict
from imu_sim.simulate import simulate

RATE_HZ = 50.0
LONG_S, LONG_RATE_HZ = 7200.0, 5.0
"""The long static run (one level orientation) for the low-frequency effects and the single-orientation null."""
TEMP_CYCLE_C, TEMP_PERIOD_S, TEMP_MEAN_C = 10.0, 1800.0, 25.0
"""Its logged temperature: a chamber cycle, 25 +- 10 C with a 30-min period (not monotone, so not a warm-up)."""
LONG_EFFECTS = ("temperature_bias", "gauss_markov_bias", "bias_random_walk")
HOLD_S, MOVE_S = 40.0, 8.0
POSES = [(0, 0, 0, 0, None), (180, 0, 30, 0, None), (0, -90, 60, 0, None), (0, 90, 120, 0, None),
         (90, 0, 200, 0, None), (-90, 0, 270, 0, None), (0, 0, 0, 60, [0, 0, 1]), (0, 0, 0, 60, [1, 0, 0]),
         (0, 0, 0, -60, [0, 1, 0])]
"""(roll, pitch, yaw deg, rate deg/s, spin axis) per segment."""
MIS_G = np.array([[0, 1.2e-3, -0.8e-3], [0.9e-3, 0, 1.1e-3], [-1.0e-3, 0.7e-3, 0]])
MIS_A = np.array([[0, 4e-4, -3e-4], [3e-4, 0, 5e-4], [-4e-4, 3e-4, 0]])
EFFECT_CASES = {
    "earth_rotation": {},
    "gravity_model": {},
    "gyro_g_sensitivity": {"gyro_coeff_rad_per_s_per_mps2": [3e-5, -2e-5, 2.5e-5]},
    "temperature_bias": {"gyro_coeff_rad_per_s_per_degc": [1.0e-6, -0.8e-6, 1.2e-6],
                         "accel_coeff_mps2_per_degc": [5e-6, -5e-6, 5e-6], "reference_temp_c": 25.0},
    "warmup_drift": {"gyro_amplitude_rad_per_s": [4e-4, -3e-4, 5e-4], "accel_amplitude_mps2": [2e-3, -2e-3, 3e-3],
                     "time_constant_s": 60.0},
    "scale_factor": {"gyro": [1.0e-3, -0.7e-3, 1.4e-3], "accel": [5e-4, -4e-4, 6e-4]},
    "axis_misalignment": {"gyro": MIS_G.tolist(), "accel": MIS_A.tolist()},
    "vibration": {"sinusoids": [{"frequency_hz": 13.7, "phase_rad": 0.4, "accel_amplitude_mps2": [0.0, 0.0, 3e-3],
                                 "gyro_amplitude_rad_per_s": [5e-4, 0.0, 0.0]}]},
    "quantization": {"gyro_lsb_rad": [1e-5] * 3, "accel_lsb_mps": [5e-5] * 3},
    "gauss_markov_bias": {"gyro_sigma_rad_per_s": [3.7e-5] * 3, "gyro_correlation_time_s": [10.0] * 3,
                          "accel_sigma_mps2": [1.9e-4] * 3, "accel_correlation_time_s": [10.0] * 3},
    "bias_random_walk": {"gyro_rad_per_s_per_sqrt_s": [6e-7] * 3, "accel_mps2_per_sqrt_s": [3e-6] * 3},
}
TRUE_PARAMS = {
    "earth_rotation": {"earth_rate_rad_per_s": 7.292115e-5},
    "gyro_g_sensitivity": {f"gyro_coeff_rad_per_s_per_mps2[{a}]": v for a, v in zip("xyz", [3e-5, -2e-5, 2.5e-5])},
    "warmup_drift": {"time_constant_s": 60.0, **{f"gyro_amplitude_rad_per_s[{a}]": v
                                                 for a, v in zip("xyz", [4e-4, -3e-4, 5e-4])}},
    "scale_factor": {f"gyro[{a}]": v for a, v in zip("xyz", [1.0e-3, -0.7e-3, 1.4e-3])},
    "axis_misalignment": {f"gyro[{'xyz'[i]}{'xyz'[j]}]": MIS_G[i, j] for i in range(3) for j in range(3) if i != j},
    "quantization": {f"gyro_lsb_rad[{a}]": 1e-5 for a in "xyz"},
    "temperature_bias": {f"gyro_coeff_rad_per_s_per_degc[{a}]": v for a, v in zip("xyz", [1.0e-6, -0.8e-6, 1.2e-6])},
    "vibration": {"frequency_hz": 13.7, "accel_amplitude_mps2[z]": 3e-3, "gyro_amplitude_rad_per_s[x]": 5e-4},
    "bias_random_walk": {f"gyro_rad_per_s_per_sqrt_s[{a}]": 6e-7 for a in "xyz"},
    "gauss_markov_bias": {f"gyro_sigma_rad_per_s[{a}]": 3.7e-5 for a in "xyz"},
}
GNSS_CASES = {
    "gps_latency": {"latency_s": 0.03},
    "gps_lever_arm": {"lever_arm_m": [0.35, -0.25, 0.4]},
    "colored_gps_noise": {"sigma_m": [0.3, 0.3, 0.5], "correlation_time_s": 30.0},
}
"""GNSS effects, below the per-fix noise (0.5, 0.5, 1.0 m): 0.03 s x 10 m/s = 0.3 m at most."""
TRUE_PARAMS.update({
    "gps_latency": {"latency_s": 0.03},
    "gps_lever_arm": {"lever_arm_m[x]": 0.35, "lever_arm_m[y]": -0.25},
    "colored_gps_noise": {"sigma_m[e]": 0.3, "sigma_m[n]": 0.3, "sigma_m[u]": 0.5},
})
NULL_GNSS_COLORED = {"sigma_m": [0.4, 0.4, 0.6], "correlation_time_s": 30.0}
NULLS = ("null_nothing_missing", "null_single_orientation", "null_colored_gps_noise")
"""Null cases; null_colored_gps_noise: a drive whose fixes carry coloured noise (in the model too), no latency."""


def suite_model() -> SensorModel:
    """The model the simulation believes: white noise only, full Earth model (SI)."""
    gyro = TriadModel(white_noise=np.full(3, 2e-4))
    accel = TriadModel(white_noise=np.full(3, 1e-3))
    return SensorModel(gyro=gyro, accel=accel, sample_rate_hz=RATE_HZ,
                       physics={"earth_rotation": {}, "gravity_model": {}})


def suite_scenario(single: bool = False) -> dict:
    """Multi-position + rate-table sequence (or one level orientation), Calgary, warming 15 -> 35 C."""
    segs = []
    poses = [POSES[0]] if single else POSES
    for i, (r, p, y, rate, axis) in enumerate(poses):
        t0 = i * (HOLD_S + MOVE_S)
        seg = {"t0": t0, "t1": t0 + (HOLD_S * len(POSES) if single else HOLD_S),
               "roll_deg": r, "pitch_deg": p, "yaw_deg": y}
        if rate:
            seg.update(rate_dps=rate, axis_body=axis)
        segs.append(seg)
    return {"latitude_deg": 51.0784, "longitude_deg": -114.13, "height_m": 1100.0, "static_segments": segs,
            "rate_hz": RATE_HZ, "gps": False, "temperature": {"start_c": 15.0, "end_c": 35.0, "time_constant_s": 900.0},
            "moves_known": True}  # a motorised sequence: the simulator's moves are the record's


def long_scenario() -> dict:
    """One level orientation for two hours at 5 Hz, Calgary; the temperature is logged (see :func:`long_temperature`)."""
    return {"latitude_deg": 51.0784, "longitude_deg": -114.13, "height_m": 1100.0, "rate_hz": LONG_RATE_HZ,
            "static_segments": [{"t0": 0.0, "t1": LONG_S, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0}],
            "gps": False}


def long_temperature(n: int) -> np.ndarray:
    """Logged temperature (deg C) of the long run's n samples: a chamber cycle, not monotone."""
    t = np.arange(1, n + 1) / LONG_RATE_HZ
    return TEMP_MEAN_C - TEMP_CYCLE_C * np.cos(2 * np.pi * t / TEMP_PERIOD_S)


def drive_scenario() -> dict:
    """An 8-min level drive with turns, stops and speed changes, GPS at 1 Hz (the GNSS cases)."""
    # wide speed range (14 and 3 m/s, stands): latency scales with speed, the lever arm does not
    leg = [{"type": "accelerate", "duration_s": 8, "speed_mps": 14.0}, {"type": "cruise", "duration_s": 12},
           {"type": "turn", "duration_s": 6, "angle_deg": 90}, {"type": "accelerate", "duration_s": 6, "speed_mps": 3.0},
           {"type": "cruise", "duration_s": 8}, {"type": "turn", "duration_s": 5, "angle_deg": -60},
           {"type": "stop", "duration_s": 4}, {"type": "stand", "duration_s": 8},
           {"type": "accelerate", "duration_s": 8, "speed_mps": 9.0}, {"type": "turn", "duration_s": 8, "angle_deg": 120},
           {"type": "stop", "duration_s": 5}]
    segs = [{"type": "stand", "duration_s": 20}] + leg * 6
    return {"latitude_deg": 51.0784, "longitude_deg": -114.13, "height_m": 1100.0, "segments": segs,
            "rate_hz": RATE_HZ, "gps": {"rate_hz": 1.0, "sigma_m": [0.5, 0.5, 1.0]},
            "temperature": {"start_c": 15.0, "end_c": 35.0, "time_constant_s": 900.0}}


def make_inputs(effect: str, seed: int):
    """(recording, scenario, model the diagnosis is given, GNSS recording or None) of one case."""
    long = effect in LONG_EFFECTS or effect == "null_single_orientation"
    drive = effect in GNSS_CASES or effect == "null_colored_gps_noise"
    sc = from_dict(drive_scenario() if drive else long_scenario() if long else suite_scenario(),
                   where=f"suite:{effect}")
    model = suite_model()
    truth_model = copy.deepcopy(model)
    if effect == "null_single_orientation":
        model.physics = {}
    elif effect in ("earth_rotation", "gravity_model"):
        model.physics.pop(effect)
    elif effect in EFFECT_CASES:
        truth_model = truth_model.with_physics(effect, **EFFECT_CASES[effect])
    elif effect in GNSS_CASES:
        truth_model = truth_model.with_physics(effect, **GNSS_CASES[effect])
    elif effect == "null_colored_gps_noise":
        truth_model = truth_model.with_physics("colored_gps_noise", **NULL_GNSS_COLORED)
        model = model.with_physics("colored_gps_noise", **NULL_GNSS_COLORED)
    temp = long_temperature(int(round(LONG_S * LONG_RATE_HZ))) if long else None
    res = simulate(sc, truth_model, seed=seed, with_bytes=False, temp_c=temp)
    rec = ImuRecording(res.imu.t, res.imu.gyro, res.imu.accel, res.imu.temp_c, source=f"suite:{effect}:{seed}")
    return rec, sc, model, res.gnss


def concealment(effect: str, seed: int) -> dict:
    """How hidden an IMU case's effect is: peak |added| over the per-sample noise std, and its Allan visibility.

    added = recording - the same seed simulated with the diagnosis model (so only the missing effect);
    Allan: deviation of (model noise + added) over that of the model noise alone, largest over channels
    and cluster times up to a tenth of the run, beside the upper 95 % interval factor of the noise's
    Allan point at that cluster time (a ratio below it is inside the plot's own scatter).
    """
    from imu_calib.allan import overlapping_adev
    rec, sc, model, _ = make_inputs(effect, seed)
    long = effect in LONG_EFFECTS
    temp = long_temperature(len(rec.t)) if long else None
    believed = simulate(sc, model, seed=seed, with_bytes=False, temp_c=temp).imu
    clean = simulate(sc, model, seed=seed, with_bytes=False, temp_c=temp, terms=()).imu
    added = np.column_stack([rec.gyro - believed.gyro, rec.accel - believed.accel])
    noise = np.column_stack([believed.gyro - clean.gyro, believed.accel - clean.accel])
    rate = 1.0 / float(np.median(np.diff(rec.t)))
    sigma = np.concatenate([model.gyro.white_noise, model.accel.white_noise]) * np.sqrt(rate)
    span = rec.t[-1] - rec.t[0]
    taus = np.logspace(np.log10(2.0 / rate), np.log10(span / 10), 12)
    # edf for white rate noise (alpha 0): what the model noise is; the slope-read edf is erratic at the last point
    a0, a1 = overlapping_adev(noise, rate, taus, alphas=0.0), overlapping_adev(noise + added, rate, taus, alphas=0.0)
    ratio = a1.adev / a0.adev
    k, c = np.unravel_index(np.argmax(ratio), ratio.shape)
    return {"peak_over_noise": float(np.max(np.abs(added).max(axis=0) / sigma)),
            "allan_ratio_max": float(ratio[k, c]), "allan_tau_s": float(taus[k]), "allan_channel": CHANNELS[c],
            "allan_ci_factor": float(a0.hi[k, c] / a0.adev[k, c]), "allan_ratio_by_channel": ratio.max(axis=0).tolist()}


def make_recording(effect: str, seed: int):
    """(recording, scenario, model the diagnosis is given) of one case."""
    return make_inputs(effect, seed)[:3]


def run_case(effect: str, seed: int, factors: dict | None = None) -> dict:
    """Diagnose one case; the row of the table (``factors``: threshold factors, None = committed calibration)."""
    rec, sc, model, gnss = make_inputs(effect, seed)
    diag = diagnose(make_case(rec, sc, model, gnss), max_effects=1, seed=seed, factors=factors)
    res = diag.result
    first = res["findings"][0] if res["findings"] else None
    row = {"effect": effect, "seed": seed, "first": first["effect"] if first else None,
           "n_findings": len(res["findings"]), "n_significant": res["n_significant_first_pass"],
           "factors": res["calibration"] if isinstance(res["calibration"], dict) else {},
           "stats": {t["effect"]: (t["value"], t["threshold"]) for t in res["tested"]}}
    if first and first["effect"] == effect:
        row["fit_before"], row["fit_after"] = first["fit_before"], first["fit_after"]
        cover = []
        for name, true in TRUE_PARAMS.get(effect, {}).items():
            if name in first["intervals"]:
                lo, hi = first["intervals"][name]
                cover.append(lo <= true <= hi)
        row["covered"], row["n_params"] = int(sum(cover)), len(cover)
    return row


def summarise(rows: list) -> dict:
    """Per effect: detection rate (right name first), coverage, median improvement; nulls: false alarms."""
    out = {}
    for effect in sorted({r["effect"] for r in rows}):
        rs = [r for r in rows if r["effect"] == effect]
        if effect in NULLS:
            alarms = [r for r in rs if r.get("n_significant", r["n_findings"]) > 0]
            out[effect] = {"cases": len(rs), "false_alarm_rate": len(alarms) / len(rs),
                           "kept_finding_rate": float(np.mean([r["n_findings"] > 0 for r in rs])),
                           "alarm_effects": sorted({e for r in alarms for e, (v, t) in r["stats"].items()
                                                    if v is not None and t and v > t})}
            continue
        hit = [r for r in rs if r["first"] == effect]
        n_par = sum(r.get("n_params", 0) for r in hit)
        out[effect] = {"cases": len(rs), "detection_rate": len(hit) / len(rs),
                       "coverage": (sum(r["covered"] for r in hit) / n_par) if n_par else None,
                       "median_fit_before": float(np.median([r["fit_before"] for r in hit])) if hit else None,
                       "median_fit_after": float(np.median([r["fit_after"] for r in hit])) if hit else None,
                       "wrong_first": sorted({str(r["first"]) for r in rs if r["first"] != effect})}
    return out
