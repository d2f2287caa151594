"""Odometry from one estimate: pose, body-frame twist and their covariances, ROS-free (the node only converts).

Every field comes from the same :class:`ins_gps_kf.records.Estimate`: the body velocity is the
estimate's ENU velocity rotated by the estimate's own attitude (never a later one), so the
published twist does not depend on how the node's intake chunked the IMU samples.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core.frames import skew
from ins_gps_kf import error_model as em
from ins_gps_kf.records import Estimate


@dataclass(frozen=True)
class Odometry:
    """``nav_msgs/Odometry`` content in SI: pose in the local ENU frame (``map``), twist in the body frame."""

    t: float                    # s
    position_n: np.ndarray      # (3,) m, ENU
    quat_xyzw: np.ndarray       # (4,) body to ENU
    pose_cov: np.ndarray        # (6, 6) position (m^2) then attitude error about E, N, U (rad^2)
    velocity_b: np.ndarray      # (3,) m/s, body axes
    angular_rate_b: np.ndarray  # (3,) rad/s, body axes: the epoch's mean bias-corrected rate
    twist_cov: np.ndarray       # (6, 6) body velocity (m^2/s^2) then rate (rad^2/s^2)


def epoch_span(t: float, prev_t: float, filter_rate_hz: float, imu_rate_hz: float) -> float:
    """Time the epoch's mean rate averages over, s: since the last epoch when that is about one filter period,
    else one sample (after alignment or a reset the span is unknown)."""
    span = t - prev_t
    return span if 0.0 < span <= 1.5 / filter_rate_hz else 1.0 / imu_rate_hz


def odometry(est: Estimate, noise: em.NoiseModel, span_s: float) -> Odometry:
    """The odometry of ``est``; ``noise`` the filter's process noise, ``span_s`` the epoch's span (s)."""
    pose_idx = em.index(em.DP, em.PHI)
    mat_bn = Rotation.from_quat(est.quat_xyzw).as_matrix().T
    # body velocity error C_bn (dv - [v x] phi) (C_est = (I - [phi x]) C_true): the attitude error turns the
    # velocity too, so at speed the heading uncertainty dominates the lateral twist covariance
    vel_idx = em.index(em.DV, em.PHI)
    jac = mat_bn @ np.hstack([np.eye(3), -skew(est.velocity_n)])
    twist_cov = np.zeros((6, 6))
    twist_cov[:3, :3] = jac @ est.cov[np.ix_(vel_idx, vel_idx)] @ jac.T
    # the rate: white noise averaged over the epoch plus the bias uncertainty
    twist_cov[3:, 3:] = np.diag(noise.gyro_white ** 2 / span_s) + est.cov[em.BG, em.BG]
    rate = est.angular_rate_b if est.angular_rate_b is not None else np.zeros(3)
    return Odometry(est.t, est.position_n, est.quat_xyzw, est.cov[np.ix_(pose_idx, pose_idx)],
                    mat_bn @ est.velocity_n, np.asarray(rate, float), twist_cov)
