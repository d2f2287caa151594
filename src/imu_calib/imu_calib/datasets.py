"""Loaders for the real recordings in ../shared/data that are not in the project's CSV format.

Each returns a :class:`nav_core.recording.ImuRecording` (SI units unless a
loader says it keeps raw counts).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nav_core.recording import ImuRecording, RecordingError
from nav_core.units import DEG, G0


def _load_text(path, n_cols: int) -> np.ndarray:
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    try:
        data = np.loadtxt(path, ndmin=2)
    except ValueError as err:
        raise RecordingError(f"{path}: not a whitespace-separated numeric table: {err}") from err
    if data.shape[1] != n_cols:
        raise RecordingError(f"{path}: expected {n_cols} columns, found {data.shape[1]}")
    return data


def load_ucalgary_updown(path) -> ImuRecording:
    """``x_adi_{up,down}.txt``: GPS seconds of week, gyro x y z (deg/s), accel x y z (m/s^2)."""
    data = _load_text(path, 7)
    return ImuRecording(data[:, 0], data[:, 1:4] * DEG, data[:, 4:7], source=str(path))


def load_imutk(acc_path, gyro_path) -> ImuRecording:
    """imu_tk's ``xsens_{acc,gyro}.mat`` text files: time (s), raw counts x y z. Keeps raw counts."""
    acc, gyro = _load_text(acc_path, 4), _load_text(gyro_path, 4)
    if len(acc) != len(gyro) or not np.allclose(acc[:, 0], gyro[:, 0]):
        raise RecordingError(f"{acc_path} and {gyro_path}: time columns differ")
    return ImuRecording(acc[:, 0], gyro[:, 1:4], acc[:, 1:4], source=f"{acc_path} (raw counts)")


def load_adis_npz(path) -> ImuRecording:
    """``adis16405_static/imuN.npz``: counts x LSB (deg/s, g) converted to rad/s and m/s^2."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    with np.load(path) as data:
        try:
            rate = float(data["rate_hz"])
            gyro = data["gyro_counts"] * float(data["gyro_lsb_dps"]) * DEG
            accel = data["accel_counts"] * float(data["accel_lsb_g"]) * G0
        except KeyError as err:
            raise RecordingError(f"{path}: missing field {err}") from err
    return ImuRecording(np.arange(len(gyro)) / rate, gyro, accel, source=str(path))
