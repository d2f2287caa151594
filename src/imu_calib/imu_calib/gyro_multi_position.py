"""Gyro scale factors and misalignment from the moves between static positions (imu_tk's second stage).

After the accelerometer stage (:mod:`imu_calib.multi_position`) every static
segment i gives the direction of the specific force ``v_i`` (unit vector, the
calibrated accelerometer frame). Between two consecutive segments the gyro,
corrected with the model ``measured = (I + diag(s) + M) true + b``, is
integrated into the body rotation ``R`` (one exact rotation-vector step per
sample, a Numba loop); a world-fixed vector then reads ``v_pred = R^T v_i`` in
the new pose. Scale factors s (3) and the six off-diagonal terms of M are
fitted by least squares so that ``v_pred`` matches ``v_{i+1}`` for every move
(Tedaldi, Pretto, Menegatti 2014). The bias b is the accelerometer stage's gyro
bias (initial static interval), as in imu_tk. M is relative to the calibrated
accelerometer frame, so all six off-diagonal terms are observable as long as the
moves turn about different axes. Rotation about gravity within one move is not
observable; the many moves about different axes make the whole fit determined.
Earth rate during a move (a few seconds) is neglected (it is in the bias).

Works on raw counts: the common counts-per-rad/s factor is found first by a
scan of one scale for all three axes, then refined with the rest.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy import optimize

from imu_calib.intervals import Z95

OFF_DIAGONAL = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
MIN_MOVES = 6
"""Nine parameters from three residuals per move: at least this many moves (about different axes)."""


@dataclass
class GyroCalibration:
    """Gyro scale factors (1), misalignment (3x3, rad, zero diagonal), 95 % intervals, residuals per move (rad)."""

    scale_factor: np.ndarray
    misalignment: np.ndarray
    intervals: dict
    residuals: np.ndarray
    """Angle between predicted and measured gravity direction after each move, rad (fitted model)."""
    residuals_before: np.ndarray
    """The same with the bias removed but no scale or misalignment correction (the common scale only)."""
    n_moves: int

    def matrix(self) -> np.ndarray:
        """I + diag(scale_factor) + misalignment."""
        return np.eye(3) + np.diag(self.scale_factor) + self.misalignment


@numba.njit(cache=True)
def _rotate_back(omega, dt, v):
    """R^T v for the body rotation R integrated from body rates ``omega`` (k, 3) rad/s, one step per sample."""
    # quaternion (w, x, y, z) of body-to-start rotation, q <- q * exp(omega dt / 2)
    qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
    for k in range(omega.shape[0]):
        rx, ry, rz = omega[k, 0] * dt, omega[k, 1] * dt, omega[k, 2] * dt
        angle = np.sqrt(rx * rx + ry * ry + rz * rz)
        if angle > 1e-12:
            s = np.sin(0.5 * angle) / angle
            dw, dx, dy, dz = np.cos(0.5 * angle), rx * s, ry * s, rz * s
        else:
            dw, dx, dy, dz = 1.0, 0.5 * rx, 0.5 * ry, 0.5 * rz
        qw, qx, qy, qz = (qw * dw - qx * dx - qy * dy - qz * dz, qw * dx + qx * dw + qy * dz - qz * dy,
                          qw * dy - qx * dz + qy * dw + qz * dx, qw * dz + qx * dy - qy * dx + qz * dw)
    norm = np.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    qw, qx, qy, qz = qw / norm, qx / norm, qy / norm, qz / norm
    # R^T v = rotate v by the conjugate quaternion
    x, y, z = v[0], v[1], v[2]
    tx, ty, tz = 2.0 * (-qy * z + qz * y), 2.0 * (-qz * x + qx * z), 2.0 * (-qx * y + qy * x)
    out = np.empty(3)
    out[0] = x + qw * tx + (-qy * tz + qz * ty)
    out[1] = y + qw * ty + (-qz * tx + qx * tz)
    out[2] = z + qw * tz + (-qx * ty + qy * tx)
    return out


def _matrix(p) -> np.ndarray:
    """I + diag(p[0:3]) + off-diagonal p[3:9]."""
    T = np.eye(3) + np.diag(p[0:3])
    for k, (i, j) in enumerate(OFF_DIAGONAL):
        T[i, j] = p[3 + k]
    return T


def _predicted(T, moves, dt):
    """Predicted gravity direction after each move for the gyro model matrix T (bias already removed)."""
    Tinv = np.linalg.inv(T)
    return np.array([_rotate_back(np.ascontiguousarray(raw @ Tinv.T), dt, v0) for raw, v0, _ in moves])


def _residuals(p, moves, dt):
    after = np.array([v1 for _, _, v1 in moves])
    return (_predicted(_matrix(p), moves, dt) - after).ravel()


def _angles(pred, moves) -> np.ndarray:
    after = np.array([v1 for _, _, v1 in moves])
    return np.arccos(np.clip(np.sum(pred * after, axis=1) / np.linalg.norm(pred, axis=1), -1.0, 1.0))


def _common_scale(moves, dt) -> float:
    """The one scale (counts per rad/s, 1 for SI data) that best explains all moves: a log scan, then refined."""
    grid = np.geomspace(1e-4, 1e6, 801)
    cost = [np.sum(_residuals(np.r_[np.full(3, k - 1.0), np.zeros(6)], moves, dt) ** 2) for k in grid]
    best = grid[int(np.argmin(cost))]
    res = optimize.minimize_scalar(lambda lk: np.sum(_residuals(np.r_[np.full(3, np.exp(lk) - 1.0), np.zeros(6)],
                                                                moves, dt) ** 2),
                                   bounds=(np.log(best / 1.05), np.log(best * 1.05)), method="bounded")
    return float(np.exp(res.x))


def moves_between(segments, gyro, gyro_bias, accel_matrix, accel_bias):
    """(bias-free gyro samples, unit specific force before, after) for each pair of consecutive segments."""
    A_inv = np.linalg.inv(accel_matrix)
    unit = [A_inv @ (s.accel_mean - accel_bias) for s in segments]
    unit = [u / np.linalg.norm(u) for u in unit]
    return [(np.asarray(gyro[a.stop:b.start], float) - gyro_bias, unit[i], unit[i + 1])
            for i, (a, b) in enumerate(zip(segments[:-1], segments[1:]))]


def fit_gyro(moves, rate_hz: float) -> GyroCalibration:
    """Least-squares gyro scale factors and misalignment from the moves (see module doc)."""
    if len(moves) < MIN_MOVES:
        raise ValueError(f"gyro calibration needs at least {MIN_MOVES} moves between static positions, "
                         f"found {len(moves)}")
    dt = 1.0 / rate_hz
    k = _common_scale(moves, dt)
    p0 = np.r_[np.full(3, k - 1.0), np.zeros(6)]
    before = _angles(_predicted(_matrix(p0), moves, dt), moves)
    res = optimize.least_squares(_residuals, p0, args=(moves, dt), x_scale=np.r_[np.full(3, k), np.full(6, k * 1e-2)],
                                 method="lm")
    # a unit-vector difference has 2 free components per move (the radial one is second order)
    dof = max(2 * len(moves) - len(p0), 1)
    cov = np.linalg.pinv(res.jac.T @ res.jac) * float(res.fun @ res.fun) / dof
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    T = _matrix(res.x)
    scale = np.diag(T) - 1.0
    mis = T - np.diag(np.diag(T))
    mis_ci = np.stack([mis, mis], axis=-1)
    for j, (r, c) in enumerate(OFF_DIAGONAL):
        mis_ci[r, c] = (mis[r, c] - Z95 * sd[3 + j], mis[r, c] + Z95 * sd[3 + j])
    intervals = {"scale_factor": np.stack([scale - Z95 * sd[:3], scale + Z95 * sd[:3]], axis=-1),
                 "misalignment": mis_ci}
    after = _angles(_predicted(T, moves, dt), moves)
    return GyroCalibration(scale, mis, intervals, after, before, len(moves))
