"""imu_sim ideal sensors: exact Earth-model readings at rest, and noise-free increments that an
independent high-order integrator turns back into the trajectory to millimetres."""
import numba
import numpy as np
import pymap3d
import pytest
from hypothesis import given, settings, strategies as st
from scipy.interpolate import make_interp_spline
from scipy.spatial.transform import Rotation

from nav_core import earth
from nav_core.units import DEG, G0

from imu_sim import kinematics, trajectory

from conftest import shared_data


@settings(max_examples=25, deadline=None)
@given(lat=st.floats(-89, 89), h=st.floats(-100, 3000), roll=st.floats(-180, 180),
       pitch=st.floats(-89, 89), yaw=st.floats(-180, 180))
def test_resting_imu_reads_rotated_normal_gravity_and_earth_rate(lat, h, roll, pitch, yaw):
    traj = trajectory.static_trajectory([{"t0": 0, "t1": 2, "roll_deg": roll, "pitch_deg": pitch,
                                          "yaw_deg": yaw}], lat, 10.0, h)
    gyro, accel = kinematics.true_rates(traj, np.array([0.5, 1.5]), kinematics.FULL)
    rot = Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True)
    g = earth.normal_gravity(lat * DEG, h)
    np.testing.assert_allclose(accel, np.tile(rot.inv().apply([0, 0, g]), (2, 1)), atol=1e-12)
    np.testing.assert_allclose(gyro, np.tile(rot.inv().apply(earth.earth_rate_n(lat * DEG)), (2, 1)), atol=1e-16)


def test_level_imu_reads_plus_g_on_z_and_vertical_earth_rate_on_gyro_z():
    traj = trajectory.static_trajectory([{"t0": 0, "t1": 10, "roll_deg": 0, "pitch_deg": 0, "yaw_deg": 40}],
                                        45.0, 7.0, 0.0)
    dtheta, dv = kinematics.increments(traj, kinematics.sample_times(traj, 64.0), 1 / 64)
    assert dv[:, 2] * 64 == pytest.approx(earth.normal_gravity(45 * DEG), abs=1e-12)
    assert dtheta[:, 2] * 64 == pytest.approx(earth.RATE * np.sin(45 * DEG), abs=1e-18)


def test_naive_physics_has_constant_gravity_and_no_earth_rate():
    traj = trajectory.static_trajectory([{"t0": 0, "t1": 4, "roll_deg": 10, "pitch_deg": 20, "yaw_deg": 30}],
                                        60.0, 0.0, 500.0)
    gyro, accel = kinematics.true_rates(traj, np.linspace(0, 4, 9), kinematics.NAIVE)
    np.testing.assert_allclose(np.linalg.norm(accel, axis=1), G0, atol=1e-12)
    np.testing.assert_allclose(gyro, 0.0, atol=1e-18)


def test_rate_table_spin_reads_commanded_rate_plus_earth_rate():
    segs = trajectory.rate_table_segments(rates_dps=(-50.0, 100.0), hold_s=20, move_s=5)
    traj = trajectory.static_trajectory(segs, 30.0, 0.0, 0.0)
    t = np.array([5.0, 15.0, 30.0, 40.0])
    gyro, _ = kinematics.true_rates(traj, t, kinematics.FULL)
    expected = np.array([-50, -50, 100, 100]) * DEG + earth.RATE * np.sin(30 * DEG)
    np.testing.assert_allclose(gyro[:, 2], expected, atol=1e-12)


# ----------------------------------------------------------------------------- reference integrator


@numba.njit(cache=True)
def _geodetic(r, a, e2):
    p = np.hypot(r[0], r[1])
    lat = np.arctan2(r[2], p * (1 - e2))
    h = 0.0
    for _ in range(6):
        n = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(r[2], p * (1 - e2 * n / (n + h)))
    return lat, np.arctan2(r[1], r[0]), h


@numba.njit(cache=True)
def _gravity_e(r, consts):
    a, e2, f, ge, k, m = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5]
    lat, lon, h = _geodetic(r, a, e2)
    s2 = np.sin(lat) ** 2
    g0 = ge * (1 + k * s2) / np.sqrt(1 - e2 * s2)
    g = g0 * (1 - 2 / a * (1 + f + m - 2 * f * s2) * h + 3 * h * h / (a * a))
    up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    return -g * up


@numba.njit(cache=True)
def _qmul(p, q):  # (w, x, y, z)
    return np.array([p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
                     p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
                     p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
                     p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]])


@numba.njit(cache=True)
def _rotate(q, v):
    qv = np.array([0.0, v[0], v[1], v[2]])
    conj = np.array([q[0], -q[1], -q[2], -q[3]])
    return _qmul(_qmul(q, qv), conj)[1:]


