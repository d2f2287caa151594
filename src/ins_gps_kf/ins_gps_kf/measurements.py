"""Measurements as ``(z, H, R)``: innovation (predicted minus measured), Jacobian on the error state, noise covariance."""
from __future__ import annotations

import numpy as np

from nav_core.frames import skew
from ins_gps_kf.error_model import DP, DV, N_STATES, PHI


def gps_position(pos_n, vel_n, mat_nb, lever_arm_b, fix_enu, fix_cov, lag_s, n_states=N_STATES):
    """GPS antenna position: INS position (m, ENU) moved by the lever arm (m, body), back by ``lag_s`` s.

    ``fix_cov`` (3, 3) m^2; the fix was taken ``lag_s`` seconds before the INS epoch.
    """
    arm_n = mat_nb @ np.asarray(lever_arm_b, dtype=float)
    predicted = pos_n + arm_n - vel_n * lag_s
    h = np.zeros((3, n_states))
    h[:, DP] = np.eye(3)
    h[:, DV] = -lag_s * np.eye(3)
    h[:, PHI] = skew(arm_n)
    return predicted - fix_enu, h, np.asarray(fix_cov, dtype=float)


def zero_velocity(vel_n, std_mps, n_states=N_STATES):
    """Zero-velocity update: the INS velocity (m/s, ENU) should be zero; ``std_mps`` per axis."""
    h = np.zeros((3, n_states))
    h[:, DV] = np.eye(3)
    return np.asarray(vel_n, dtype=float).copy(), h, np.eye(3) * std_mps**2


UNKNOWN_FIX_STD_M = 10.0
"""Std (m) assumed when a fix carries no covariance (NavSatFix COVARIANCE_TYPE_UNKNOWN) and none is configured."""


def fix_covariance(std_enu, cfg_std_h, cfg_std_u, floor):
    """GPS covariance (3, 3) m^2: the configured std where set (> 0), else the message's, floored."""
    std = np.asarray(std_enu, dtype=float).copy()
    if cfg_std_h > 0:
        std[:2] = cfg_std_h
    if cfg_std_u > 0:
        std[2] = cfg_std_u
    std = np.where(np.isfinite(std) & (std > 0), std, UNKNOWN_FIX_STD_M)
    return np.diag(np.maximum(std, floor) ** 2)
