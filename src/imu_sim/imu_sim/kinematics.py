"""True angular rate and specific force of a trajectory, and exact IMU increments.

Full Earth model (nav_core.earth): in the local-level ENU frame n at the current point,

    f^n = dv_n/dt + (2 w_ie^n + w_en^n) x v_n - g^n(lat, h)
    w_ib^b = w_nb^b + C_bn (w_ie^n + w_en^n)

with v_n = C_ne v_e and dv_n/dt = C_ne a_e - w_en^n x v_n (a_e the ECEF acceleration,
exact spline derivatives). Each Earth term is switchable (:class:`Physics`):
``earth_rotation`` gives w_ie in the gyros; ``coriolis`` gives (2 w_ie + w_en) x v in the
accelerometers and the transport rate w_en in the gyros; ``gravity_model`` gives WGS-84
normal gravity by latitude and height instead of the constant 9.80665 m/s^2.

Increments are what an integrating IMU outputs: dtheta_k = integral of w_ib^b and
dv_k = integral of f^b (body frame rotating within the interval, so coning and
sculling of the true motion are in them) over (t_k - dt, t_k], by Gauss-Legendre
quadrature.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core import earth
from nav_core.units import G0

from imu_sim.trajectory import TruthTrajectory

QUADRATURE_NODES = 4
"""Gauss-Legendre nodes per sample interval (exact for polynomials of degree 7)."""
CHUNK_INTERVALS = 16384
"""Intervals evaluated at once (bounds peak memory)."""


@dataclass(frozen=True)
class Physics:
    """Which Earth-model terms the kinematics include."""

    earth_rotation: bool = False
    coriolis: bool = False
    gravity_model: bool = False

    @classmethod
    def from_effects(cls, physics: dict | None) -> Physics:
        """From a sensor model's physics section (None or missing names -> naive terms)."""
        physics = physics or {}
        return cls(*(name in physics for name in ("earth_rotation", "coriolis", "gravity_model")))


FULL = Physics(True, True, True)
NAIVE = Physics(False, False, False)


def _cross(a, b):
    return np.cross(a, b)


def true_rates(traj: TruthTrajectory, t, physics: Physics = FULL):
    """True angular rate w_ib^b (rad/s) and specific force f^b (m/s^2) at times t (s), each (n, 3)."""
    t = np.atleast_1d(np.asarray(t, float))
    lat, lon, h = traj.geodetic(t)
    c_ne = earth.mat_ne(lat, lon)
    m = traj.mat_e_enu0()
    v_n = np.einsum("nij,nj->ni", c_ne, traj.position.enu(t, 1) @ m.T)
    a_n = np.einsum("nij,nj->ni", c_ne, traj.position.enu(t, 2) @ m.T)
    w_en = earth.transport_rate_n(lat, h, v_n)
    w_ie = earth.earth_rate_n(lat)
    accel = a_n - _cross(w_en, v_n)
    w_in = np.zeros_like(v_n)
    if physics.coriolis:
        accel += _cross(2.0 * w_ie + w_en, v_n)
        w_in += w_en
    if physics.earth_rotation:
        w_in += w_ie
    if physics.gravity_model:
        accel -= earth.gravity_n(lat, h)
    else:
        accel[:, 2] += G0
    rot, rate_nb = traj.attitude.rotation_and_rate(t)
    rot_inv = rot.inv()
    return rate_nb + rot_inv.apply(w_in), rot_inv.apply(accel)


def sample_times(traj: TruthTrajectory, rate_hz: float) -> np.ndarray:
    """IMU sample stamps (s): sample k covers (t_k - dt, t_k], t_k = t0 + (k+1) dt, within the trajectory."""
    dt = 1.0 / rate_hz
    n = int(np.floor(traj.duration * rate_hz + 1e-9))
    return traj.t0 + dt * np.arange(1, n + 1)


def increments(traj: TruthTrajectory, t_end, dt: float, physics: Physics = FULL,
               nodes: int = QUADRATURE_NODES):
    """Exact angle (rad) and velocity (m/s) increments over (t_end - dt, t_end], each (n, 3)."""
    t_end = np.asarray(t_end, float)
    x, w = np.polynomial.legendre.leggauss(nodes)
    offsets, weights = 0.5 * dt * (x - 1.0), 0.5 * dt * w
    dtheta, dv = np.empty((len(t_end), 3)), np.empty((len(t_end), 3))
    for start in range(0, len(t_end), CHUNK_INTERVALS):
        stop = min(start + CHUNK_INTERVALS, len(t_end))
        times = (t_end[start:stop, None] + offsets[None, :]).ravel()
        rate, force = true_rates(traj, times, physics)
        dtheta[start:stop] = np.einsum("nkj,k->nj", rate.reshape(-1, nodes, 3), weights)
        dv[start:stop] = np.einsum("nkj,k->nj", force.reshape(-1, nodes, 3), weights)
    return dtheta, dv
