"""Multi-position accelerometer calibration without a rate table (after Tedaldi et al., imu_tk).

The IMU rests in many orientations with short moves between them. Static
segments are found automatically (a moving-window variance of the three
accelerometer axes below ``threshold_factor`` times its value over the initial
static interval), then bias b, scale factors s and misalignment M of

    measured = (I + diag(s) + M) @ true + b

are fitted by least squares (``scipy.optimize.least_squares``) so that the
corrected mean of every static segment has the magnitude of local gravity.
Gravity magnitude alone cannot fix a rotation of the reference frame, so M is
upper triangular (M[0,1], M[0,2], M[1,2]): the frame's z axis is the
accelerometer's z axis and its y axis lies in the accelerometer's y-z plane.
Works in any units (raw counts too): initial guesses come from the data.

The gyro bias is the mean rate over the initial static interval, minus the
vertical Earth rate along the sensed "up" (when the latitude is given and the
data are in rad/s); the unknown horizontal Earth rate (heading unknown) is
added to its interval. Gyro scale factors and misalignment then come from the
moves between the static positions (:mod:`imu_calib.gyro_multi_position`).
The gyro is integrated one sample interval per sample, so a move whose stamps
break (go back, repeat, or leave a gap) cannot be integrated: it is left out of
that fit and listed in ``moves_skipped``; static segments only average samples
and keep them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize
from scipy.ndimage import uniform_filter1d

from imu_calib.intervals import Z95
from imu_calib.gyro_multi_position import GyroCalibration, fit_gyro, moves_between
from nav_core.earth import RATE, normal_gravity
from nav_core.recording import ImuRecording, check_timestamps

MISALIGNMENT_INDEX = ((0, 1), (0, 2), (1, 2))


@dataclass
class StaticSegment:
    """A detected static interval: sample indices [start, stop), and the mean accel/gyro over it."""

    start: int
    stop: int
    accel_mean: np.ndarray
    gyro_mean: np.ndarray


@dataclass
class MultiPositionResult:
    """Fitted accel bias (input units), scale factors (1), misalignment (3x3, rad), gyro bias, 95 % intervals."""

    bias: np.ndarray
    scale_factor: np.ndarray
    misalignment: np.ndarray
    gyro_bias: np.ndarray
    intervals: dict
    gravity: float
    residuals: np.ndarray
    """|corrected segment mean| - g per static segment (input units)."""
    residuals_before: np.ndarray
    """The same for the naive six-position style start (mid-range bias, half-range scale), for comparison."""
    segments: list = field(default_factory=list)
    gyro: GyroCalibration | None = None
    """Gyro scale factors and misalignment from the moves (None when not asked for)."""
    moves_skipped: list = field(default_factory=list)
    """(move index, sample index, stamp s) of each move left out of the gyro fit: its stamps break there."""

    @property
    def rms_residual(self) -> float:
        """RMS of the residuals after calibration (input units)."""
        return float(np.sqrt(np.mean(self.residuals ** 2)))

    def matrix(self) -> np.ndarray:
        """I + diag(scale_factor) + misalignment."""
        return np.eye(3) + np.diag(self.scale_factor) + self.misalignment


def detect_static(accel, rate_hz: float, init_static_s: float = 30.0, window_s: float = 1.0,
                  threshold_factor: float = 4.0, min_static_s: float = 2.0) -> list:
    """Static intervals (start, stop) sample indices: window variance below factor x initial level."""
    accel = np.asarray(accel, float)
    win = max(3, int(round(window_s * rate_hz)))
    if len(accel) < 2 * win:
        raise ValueError(f"recording too short for static detection: {len(accel)} samples, "
                         f"window {win} samples")
    mean = uniform_filter1d(accel, win, axis=0, mode="nearest")
    var = uniform_filter1d(accel ** 2, win, axis=0, mode="nearest") - mean ** 2
    metric = np.sqrt(np.sum(np.maximum(var, 0.0) ** 2, axis=1))
    n_init = int(round(init_static_s * rate_hz))
    if n_init < win:
        raise ValueError(f"initial static interval {init_static_s} s is shorter than the window {window_s} s")
    level = np.median(metric[win // 2: max(n_init - win // 2, win // 2 + 1)])
    static = metric <= threshold_factor * level
    edges = np.flatnonzero(np.diff(np.concatenate(([0], static.astype(np.int8), [0]))))
    min_len = int(round(min_static_s * rate_hz))
    out = []
    for start, stop in zip(edges[::2], edges[1::2]):
        # trim half a window at each end: the variance window smears motion into neighbours
        start, stop = start + win // 2, stop - win // 2
        if stop - start >= min_len:
            out.append((int(start), int(stop)))
    return out


def segments_of(rec: ImuRecording, intervals) -> list:
    """StaticSegment means for the given (start, stop) intervals."""
    return [StaticSegment(a, b, rec.accel[a:b].mean(axis=0), rec.gyro[a:b].mean(axis=0)) for a, b in intervals]


def _unpack(p):
    bias, scale = p[0:3], p[3:6]
    mis = np.zeros((3, 3))
    for k, (i, j) in enumerate(MISALIGNMENT_INDEX):
        mis[i, j] = p[6 + k]
    return bias, scale, mis


def _residuals(p, means, g):
    bias, scale, mis = _unpack(p)
    true = np.linalg.solve(np.eye(3) + np.diag(scale) + mis, (means - bias).T).T
    return np.linalg.norm(true, axis=1) - g


def fit_accel(means, gravity: float):
    """Least-squares bias, scale, misalignment from static means (k, 3).

    Returns parameters, covariance, residuals, and the residuals of the naive
    start (bias = mid-range, scale = half-range / g, no misalignment).
    """
    means = np.asarray(means, float)
    if len(means) < 9:
        raise ValueError(f"multi-position calibration needs at least 9 static orientations, found {len(means)}")
    lo, hi = means.min(axis=0), means.max(axis=0)
    p0 = np.concatenate([0.5 * (lo + hi), (hi - lo) / (2.0 * gravity) - 1.0, np.zeros(3)])
    if np.any(hi - lo <= 0):
        raise ValueError("static orientations do not span both directions of every axis")
    res = optimize.least_squares(_residuals, p0, args=(means, gravity), x_scale="jac", method="lm")
    dof = max(len(means) - len(p0), 1)
    s2 = float(res.fun @ res.fun) / dof
    cov = np.linalg.pinv(res.jac.T @ res.jac) * s2
    return res.x, cov, res.fun, _residuals(p0, means, gravity)


def multi_position(rec: ImuRecording, lat_rad: float | None = None, height_m: float = 0.0,
                   gravity: float | None = None, with_gyro: bool = True, **detect_kwargs) -> MultiPositionResult:
    """Detect static segments of ``rec`` and fit the accelerometer model; gyro bias from the initial interval.

    ``gravity`` (input units) defaults to WGS-84 normal gravity at ``lat_rad``,
    ``height_m`` (m/s^2); pass it explicitly for raw counts scaled otherwise.
    ``with_gyro``: also fit gyro scale factors and misalignment from the moves.
    """
    if gravity is None:
        if lat_rad is None:
            raise ValueError("give the latitude (for local gravity) or the gravity magnitude")
        gravity = float(normal_gravity(lat_rad, height_m))
    rate = rec.rate_hz
    intervals = detect_static(rec.accel, rate, **detect_kwargs)
    segs = segments_of(rec, intervals)
    means = np.array([s.accel_mean for s in segs]).reshape(-1, 3)
    p, cov, resid, before = fit_accel(means, gravity)
    bias, scale, mis = _unpack(p)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    intervals_95 = {"bias": _ci(bias, sd[0:3]), "scale_factor": _ci(scale, sd[3:6]),
                    "misalignment": _mis_interval(mis, sd[6:9])}
    gyro_bias, gyro_ci = _gyro_bias(rec, segs, bias, scale, mis, lat_rad, detect_kwargs.get("init_static_s", 30.0))
    intervals_95["gyro_bias"] = gyro_ci
    gyro, skipped = None, []
    if with_gyro:
        moves = moves_between(segs, rec.gyro, gyro_bias, np.eye(3) + np.diag(scale) + mis, bias)
        skipped = broken_moves(rec.t, segs)
        gone = {k for k, _, _ in skipped}
        gyro = fit_gyro([m for k, m in enumerate(moves) if k not in gone], rate)
    return MultiPositionResult(bias, scale, mis, gyro_bias, intervals_95, gravity, resid, before, segs, gyro,
                               skipped)


def broken_moves(t, segments, gap_factor: float = 1.5) -> list:
    """(move index, sample index, stamp s) of the first break of each move between consecutive ``segments``
    whose stamps ``t`` (s) go back, repeat or leave a gap (> ``gap_factor`` median intervals)."""
    check = check_timestamps(t, gap_factor=gap_factor)
    breaks = np.unique(np.concatenate([check.backwards, check.duplicates, check.gaps]).astype(int))
    out = []
    for k, (a, b) in enumerate(zip(segments[:-1], segments[1:])):
        inside = breaks[(breaks >= a.stop) & (breaks <= b.start)]  # step t[i-1] -> t[i] within the move
        if len(inside):
            out.append((k, int(inside[0]), float(t[inside[0]])))
    return out


def _ci(value, sd):
    return np.stack([value - Z95 * sd, value + Z95 * sd], axis=-1)


def _mis_interval(mis, sd):
    out = np.stack([mis, mis], axis=-1)
    for k, (i, j) in enumerate(MISALIGNMENT_INDEX):
        out[i, j] = (mis[i, j] - Z95 * sd[k], mis[i, j] + Z95 * sd[k])
    return out


def _gyro_bias(rec, segs, bias, scale, mis, lat_rad, init_static_s):
    """Mean gyro over the initial static interval minus the vertical Earth rate; 95 % interval."""
    n_init = max(2, int(round(init_static_s * rec.rate_hz)))
    gyro = rec.gyro[:n_init]
    mean = gyro.mean(axis=0)
    blocks = np.array([b.mean(axis=0) for b in np.array_split(gyro, 20)])
    se = blocks.std(axis=0, ddof=1) / np.sqrt(len(blocks))
    half = Z95 * se
    if lat_rad is not None:
        up = np.linalg.solve(np.eye(3) + np.diag(scale) + mis, rec.accel[:n_init].mean(axis=0) - bias)
        up /= np.linalg.norm(up)
        mean = mean - RATE * np.sin(lat_rad) * up
        half = half + RATE * abs(np.cos(lat_rad))  # horizontal Earth rate: heading unknown
    return mean, np.stack([mean - half, mean + half], axis=-1)


def apply_to_model(model, result: MultiPositionResult, with_gyro_bias: bool = True):
    """Write accel bias, scale factors, misalignment (and gyro bias) with intervals into a SensorModel."""
    acc = model.accel
    acc.bias, acc.scale_factor, acc.misalignment = (result.bias.copy(), result.scale_factor.copy(),
                                                    result.misalignment.copy())
    for term in ("bias", "scale_factor", "misalignment"):
        acc.intervals[term] = result.intervals[term]
    acc.info["multi_position"] = {"static_segments": len(result.segments),
                                  "rms_residual": result.rms_residual,
                                  "rms_residual_before": float(np.sqrt(np.mean(result.residuals_before ** 2)))}
    if with_gyro_bias:
        model.gyro.bias = result.gyro_bias.copy()
        model.gyro.intervals["bias"] = result.intervals["gyro_bias"]
    if result.gyro is not None:
        gyro = result.gyro
        model.gyro.scale_factor, model.gyro.misalignment = gyro.scale_factor.copy(), gyro.misalignment.copy()
        for term in ("scale_factor", "misalignment"):
            model.gyro.intervals[term] = gyro.intervals[term]
        model.gyro.info["multi_position"] = {"moves": gyro.n_moves,
                                             "rms_gravity_direction_error_rad": float(np.sqrt(np.mean(gyro.residuals ** 2))),
                                             "rms_before_rad": float(np.sqrt(np.mean(gyro.residuals_before ** 2)))}
    return model
