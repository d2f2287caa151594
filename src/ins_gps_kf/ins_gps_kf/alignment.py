"""Coarse alignment from a stationary period: roll, pitch, gyro bias; heading from GPS course or a parameter.

A MEMS gyro cannot find north (its noise and bias exceed the 15 deg/h Earth rate),
so heading comes from the GPS course once the vehicle moves, or from a parameter.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core import earth, frames
from nav_core.units import G0


@dataclass
class Alignment:
    """Result of the stationary alignment: roll, pitch (rad), gyro bias (rad/s, body), span (s)."""

    roll: float
    pitch: float
    gyro_bias: np.ndarray
    mean_accel: np.ndarray
    duration_s: float
    samples: int


def level_from_specific_force(mean_accel):
    """Roll and pitch (rad) of a resting FLU IMU from its mean specific force (m/s^2, reads +g up)."""
    fx, fy, fz = np.asarray(mean_accel, dtype=float)
    return float(np.arctan2(fy, fz)), float(np.arctan2(-fx, np.hypot(fy, fz)))


def gyro_bias_at_rest(mean_gyro, roll, pitch, lat_rad, yaw=None):
    """Gyro bias (rad/s, body): mean rate at rest minus the Earth rate seen at that attitude.

    Without a known ``yaw`` (rad) only the vertical Earth rate is removed; the horizontal
    part (at most RATE*cos(lat)) stays in the bias.
    """
    mat_nb = frames.mat_nb_from_euler(roll, pitch, 0.0 if yaw is None else yaw)
    w_ie_n = earth.earth_rate_n(lat_rad)
    if yaw is None:
        w_ie_n[:2] = 0.0
    return np.asarray(mean_gyro, dtype=float) - mat_nb.T @ w_ie_n


REST_FORCE_MIN, REST_FORCE_MAX = 0.5 * G0, 2.0 * G0
"""m/s^2: the mean specific force of an IMU at rest on Earth lies well inside (g = 9.78-9.83)."""


class _ImuSums:
    """Sums of IMU samples over a span: count ``n``, first and last stamp (s), rate and specific-force sums."""

    def _reset_sums(self):
        self.t0 = None
        self.t_last = None
        self.n = 0
        self.sum_gyro = np.zeros(3)
        self.sum_accel = np.zeros(3)

    def _add_sums(self, t0, t, n, gyro_sum, accel_sum):
        """Add ``n`` samples from ``t0`` to ``t`` s with the given sums (rad/s, m/s^2)."""
        if self.t0 is None:
            self.t0 = t0
        self.t_last = t
        self.n += n
        self.sum_gyro += gyro_sum
        self.sum_accel += accel_sum

    @property
    def elapsed_s(self) -> float:
        """Span accumulated so far, s."""
        return 0.0 if self.t0 is None else self.t_last - self.t0


class StationaryAligner(_ImuSums):
    """Accumulates IMU samples while they stay stationary; finishes after ``duration_s`` or when motion starts.

    Samples are judged in blocks of ``block_s`` s so that sensor noise and engine vibration
    average out: a block is stationary when its mean rate (rad/s) and mean specific force
    (m/s^2) stay within ``gyro_threshold`` and ``accel_threshold`` of the mean so far, and
    its mean rate is below ``max_rate`` (rad/s: a steady turn in place keeps a constant
    mean, which is not rest). Motion before ``min_duration_s`` restarts the accumulation
    (the period was not stationary). A block whose mean |specific force| is outside
    [0.5 g, 2 g] is not rest on Earth either (an accelerometer in g reads 1.0): it restarts the
    accumulation too, and ``on_refused(text)`` is told why (the filter counts it).
    """

    def __init__(self, duration_s, min_duration_s, gyro_threshold, accel_threshold, block_s=1.0,
                 max_rate=np.inf, on_refused=None):
        self.duration_s, self.min_duration_s = duration_s, min_duration_s
        self.gyro_threshold, self.accel_threshold = gyro_threshold, accel_threshold
        self.max_rate = max_rate
        self.block_s = block_s
        self.on_refused = on_refused or (lambda text: None)
        self.restarts = -1
        self.restart()

    def restart(self):
        """Forget the samples seen so far."""
        self._reset_sums()
        self._new_block(None)
        self.moving = False
        self.restarts += 1

    def _new_block(self, t0):
        self.block_t0 = t0
        self.block_n = 0
        self.block_gyro = np.zeros(3)
        self.block_accel = np.zeros(3)

    def add(self, t, gyro, accel) -> bool:
        """Add one sample (s, rad/s, m/s^2); True when the alignment is ready to be finished."""
        if self.block_t0 is None:
            self._new_block(t)
        self.block_n += 1
        self.block_gyro += gyro
        self.block_accel += accel
        if t - self.block_t0 < self.block_s:
            return False
        return self._close_block(t)

    def _close_block(self, t) -> bool:
        mean_g, mean_a = self.block_gyro / self.block_n, self.block_accel / self.block_n
        f = float(np.linalg.norm(mean_a))
        if not REST_FORCE_MIN <= f <= REST_FORCE_MAX:
            self.on_refused(f"IMU block ending at t={t:.3f} s reads |specific force| {f:.4g} m/s^2, not about "
                            "9.8: not at rest on Earth (accelerometer in g or another unit?)")
            self.restart()
            return False
        if np.linalg.norm(mean_g) > self.max_rate:
            if self.n > 0 and self.elapsed_s >= self.min_duration_s:
                self.moving = True
                return True
            self.restart()
            return False
        if self.n > 0:
            ref_g, ref_a = self.sum_gyro / self.n, self.sum_accel / self.n
            if (np.linalg.norm(mean_g - ref_g) > self.gyro_threshold
                    or np.linalg.norm(mean_a - ref_a) > self.accel_threshold):
                if self.elapsed_s >= self.min_duration_s:
                    self.moving = True
                    return True
                self.restart()
                return False
        self._add_sums(self.block_t0, t, self.block_n, self.block_gyro, self.block_accel)
        self._new_block(None)
        return self.elapsed_s >= self.duration_s

    def finish(self, lat_rad, yaw=None) -> Alignment:
        """Roll, pitch and gyro bias from the accumulated samples at latitude ``lat_rad`` (yaw in rad if known)."""
        mean_g, mean_a = self.sum_gyro / self.n, self.sum_accel / self.n
        roll, pitch = level_from_specific_force(mean_a)
        return Alignment(roll, pitch, gyro_bias_at_rest(mean_g, roll, pitch, lat_rad, yaw), mean_a,
                         self.elapsed_s, self.n)


def yaw_from_displacement(d_enu):
    """Course yaw (rad, ENU: 0 = east, CCW) of a horizontal displacement (m, ENU)."""
    return float(np.arctan2(d_enu[1], d_enu[0]))


# ----------------------------------------------------------------------------- alignment in motion


@dataclass
class MotionAlignment:
    """Alignment of a moving vehicle: roll, pitch, yaw (rad), ENU velocity (m/s) and position (m) at ``t`` (s),
    their 1-sigma (rad, m/s, m), the fitted horizontal acceleration (m/s^2), span (s) and sample count."""

    t: float
    roll: float
    pitch: float
    yaw: float
    velocity_n: np.ndarray
    position_n: np.ndarray
    tilt_std: float
    yaw_std: float
    velocity_std: float
    position_std: np.ndarray
    accel_h: float
    duration_s: float
    samples: int
    gyro_bias: np.ndarray


def fit_track(t, enu, t_end):
    """Quadratic least-squares fit per ENU axis of fixes ``enu`` (n, 3) m at ``t`` (n,) s, evaluated at ``t_end``.

    Returns position (m), velocity (m/s), acceleration (m/s^2), each (3,), and the rms residual per axis (m).
    """
    tau = np.asarray(t, float) - t_end
    design = np.column_stack([np.ones_like(tau), tau, 0.5 * tau**2])
    coef, *_ = np.linalg.lstsq(design, np.asarray(enu, float), rcond=None)
    resid = np.asarray(enu, float) - design @ coef
    dof = max(len(tau) - 3, 1)
    return coef[0], coef[1], coef[2], np.sqrt(np.sum(resid**2, axis=0) / dof)


class InMotionAligner(_ImuSums):
    """Alignment while driving at nearly constant velocity: roll/pitch from the mean specific force over a
    ``window_s`` window, yaw and velocity from a quadratic fit of the GPS fixes in it.

    The window is accepted when the fitted horizontal acceleration (speed change and
    centripetal, m/s^2) is below ``max_accel`` (the level error is about ``max_accel / g``
    rad) and the speed at the window's end is at least ``min_speed`` (m/s); otherwise a
    new window starts. Yaw is the GPS course, which assumes the body x axis points along
    the motion. A vehicle at nearly constant velocity turns only about the vertical, at
    the course rate of the fit, so the mean rate minus that is the gyro bias of the body
    x and y axes (``gyro_bias``, else zero); the z bias starts at zero, since the course
    rate from metre-level fixes is too noisy for it (0.04 m/s^2 fit noise at 10 m/s is
    0.2 deg/s). Earth rate (< 0.005 deg/s) is left in the bias.
    """

    def __init__(self, window_s, max_accel, min_speed, gyro_bias=True, min_fixes=4):
        self.window_s, self.max_accel, self.gyro_bias = window_s, max_accel, gyro_bias
        self.min_speed, self.min_fixes = min_speed, min_fixes
        self.restarts = -1
        self.fixes = []
        self.restart()

    def restart(self):
        """Start a new window (fixes older than it are dropped when the next one closes)."""
        self._reset_sums()
        self.restarts += 1
        self.result = None

    def add_fix(self, t, enu):
        """Remember one GPS fix (s, ENU m)."""
        self.fixes.append((float(t), np.asarray(enu, float)))

    def add(self, t, gyro, accel) -> bool:
        """Add one IMU sample (s, rad/s, m/s^2); True when a window passed the tests (see :meth:`finish`)."""
        self._add_sums(t, t, 1, gyro, accel)
        if t - self.t0 < self.window_s:
            return False
        return self._close_window(t)

    def _close_window(self, t) -> bool:
        self.fixes = [f for f in self.fixes if f[0] >= self.t0 - 1e-9 and f[0] <= t + 1e-9]
        ok = len(self.fixes) >= self.min_fixes and self.fixes[-1][0] - self.fixes[0][0] >= 0.5 * self.window_s
        if ok:
            ts = np.array([f[0] for f in self.fixes])
            pos, vel, acc, resid = fit_track(ts, np.array([f[1] for f in self.fixes]), t)
            speed = float(np.hypot(vel[0], vel[1]))
            accel_h = float(np.hypot(acc[0], acc[1]))
            ok = accel_h <= self.max_accel and speed >= self.min_speed
        if not ok:
            self.restart()
            return False
        # velocity std of the end-point slope of a quadratic fit: ~ sqrt(12 / N) * resid / span, doubled
        # for the end point (an extrapolation) -- GPS errors are correlated, so the residual understates them
        span = max(ts[-1] - ts[0], 1e-3)
        vel_std = float(2.0 * np.sqrt(12.0 / len(ts)) * np.hypot(resid[0], resid[1]) / span)
        roll, pitch = level_from_specific_force(self.sum_accel / self.n)
        yaw = float(np.arctan2(vel[1], vel[0]))
        bias = np.zeros(3)
        if self.gyro_bias:
            course_rate = float(vel[0] * acc[1] - vel[1] * acc[0]) / speed**2  # rad/s about up
            bias = self.sum_gyro / self.n - frames.mat_nb_from_euler(roll, pitch, yaw).T @ [0.0, 0.0, course_rate]
            bias[2] = 0.0
        self.result = MotionAlignment(float(t), roll, pitch, yaw, vel, pos,
                                      float(max(accel_h, self.max_accel) / 9.81), vel_std / speed, vel_std,
                                      resid, accel_h, self.elapsed_s, self.n, bias)
        return True

    def finish(self, lat_rad=None, yaw=None) -> MotionAlignment:
        """The accepted window's alignment (``yaw`` in rad overrides the course); gyro bias zero."""
        if yaw is not None:
            self.result.yaw = float(yaw)
        return self.result
