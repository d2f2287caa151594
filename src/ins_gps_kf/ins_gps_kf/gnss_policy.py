"""GNSS gating policy: which fix an epoch uses (the newest pending one, or optionally the last one again), the
chord speed the ZUPT veto reads, and when too many rejected fixes in a row make a GPS reset (not after a jump).

The chi-square gate itself is :func:`ins_gps_kf.kalman.correct`'s; this module keeps the judged fixes' history
and counts (``fixes_rejected``, ``fixes_reused`` in :class:`ins_gps_kf.records.Counters`).
"""
from __future__ import annotations

import numpy as np

from ins_gps_kf import input_checks
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import Counters, Fix


class GnssPolicy:
    """The fixes between queueing and judging: pending, previous, rejections in a row, the history of jumps."""

    def __init__(self, cfg: FilterConfig, counters: Counters, input_counters):
        self.cfg = cfg
        self.counters = counters
        self.pending_fix: Fix | None = None
        self.prev_fix: Fix | None = None
        self.rejected_in_row = 0
        self.fix_history = input_checks.FixHistory(cfg.max_rejected_fixes, cfg.max_speed, cfg.max_accel,
                                                   input_counters)
        self.gps_speed = 0.0  # horizontal speed between the last two fixes, m/s, less 3 sigma of its noise

    def take(self, t_e: float):
        """(fix, reused) for the epoch at ``t_e`` s, or None: the pending fix, else (``reuse_last_fix``) the last
        one while younger than 1.5 GPS periods; the chord speed follows each new fix."""
        fix, reused = self.pending_fix, False
        self.pending_fix = None
        if fix is not None and self.prev_fix is not None and fix.t > self.prev_fix.t:
            dt = fix.t - self.prev_fix.t
            noise = 3.0 * np.sqrt(fix.cov[0, 0] + self.prev_fix.cov[0, 0]) / dt
            self.gps_speed = max(float(np.hypot(*(fix.enu - self.prev_fix.enu)[:2])) / dt - noise, 0.0)
        if fix is None:
            max_age = 1.5 / self.cfg.gps_rate_hz
            if not (self.cfg.reuse_last_fix and self.prev_fix is not None and t_e - self.prev_fix.t <= max_age):
                return None
            fix, reused = self.prev_fix, True
        if not reused:
            self.fix_history.consumed(fix)
        return fix, reused

    def reset_due(self, fix: Fix) -> bool:
        """Whether ``fix`` (new) should reset the solution: too many rejected in a row, and no jump among them."""
        return self.rejected_in_row >= self.cfg.max_rejected_fixes and self.fix_history.reset_allowed(fix)

    def taken_whole(self, fix: Fix) -> None:
        """``fix`` set the solution (heading from course, GPS reset): accepted, no longer rejected in a row."""
        self.prev_fix = fix
        self.fix_history.judged(fix, True)

    def judged(self, fix: Fix, accepted: bool, reused: bool) -> None:
        """The gate's verdict on ``fix``, counted."""
        if not reused:
            self.prev_fix = fix
            self.counters.fixes_rejected += not accepted
            self.rejected_in_row = 0 if accepted else self.rejected_in_row + 1
            self.fix_history.judged(fix, accepted)
        else:
            self.counters.fixes_reused += 1
