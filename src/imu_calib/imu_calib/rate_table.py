"""Rate-table gyro calibration (the paper's eqs. 5-7): two table rates about the gyro axis.

The gyro senses ``wg = (1 + s)(w + w_ex) + b`` where ``w`` is the table rate and
``w_ex`` the Earth-rate component along the gyro axis. From two rates::

    s = ((wg1 - wg2) - (w1 - w2)) / (w1 - w2)
    b = (wg1 + wg2) / 2 - (s + 1)(w1 + w2 + 2 w_ex) / 2

``w_ex`` is computed from latitude and the axis direction in ENU (WGS-84 Earth
rate), never typed in.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imu_calib.intervals import Z95
from imu_calib.model_io import set_interval
from nav_core.earth import earth_rate_n

DIRECTIONS = {"up": (0, 0, 1), "down": (0, 0, -1), "north": (0, 1, 0), "south": (0, -1, 0),
              "east": (1, 0, 0), "west": (-1, 0, 0)}


@dataclass
class RateTableResult:
    """Gyro scale factor (1) and bias (rad/s) of one axis, the Earth-rate component used (rad/s), intervals."""

    axis: int
    scale_factor: float
    bias: float
    earth_rate_component: float
    scale_interval: tuple
    bias_interval: tuple


def direction_enu(direction) -> np.ndarray:
    """Unit vector in ENU from a name ('up', 'north', ...) or a 3-vector."""
    if isinstance(direction, str):
        if direction.lower() not in DIRECTIONS:
            raise ValueError(f"axis direction must be one of {sorted(DIRECTIONS)} or a vector; got {direction!r}")
        direction = DIRECTIONS[direction.lower()]
    vec = np.asarray(direction, dtype=float)
    if vec.shape != (3,) or not np.linalg.norm(vec) > 0:
        raise ValueError(f"axis direction must be a non-zero 3-vector in ENU; got {direction!r}")
    return vec / np.linalg.norm(vec)


def earth_rate_along(lat_rad: float, direction) -> float:
    """Earth-rate component (rad/s) sensed by an axis pointing along ``direction`` (ENU) at latitude."""
    return float(earth_rate_n(lat_rad) @ direction_enu(direction))


def rate_table(gyro1_rps, rate1_rps: float, gyro2_rps, rate2_rps: float, lat_rad: float,
               direction="up", axis: int = 2) -> RateTableResult:
    """Eqs. 5-7 from gyro samples (rad/s) at table rates ``rate1_rps`` and ``rate2_rps`` about the axis."""
    g1, g2 = np.asarray(gyro1_rps, float), np.asarray(gyro2_rps, float)
    if len(g1) < 2 or len(g2) < 2:
        raise ValueError(f"rate-table calibration needs samples at both rates (got {len(g1)}, {len(g2)})")
    if rate1_rps == rate2_rps:
        raise ValueError("the two table rates must differ")
    w_ex = earth_rate_along(lat_rad, direction)
    wg1, wg2 = g1.mean(), g2.mean()
    dw = rate1_rps - rate2_rps
    s = ((wg1 - wg2) - dw) / dw
    if not s > -1.0:  # the gyro saw no rate difference, or the opposite one: not a scale factor
        raise ValueError(f"the gyro's mean rates differ by {np.degrees(wg1 - wg2):.4g} deg/s where the table rates "
                         f"differ by {np.degrees(dw):.4g} deg/s (scale factor {s:.4g}, must be > -1): check the "
                         f"table rates, their signs, the axis and which recording is which")
    b = 0.5 * (wg1 + wg2) - 0.5 * (s + 1.0) * (rate1_rps + rate2_rps + 2.0 * w_ex)
    se1, se2 = (_se(g1), _se(g2))
    se_s = np.hypot(se1, se2) / abs(dw)
    # b is linear in wg1, wg2 through s as well: db/dwg1 = 1/2 - (w1+w2+2w_ex)/(2 dw), likewise for wg2
    k = (rate1_rps + rate2_rps + 2.0 * w_ex) / (2.0 * dw)
    se_b = np.hypot((0.5 - k) * se1, (0.5 + k) * se2)
    return RateTableResult(axis, float(s), float(b), w_ex, (s - Z95 * se_s, s + Z95 * se_s),
                           (b - Z95 * se_b, b + Z95 * se_b))


def _se(x, n_blocks: int = 20) -> float:
    means = np.array([blk.mean() for blk in np.array_split(x, min(n_blocks, len(x)))])
    return float(means.std(ddof=1) / np.sqrt(len(means)))


def apply_to_model(model, result: RateTableResult):
    """Write the axis's gyro scale factor and bias with intervals into a SensorModel."""
    i = result.axis
    model.gyro.scale_factor[i], model.gyro.bias[i] = result.scale_factor, result.bias
    set_interval(model.gyro, "scale_factor", i, result.scale_interval)
    set_interval(model.gyro, "bias", i, result.bias_interval)
    return model
