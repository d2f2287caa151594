"""Heading from the GNSS course, and the GPS reset: setting yaw, velocity and position from fixes.

The course of the chord from an earlier fix is the heading at the chord's middle; the INS yaw change
since then (gyros are good over seconds) brings it to now. After too many rejected fixes in a row the
INS has diverged, usually with a wrong heading or velocity: the position restarts at the fix and the
heading is taken from the course again.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import frames
from ins_gps_kf import error_model as em
from ins_gps_kf import input_checks, kalman, strapdown
from ins_gps_kf.alignment import yaw_from_displacement
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import Fix

HEADING_BASELINE_SIGMAS = 10.0  # course baseline at least this many GPS sigmas: heading error ~ 1/10 rad worst
HEADING_HISTORY_S = 10.0  # longest course baseline, s
UNKNOWN_STD_HEADING_HISTORY_S = 30.0  # with fixes of unknown std (10 m assumed) a longer baseline is needed
RESET_STATES = em.index(em.DP, em.DV, em.YAW)  # what a heading from course or a GPS reset sets anew


def ins_yaw(nav) -> float:
    """Yaw (rad, ENU) of the strapdown state."""
    return float(frames.euler_from_quat_xyzw(nav[strapdown.Q])[2])


class HeadingFromCourse:
    """The fixes (with the INS yaw at their epochs) kept while the heading is pending."""

    def __init__(self, cfg: FilterConfig):
        self.cfg = cfg
        self.history = []  # (fix, INS yaw at its epoch, rad)

    def course(self, fix: Fix, yaw_ins: float):
        """(yaw rad, speed m/s, climb m/s, course std rad) from the longest good chord ending at ``fix``, or None
        (then ``fix`` is kept as a chord start)."""
        cfg = self.cfg
        window = HEADING_HISTORY_S if fix.std_known else UNKNOWN_STD_HEADING_HISTORY_S
        self.history = [(f, y) for f, y in self.history if fix.t - f.t <= window]
        if input_checks.jumps([f for f, _ in self.history[-2:]] + [fix], cfg.max_speed, cfg.max_accel):
            return None  # the fix jumped away from the track: neither a course nor a baseline for one
        for prev, prev_yaw in reversed(self.history):
            d, dt = fix.enu - prev.enu, fix.t - prev.t
            dist = float(np.hypot(d[0], d[1]))
            sigma = float(np.sqrt(fix.cov[0, 0] + prev.cov[0, 0]))
            possible = dist <= cfg.max_speed * dt + input_checks.NOISE_SIGMAS * sigma  # else a jump
            if dt > 0 and dist / dt >= cfg.heading_min_speed and dist >= HEADING_BASELINE_SIGMAS * sigma and possible:
                yaw = yaw_from_displacement(d) + 0.5 * float(frames.wrap_angle(yaw_ins - prev_yaw))
                return yaw, dist / dt, d[2] / dt, sigma / dist
        self.history.append((fix, yaw_ins))
        return None


def set_heading(nav, cov, fix: Fix, t_e: float, course: tuple, lever_arm_b, heading_std: float) -> None:
    """Heading, ground speed and climb from ``course`` (see :meth:`HeadingFromCourse.course`), position from the
    fix moved to the epoch ``t_e`` s; ``nav`` and ``cov`` changed in place."""
    yaw, speed, climb, course_std = course
    roll, pitch, _ = frames.euler_from_quat_xyzw(nav[strapdown.Q])
    quat = frames.quat_xyzw_from_euler(roll, pitch, yaw)
    vel = np.array([speed * np.cos(yaw), speed * np.sin(yaw), climb])
    nav[strapdown.Q] = quat
    nav[strapdown.V] = vel
    nav[strapdown.P] = fix.enu - Rotation.from_quat(quat).as_matrix() @ lever_arm_b
    nav[strapdown.P] += vel * (t_e - fix.t)
    # the chord speed is a mean over the baseline: while accelerating it lags by up to half the change
    vel_var = np.diag(fix.cov) * 2.0 + (0.2 * speed) ** 2 + 0.1**2
    kalman.reset_block(cov, RESET_STATES, np.concatenate([np.diag(fix.cov), vel_var,
                                                          [heading_std**2 + course_std**2]]))


def reset_to_fix(nav, cov, fix: Fix, lever_arm_b, heading_std: float) -> None:
    """The GPS reset: position at the fix, velocity zero and uncertain, heading uncertain; in place."""
    nav[strapdown.P] = fix.enu - strapdown.mat_nb(nav) @ lever_arm_b
    nav[strapdown.V] = 0.0
    speed_var = max(float(np.sum(np.diag(cov[em.DV, em.DV]))), 1.0)
    kalman.reset_block(cov, RESET_STATES, np.concatenate([np.diag(fix.cov), np.full(3, speed_var),
                                                          [heading_std**2]]))
