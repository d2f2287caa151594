"""The navigation filter's gyro bias as its output shows it, beside the monitor's own tests. No ROS; rad/s, s.

ins_gps_kf publishes no bias topic, but ``odometry/filtered`` carries in ``twist.twist.angular`` the epoch's mean
*bias-corrected* body rate (the mean over its input samples since its previous epoch; body = IMU axes). Its input
is ``imu/data_raw`` calibrated by the sensor model and denoised (wmra_node; the denoising keeps the mean). The
calibrated raw gyro averaged over the same span, less that rate, is the filter's gyro bias state; averaged over the
last ``average_s`` (the epochs' differences carry one epoch's white noise, independent from epoch to epoch).
``test_sensor_health_odometry_bias`` checks it against ins_gps_kf's own bias state on a drive.

The estimate feeds no test: a threshold on it would need the false-alarm rate measured through the filter, which
it is not. It is reported (``/diagnostics``, gx gy gz) so a ``bias_shift`` the monitor names can be set against
what the filter has absorbed, and a filter whose bias walks away while the monitor sees none is visible.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from nav_core.noise_stats import Z95

MAX_QUEUED = 1000
"""Odometry messages held for IMU samples not yet received (500 s of 2-Hz epochs)."""


class OdometryBias:
    """Streaming: :meth:`push_imu` raw gyro samples, :meth:`push_odometry` the filter's epoch rates;
    :meth:`estimate` the mean difference over the last ``average_s`` s."""

    def __init__(self, average_s: float = 10.0, max_epoch_s: float = 1.0, keep_s: float = 30.0):
        """``max_epoch_s``: a longer gap between two odometry stamps is not one filter epoch (after alignment or a
        reset the span the rate averages is unknown): skipped. ``keep_s``: raw samples kept for odometry that
        comes late (the filter's intake waits for reordering)."""
        self.average_s, self.max_epoch_s, self.keep_s = float(average_s), float(max_epoch_s), float(keep_s)
        self.imu_t, self.gyro = np.zeros(0), np.zeros((0, 3))
        # odometry (t, rate) waiting for the raw samples of its epoch; bounded: stamps the IMU never reaches (another
        # clock) must not pile up
        self.queue = deque(maxlen=MAX_QUEUED)
        self.last_t = None
        self.diffs = deque()  # (t, raw mean - filter rate (3,))
        self.epochs = 0

    def push_imu(self, t, gyro) -> None:
        """Gyro samples as the filter's input has them before its bias (calibrated): t (m,) s, gyro (m, 3) rad/s,
        in time order."""
        t = np.asarray(t, float).reshape(-1)
        if len(t) == 0:
            return
        self.imu_t = np.concatenate([self.imu_t, t])
        self.gyro = np.vstack([self.gyro, np.asarray(gyro, float).reshape(-1, 3)])
        cut = np.searchsorted(self.imu_t, self.imu_t[-1] - self.keep_s)
        if cut > len(t):  # trim in steps, not every push
            self.imu_t, self.gyro = self.imu_t[cut:], self.gyro[cut:]
        self._process()

    def push_odometry(self, t: float, rate_b) -> None:
        """One filter epoch: its stamp t s and its mean bias-corrected body rate (3,) rad/s."""
        self.queue.append((float(t), np.asarray(rate_b, float).reshape(3)))
        self._process()

    def _process(self) -> None:
        while self.queue and len(self.imu_t) and self.imu_t[-1] >= self.queue[0][0]:
            t, rate = self.queue.popleft()
            prev, self.last_t = self.last_t, t
            if prev is None or not 0.0 < t - prev <= self.max_epoch_s:
                continue
            sel = (self.imu_t > prev) & (self.imu_t <= t)
            g = self.gyro[sel]
            if not len(g) or not np.isfinite(g).all() or not np.isfinite(rate).all():
                continue
            self.diffs.append((t, g.mean(axis=0) - rate))
            self.epochs += 1
            while self.diffs[0][0] <= t - self.average_s:  # the last average_s: (t - average_s, t]
                self.diffs.popleft()

    def estimate(self):
        """(bias (3,) rad/s, 95 % interval (3, 2), epochs averaged) over the last ``average_s``; None before two."""
        if len(self.diffs) < 2:
            return None
        d = np.array([v for _, v in self.diffs])
        mean, half = d.mean(axis=0), Z95 * d.std(axis=0, ddof=1) / np.sqrt(len(d))
        return mean, np.column_stack([mean - half, mean + half]), len(d)
