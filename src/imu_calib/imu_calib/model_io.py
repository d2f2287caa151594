"""Small helpers around nav_core.sensor_model for the calibration tools: load-or-new, per-axis intervals,
the Kalibr ``imu.yaml`` export (positive values only; an upper bound is said to be one)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from nav_core import sensor_model


def load_or_new(path, sample_rate_hz: float | None = None) -> sensor_model.SensorModel:
    """The sensor model at ``path`` if it exists (validated), else a new empty one."""
    path = Path(path)
    model = sensor_model.load(path) if path.exists() else sensor_model.SensorModel()
    if sample_rate_hz is not None:
        model.sample_rate_hz = float(sample_rate_hz)
    return model


def set_interval(triad, term: str, axis: int, interval) -> None:
    """Set the 95 % interval of one axis of ``term``; other axes keep theirs (or a point interval)."""
    value = np.asarray(getattr(triad, term), dtype=float)
    current = triad.intervals.get(term)
    current = np.stack([value, value], axis=-1) if current is None else np.array(current, dtype=float)
    current[axis] = interval
    triad.intervals[term] = current


KALIBR_KEYS = (("gyroscope_noise_density", "gyro", "white_noise"),
               ("gyroscope_random_walk", "gyro", "rate_random_walk"),
               ("accelerometer_noise_density", "accel", "white_noise"),
               ("accelerometer_random_walk", "accel", "rate_random_walk"))
"""Kalibr imu.yaml key, triad, sensor-model term. Units: noise density rad/s/sqrt(Hz) = rad/sqrt(s) (our N),
random walk rad/s^2/sqrt(Hz) = rad/s/sqrt(s) (our K); the same with m/s for the accelerometer."""


class KalibrError(ValueError):
    """A Kalibr key would be 0 or missing: Kalibr inverts these values, so none is written."""


def _worst_axis(model: sensor_model.SensorModel, triad: str, term: str):
    """Largest value over the three axes and whether it is an estimate (False: an upper bound)."""
    tri = model.triad(triad)
    values = np.asarray(getattr(tri, term), dtype=float)
    i = int(np.argmax(values))
    flags = tri.identifiable.get(term)
    return float(values[i]), (True if flags is None else bool(flags[i])), "xyz"[i]


def kalibr_dict(model: sensor_model.SensorModel, rostopic: str = "/imu/data_raw") -> dict:
    """Kalibr ``imu.yaml`` keys (worst axis, positive values only); KalibrError if a value is not positive."""
    out = {"rostopic": rostopic, "update_rate": float(model.sample_rate_hz)}
    for key, triad, term in KALIBR_KEYS:
        value, _, _ = _worst_axis(model, triad, term)
        if not (np.isfinite(value) and value > 0):
            raise KalibrError(f"Kalibr {key}: {triad} {term} is {value:g} on every axis (no estimate and no "
                              f"upper bound); Kalibr inverts it, so imu.yaml is not written")
        out[key] = value
    return out


def kalibr_warnings(model: sensor_model.SensorModel) -> list:
    """One line per Kalibr key that is a 95 % upper bound rather than an estimate."""
    out = []
    for key, triad, term in KALIBR_KEYS:
        value, estimated, axis = _worst_axis(model, triad, term)
        if not estimated:
            out.append(f"Kalibr {key} = {value:.4g} is the 95 % upper bound of {triad} {axis} {term} "
                       f"(not identifiable from this record), not an estimate")
    return out


def save_kalibr(model: sensor_model.SensorModel, path, rostopic: str = "/imu/data_raw") -> Path:
    """Write Kalibr's ``imu.yaml``: positive values only, a comment above each key that is an upper bound."""
    path = Path(path)
    values = kalibr_dict(model, rostopic)
    lines = ["# Kalibr IMU noise model written by imu_calib (worst axis of each triad)",
             "# noise density: rad/s/sqrt(Hz), m/s^2/sqrt(Hz); random walk: rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)"]
    upper = {line.split()[1]: line for line in kalibr_warnings(model)}
    for key, value in values.items():
        if key in upper:
            lines.append(f"# {upper[key]}")
        lines.append(yaml.safe_dump({key: value}, sort_keys=False).strip())
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path