@numba.njit(cache=True)
def _deriv(y, w_b, f_b, omega, consts):
    q, v, r = y[:4], y[4:7], y[7:]
    we = np.array([0.0, 0.0, omega])
    dq = 0.5 * _qmul(q, np.array([0.0, w_b[0], w_b[1], w_b[2]])) \
        - 0.5 * _qmul(np.array([0.0, 0.0, 0.0, omega]), q)
    dv = _rotate(q, f_b) - 2.0 * np.cross(we, v) + _gravity_e(r, consts)
    out = np.empty(10)
    out[:4], out[4:7], out[7:] = dq, dv, v
    return out


@numba.njit(cache=True)
def _rk4(y0, w_nodes, f_nodes, dt, omega, consts):
    """Classical RK4 in ECEF; nodes (n, 3, 3): rate and force at t_k, t_k + dt/2, t_k + dt."""
    n = w_nodes.shape[0]
    out = np.empty((n + 1, 10))
    y = y0.copy()
    out[0] = y
    for k in range(n):
        k1 = _deriv(y, w_nodes[k, 0], f_nodes[k, 0], omega, consts)
        k2 = _deriv(y + 0.5 * dt * k1, w_nodes[k, 1], f_nodes[k, 1], omega, consts)
        k3 = _deriv(y + 0.5 * dt * k2, w_nodes[k, 1], f_nodes[k, 1], omega, consts)
        k4 = _deriv(y + dt * k3, w_nodes[k, 2], f_nodes[k, 2], omega, consts)
        y = y + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        y[:4] /= np.sqrt(np.sum(y[:4] ** 2))
        out[k + 1] = y
    return out


def _rates_from_increments(t_edges, increments):
    """Continuous rate whose integral over every interval equals the increment (quintic spline)."""
    cumulative = np.vstack([np.zeros(3), np.cumsum(increments, axis=0)])
    return make_interp_spline(t_edges, cumulative, k=5).derivative()


def _integrate(traj, dt, dtheta, dv):
    t_edges = traj.t0 + dt * np.arange(len(dtheta) + 1)
    w_spl, f_spl = _rates_from_increments(t_edges, dtheta), _rates_from_increments(t_edges, dv)
    node_t = t_edges[:-1, None] + dt * np.array([0.0, 0.5, 1.0])
    w_nodes = w_spl(node_t.ravel()).reshape(-1, 3, 3)
    f_nodes = f_spl(node_t.ravel()).reshape(-1, 3, 3)
    m = traj.mat_e_enu0()
    r0_e = np.array(pymap3d.geodetic2ecef(traj.frame.lat0_deg, traj.frame.lon0_deg, traj.frame.h0_m))
    lat, lon, _ = traj.geodetic(np.array([traj.t0]))
    c_en = earth.mat_ne(lat, lon)[0].T
    q_eb = Rotation.from_matrix(c_en) * traj.attitude.rotation(np.array([traj.t0]))[0]
    x, y, z, w = q_eb.as_quat()
    state0 = np.concatenate([[w, x, y, z], traj.position.enu(np.array([traj.t0]), 1)[0] @ m.T,
                             r0_e + traj.position.enu(np.array([traj.t0]))[0] @ m.T])
    consts = np.array([earth.A, earth.E2, earth.F, earth.GAMMA_E, earth.K_SOMIGLIANA, earth.M_RATIO])
    states = _rk4(state0, w_nodes, f_nodes, dt, earth.RATE, consts)
    r_true = r0_e + traj.position.enu(t_edges) @ m.T
    q = states[:, [1, 2, 3, 0]]
    lat, lon, _ = traj.geodetic(t_edges)
    rot_true = Rotation.from_matrix(np.transpose(earth.mat_ne(lat, lon), (0, 2, 1))) * traj.attitude.rotation(t_edges)
    att_err = (Rotation.from_quat(q).inv() * rot_true).magnitude()
    return np.linalg.norm(states[:, 7:] - r_true, axis=1), att_err


def _check_reproduces(traj, rate_hz=64.0):
    dt = 1.0 / rate_hz
    t = kinematics.sample_times(traj, rate_hz)
    dtheta, dv = kinematics.increments(traj, t, dt, kinematics.FULL)
    pos_err, att_err = _integrate(traj, dt, dtheta, dv)
    return pos_err, att_err


@pytest.mark.slow
def test_noise_free_increments_reproduce_the_paper_drive_to_millimetres_over_10_minutes():
    traj = trajectory.paper_drive()
    traj.t1 = traj.t0 + 600.0
    pos_err, att_err = _check_reproduces(traj)
    assert pos_err.max() < 1e-3, f"max position error {pos_err.max():.2e} m"
    assert att_err.max() < 1e-9


@pytest.mark.slow
def test_noise_free_increments_reproduce_a_real_gnss_track_drive_to_millimetres_over_10_minutes():
    traj = trajectory.gnss_track_trajectory(shared_data("kfgins_gnss", "GNSS-RTK.txt"), duration_s=600.0)
    pos_err, att_err = _check_reproduces(traj)
    assert pos_err.max() < 1e-3, f"max position error {pos_err.max():.2e} m"
    # Brief 1e-7 rad transients where the fitted yaw turns sharply; they do not accumulate.
    assert att_err.max() < 1e-6 and att_err[-1] < 1e-8
