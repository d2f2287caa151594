"""Two-position accelerometer calibration (the paper's eqs. 1-4): axis up, then axis down.

With the axis pointing up the accelerometer reads ``z1 = b + (1 + s) g``, with
it pointing down ``z2 = b - (1 + s) g``, so::

    b = (z1 + z2) / 2            s = (z1 - z2) / (2 g) - 1

``g`` is the local WGS-84 normal gravity (m/s^2) at the site's latitude and
height, not a constant. The same two positions give the gyro bias of that axis:
the sensed vertical Earth rate flips sign with the axis and cancels in the mean.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imu_calib.intervals import Z95
from imu_calib.model_io import set_interval
from nav_core.earth import normal_gravity
from nav_core.recording import ImuRecording

AXES = {"x": 0, "y": 1, "z": 2}


@dataclass
class TwoPositionResult:
    """Bias (m/s^2) and scale factor (1) of one accelerometer axis, gyro bias (rad/s), 95 % intervals."""

    axis: int
    bias: float
    scale_factor: float
    gravity: float
    gyro_bias: float
    bias_interval: tuple
    scale_interval: tuple
    gyro_bias_interval: tuple
    mean_up: float
    mean_down: float


def axis_index(axis) -> int:
    """Axis index 0..2 from 'x'/'y'/'z' or an int."""
    if isinstance(axis, str):
        if axis.lower() not in AXES:
            raise ValueError(f"axis must be one of x, y, z; got {axis!r}")
        return AXES[axis.lower()]
    if axis not in (0, 1, 2):
        raise ValueError(f"axis index must be 0, 1 or 2; got {axis!r}")
    return int(axis)


def _mean_and_se(x: np.ndarray, n_blocks: int = 20):
    """Mean and its standard error from block means (robust to slowly correlated noise)."""
    blocks = np.array_split(x, min(n_blocks, len(x)))
    means = np.array([b.mean() for b in blocks])
    se = means.std(ddof=1) / np.sqrt(len(means)) if len(means) > 1 else 0.0
    return float(x.mean()), float(se)


def two_position(up_mps2, down_mps2, lat_rad: float, height_m: float = 0.0,
                 gyro_up_rps=None, gyro_down_rps=None, axis: int = 0) -> TwoPositionResult:
    """Eqs. 1-4 from the axis's specific force samples (m/s^2) with the axis up and down.

    Intervals are 95 %, from the standard errors of the two means (block means).
    """
    up, down = np.asarray(up_mps2, float), np.asarray(down_mps2, float)
    if len(up) < 2 or len(down) < 2:
        raise ValueError(f"two-position calibration needs samples in both positions (got {len(up)}, {len(down)})")
    g = float(normal_gravity(lat_rad, height_m))
    z1, se1 = _mean_and_se(up)
    z2, se2 = _mean_and_se(down)
    if not z1 > z2:
        raise ValueError(f"axis-up mean {z1:.4g} m/s^2 is not above the axis-down mean {z2:.4g}: "
                         "are the recordings swapped or is it another axis?")
    bias, scale = 0.5 * (z1 + z2), (z1 - z2) / (2.0 * g) - 1.0
    se_b = 0.5 * np.hypot(se1, se2)
    se_s = se_b / g
    gyro_bias, se_g = np.nan, np.nan
    if gyro_up_rps is not None and gyro_down_rps is not None:
        w1, s1 = _mean_and_se(np.asarray(gyro_up_rps, float))
        w2, s2 = _mean_and_se(np.asarray(gyro_down_rps, float))
        gyro_bias, se_g = 0.5 * (w1 + w2), 0.5 * np.hypot(s1, s2)
    return TwoPositionResult(axis, bias, scale, g, gyro_bias, _ci(bias, se_b), _ci(scale, se_s),
                             _ci(gyro_bias, se_g), z1, z2)


def _ci(value, se):
    return (float(value - Z95 * se), float(value + Z95 * se))


def two_position_from_recordings(up: ImuRecording, down: ImuRecording, axis, lat_rad: float,
                                 height_m: float = 0.0) -> TwoPositionResult:
    """Eqs. 1-4 for ``axis`` ('x', 'y', 'z') from two static recordings (axis up, axis down)."""
    i = axis_index(axis)
    return two_position(up.accel[:, i], down.accel[:, i], lat_rad, height_m, up.gyro[:, i], down.gyro[:, i], i)


def apply_to_model(model, result: TwoPositionResult, with_gyro_bias: bool = True):
    """Write the axis's accel bias and scale factor (and gyro bias) with intervals into a SensorModel."""
    i = result.axis
    acc = model.accel
    acc.bias[i], acc.scale_factor[i] = result.bias, result.scale_factor
    set_interval(acc, "bias", i, result.bias_interval)
    set_interval(acc, "scale_factor", i, result.scale_interval)
    if with_gyro_bias and np.isfinite(result.gyro_bias):
        model.gyro.bias[i] = result.gyro_bias
        set_interval(model.gyro, "bias", i, result.gyro_bias_interval)
    return model
