"""Error-free IMU output: mean angular rate and specific force over each sample interval (t_k - dt, t_k].

Gyro: rotation vector of the attitude change across the interval over dt (the body's motion over the
Earth) plus the Simpson mean of C_bn (w_ie + w_en). Accelerometer: the Simpson mean of
C_bn (v' + (2 w_ie + w_en) x v + (0, 0, gamma)). All on the Motion's fine grid of ``m`` steps a sample.
"""
import numpy as np

from . import earth


def simpson_weights(m: int) -> np.ndarray:
    """Weights of the composite Simpson mean over m (even) equal steps, summing to 1."""
    if m % 2:
        raise ValueError("m must be even")
    w = np.ones(m + 1)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    return w / w.sum()


def interval_means(x: np.ndarray, m: int) -> np.ndarray:
    """Simpson means of fine-grid rows ``x`` (shape (n*m+1, k)) over each of the n intervals."""
    n = (len(x) - 1) // m
    idx = np.arange(n)[:, None] * m + np.arange(m + 1)[None]
    return np.einsum("j,njk->nk", simpson_weights(m), x[idx])


def specific_force_enu(motion) -> np.ndarray:
    """True specific force in ENU on the fine grid, m/s^2."""
    w_ie = earth.earth_rate_enu(motion.lat)
    w_en = earth.transport_rate_enu(motion.lat, motion.h, motion.v)
    up = np.zeros_like(motion.v)
    up[:, 2] = earth.normal_gravity(motion.lat, motion.h)
    return motion.vdot + np.cross(2 * w_ie + w_en, motion.v) + up


def ideal_imu(motion, m: int):
    """(gyro rad/s, accel m/s^2), each shape (n, 3): the interval means of the true motion."""
    rot = motion.rot
    inv = rot.inv()
    ends = np.arange(0, len(motion.t), m)
    dt = motion.t[m] - motion.t[0]
    w_nb = (rot[ends[:-1]].inv() * rot[ends[1:]]).as_rotvec() / dt
    w_in = earth.earth_rate_enu(motion.lat) + earth.transport_rate_enu(motion.lat, motion.h, motion.v)
    gyro = w_nb + interval_means(inv.apply(w_in), m)
    accel = interval_means(inv.apply(specific_force_enu(motion)), m)
    return gyro, accel
