"""Bridging policy: a forward IMU gap up to ``max_bridged_gap_s`` is crossed instead of resetting the filter.

The gap is filled with the mean of the last second of samples (one noisy sample would be worse), and the
covariance grows by what the vehicle may have done meanwhile (``bridge_*_std``), so the next fixes pull
the solution back.
"""
from __future__ import annotations

import numpy as np

from ins_gps_kf.config import FilterConfig
from ins_gps_kf.error_model import DP, DV, YAW


def time_breaks(t: np.ndarray, t_last: float | None, time_jump_s: float) -> np.ndarray:
    """Indices where the stamp (s) goes backwards or jumps forward by more than ``time_jump_s`` s."""
    prev = np.concatenate(([t[0] if t_last is None else t_last], t[:-1]))
    dt = t - prev
    return np.flatnonzero((dt < 0.0) | (dt > time_jump_s))


class GapBridge:
    """The last second of IMU samples and the rules for crossing a gap with them."""

    def __init__(self, cfg: FilterConfig):
        self.cfg = cfg
        self.recent = None  # (n, 6) gyro rad/s then accel m/s^2

    def clear(self) -> None:
        """Forget the remembered samples (after a reset)."""
        self.recent = None

    def remember(self, gyro, accel) -> None:
        """Keep the last second of samples (n, 6): a bridged gap holds their mean, not one noisy sample."""
        n = max(int(self.cfg.imu_rate_hz), 1)
        rows = np.hstack([gyro[-n:], accel[-n:]])
        if len(rows) < n and self.recent is not None:
            rows = np.vstack([self.recent, rows])[-n:]
        self.recent = rows

    def can_bridge(self, gap_s: float, navigating: bool) -> bool:
        """Whether a gap of ``gap_s`` s is crossed (True) or resets the filter."""
        return 0.0 < gap_s <= self.cfg.max_bridged_gap and navigating and self.recent is not None

    def grow(self, cov: np.ndarray, gap_s: float) -> None:
        """Grow ``cov`` in place by the vehicle's possible motion over ``gap_s`` s."""
        cov[DV, DV] += np.eye(3) * (self.cfg.bridge_accel_std * gap_s) ** 2
        cov[DP, DP] += np.eye(3) * (0.5 * self.cfg.bridge_accel_std * gap_s**2) ** 2
        # A road vehicle turns about the vertical; its roll and pitch stay within a few degrees, so only the
        # heading uncertainty grows with the turn rate (tilt growth would let GPS updates bend the tilt).
        cov[YAW, YAW] += (self.cfg.bridge_rate_std * gap_s) ** 2

    def held(self, t_from: float, t_to: float):
        """(t (n,) s, gyro (n, 3), accel (n, 3)): the held mean sample at the nominal rate inside the gap, or
        None when the gap holds no sample slot."""
        n = int(np.floor((t_to - t_from) * self.cfg.imu_rate_hz)) - 1
        if n < 1:
            return None
        ts = t_from + np.arange(1, n + 1) / self.cfg.imu_rate_hz
        held = np.tile(self.recent.mean(axis=0), (n, 1))
        return ts, held[:, :3], held[:, 3:]
