"""Start policy: how navigation begins once the aligner is done (stationary or in motion), as a new state.

A stationary start levels from the rest period, takes the gyro bias from it and the yaw from the
``initial_yaw_deg`` parameter, else leaves the heading pending (taken from the GPS course later). An
in-motion start takes level, course, velocity and position from the window the aligner fitted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import frames
from ins_gps_kf import error_model as em
from ins_gps_kf import strapdown
from ins_gps_kf.alignment import InMotionAligner, MotionAlignment, StationaryAligner
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import HEADING_PENDING, NAVIGATING


@dataclass
class Start:
    """A new navigation solution: strapdown state and memory, biases (body, SI), covariance, status."""

    nav: np.ndarray
    mem: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    cov: np.ndarray
    status: str


def make_aligner(cfg: FilterConfig, input_counters):
    """The aligner ``alignment_mode`` asks for (refused rest blocks counted in ``input_counters``)."""
    if cfg.alignment_mode == "in_motion":
        return InMotionAligner(cfg.motion_window_s, cfg.motion_max_accel, cfg.heading_min_speed,
                               cfg.motion_gyro_bias)
    # block means: the per-block noise is far below the per-sample thresholds, hence a quarter
    return StationaryAligner(cfg.alignment_time_s, cfg.min_alignment_time_s, 0.25 * cfg.stationary_gyro,
                             cfg.stationary_accel, max_rate=cfg.stationary_gyro,
                             on_refused=input_counters.counter("alignment_not_gravity"))


def scale_stds(cfg: FilterConfig, n_states: int) -> tuple:
    """Initial scale-factor stds (gyro, accel) when they are states, else nothing."""
    std = cfg.init_scale_factor_std
    return (std, std) if n_states == em.N_STATES_SF else ()


def start(cfg: FilterConfig, alignment, t0: float, pending_fix, lever_arm_b, model, n_states: int) -> Start:
    """The start from a finished ``alignment`` at ``t0`` s (``pending_fix``: the newest fix, or None)."""
    if isinstance(alignment, MotionAlignment):
        return _in_motion(cfg, alignment, t0, pending_fix, lever_arm_b, model, n_states)
    known_yaw = not math.isnan(cfg.initial_yaw)
    yaw = cfg.initial_yaw if known_yaw else 0.0
    quat = frames.quat_xyzw_from_euler(alignment.roll, alignment.pitch, yaw)
    pos, pos_std = np.zeros(3), 10.0
    if pending_fix is not None:
        mat_nb = Rotation.from_quat(quat).as_matrix()
        pos = pending_fix.enu - mat_nb @ lever_arm_b
        pos_std = np.sqrt(np.diag(pending_fix.cov))
    att_std = np.array([cfg.init_attitude_std, cfg.init_attitude_std, cfg.heading_std])
    cov = em.initial_covariance(pos_std, cfg.zupt_std, att_std, cfg.init_gyro_bias_std, cfg.init_accel_bias_std,
                                *scale_stds(cfg, n_states))
    return Start(strapdown.new_state(quat, np.zeros(3), pos), strapdown.new_memory(t0),
                 alignment.gyro_bias.copy(), np.zeros(3), cov, NAVIGATING if known_yaw else HEADING_PENDING)


def _in_motion(cfg: FilterConfig, al, t0, pending_fix, lever_arm_b, model, n_states) -> Start:
    """Navigation from an in-motion alignment: level (or the roll/pitch parameters), course, fitted velocity
    and position; gyro bias from the window, or zero (the model's when its calibration is not applied)."""
    tilt_std = al.tilt_std
    if not math.isnan(cfg.initial_roll):
        al.roll = cfg.initial_roll
    if not math.isnan(cfg.initial_pitch):
        al.pitch = cfg.initial_pitch
    if not (math.isnan(cfg.initial_roll) or math.isnan(cfg.initial_pitch)):
        tilt_std = cfg.init_attitude_std  # both given: as good as the parameters claim
    quat = frames.quat_xyzw_from_euler(al.roll, al.pitch, al.yaw)
    mat_nb = Rotation.from_quat(quat).as_matrix()
    pos = al.position_n - mat_nb @ lever_arm_b
    pos_std = (np.sqrt(np.diag(pending_fix.cov)) if pending_fix is not None
               else np.maximum(al.position_std, 1.0))
    from_model = not (cfg.motion_gyro_bias or cfg.apply_calibration)
    gyro_bias = model.gyro.bias.copy() if from_model else al.gyro_bias.copy()
    speed = float(np.hypot(al.velocity_n[0], al.velocity_n[1]))
    vel_std = np.sqrt(al.velocity_std**2 + (0.05 * speed) ** 2 + 0.1**2)
    att_std = np.array([max(tilt_std, cfg.init_attitude_std)] * 2 + [math.hypot(cfg.heading_std, al.yaw_std)])
    cov = em.initial_covariance(pos_std, vel_std, att_std, cfg.init_gyro_bias_std, cfg.init_accel_bias_std,
                                *scale_stds(cfg, n_states))
    return Start(strapdown.new_state(quat, al.velocity_n, pos), strapdown.new_memory(t0), gyro_bias, np.zeros(3),
                 cov, NAVIGATING)
