"""Real recordings into the diagnosis's inputs: recording CSV + scenario YAML (+ a model from their noise fit)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from nav_core.recording import ImuRecording, write_imu_csv
from nav_core.sensor_model import SensorModel, TriadModel, save

from imu_calib.allan import overlapping_adev
from nav_core.datasets import load_adis_npz, load_ucalgary_updown
from imu_calib.noise_fit import fit_noise

UCALGARY_LAT_DEG, UCALGARY_LON_DEG, UCALGARY_H_M = 51.0784, -114.1335, 1110.0


def noise_model(rec: ImuRecording, physics=None) -> SensorModel:
    """White + random-walk model from an Allan fit of the first half (the simulation's belief, no physics)."""
    half = rec.select(slice(0, len(rec) // 2))
    model = SensorModel(gyro=TriadModel(), accel=TriadModel(), sample_rate_hz=rec.rate_hz, physics=physics)
    for name, data in (("gyro", half.gyro), ("accel", half.accel)):
        adev = overlapping_adev(data - data.mean(axis=0), rec.rate_hz)
        tri = model.triad(name)
        for i in range(3):
            fit = fit_noise(adev.axis(i), terms=("N", "K"), try_gauss_markov=False)
            tri.white_noise[i] = fit.values.get("N", 0.0)
            tri.rate_random_walk[i] = fit.values.get("K", 0.0)
    return model


def prepare_adis(npz_path, out_dir, duration_s: float | None = None) -> dict:
    """ADIS16405 static run: CSV, scenario (one orientation, z down), white+RW model; returns paths."""
    rec = load_adis_npz(npz_path)
    if duration_s:
        rec = rec.select(slice(0, int(duration_s * rec.rate_hz)))
    return _write(rec, out_dir, [{"t0": 0.0, "t1": float(len(rec) / rec.rate_hz + 1), "roll_deg": 180.0,
                                  "pitch_deg": 0.0, "yaw_deg": 0.0}],
                  "ADIS16405 static (SMAC-Group/imudata), z axis down; location not published: Calgary assumed")


def prepare_updown(up_path, down_path, out_dir) -> dict:
    """UCalgary ADI two-position run (x up, then x down) as one recording with a gap removed."""
    up, down = load_ucalgary_updown(up_path), load_ucalgary_updown(down_path)
    rate = up.rate_hz
    n_up = len(up)
    t = np.arange(n_up + len(down)) / rate
    rec = ImuRecording(t, np.vstack([up.gyro, down.gyro]), np.vstack([up.accel, down.accel]), source="ucalgary updown")
    t_split = n_up / rate
    segs = [{"t0": 0.0, "t1": t_split, "roll_deg": 0.0, "pitch_deg": -90.0, "yaw_deg": 0.0},
            {"t0": t_split + 1e-3, "t1": float(len(t) / rate + 1), "roll_deg": 0.0, "pitch_deg": 90.0, "yaw_deg": 0.0}]
    return _write(rec, out_dir, segs, "UCalgary ADI two-position (talhaitis/Ins-Calibration): x up then x down; "
                  "the recordings are joined (the turn between them is not recorded); heading unknown (0 assumed)")


def _write(rec, out_dir, segs, notes) -> dict:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    csv = write_imu_csv(out / "imu.csv", rec)
    scenario = {"latitude_deg": UCALGARY_LAT_DEG, "longitude_deg": UCALGARY_LON_DEG, "height_m": UCALGARY_H_M,
                "static_segments": segs, "rate_hz": float(rec.rate_hz), "gps": False, "notes": notes}
    sc_path = out / "scenario.yaml"
    sc_path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    model_path = save(noise_model(rec), out / "model.yaml")
    return {"recording": csv, "scenario": sc_path, "model": model_path}
