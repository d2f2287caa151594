"""Strapdown mechanization against closed-form motions (independent truth in ins_gps_kf.synthetic)."""


import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nav_core import earth, frames
from nav_core.units import DEG
from ins_gps_kf import strapdown
from ins_gps_kf import synthetic as syn


def _run_free_inertial(motion, rate_hz, chunks=None):
    """Integrate the ideal IMU of ``motion`` from the true initial state; returns (nav history at stamps, truth)."""
    imu = syn.ideal_imu(motion, rate_hz)
    t, pos, vel, yaw = syn.truth(motion, rate_hz)
    lat0 = motion.lat0_deg * DEG
    nav = strapdown.new_state(frames.quat_xyzw_from_euler(0.0, 0.0, yaw[0]), vel[0], pos[0])
    mem = strapdown.new_memory(0.0)
    w_ie = earth.earth_rate_n(lat0)
    g_n = earth.gravity_n(lat0, motion.h0_m)
    out = np.empty((len(imu), 3))
    bounds = chunks if chunks is not None else np.arange(len(imu) + 1)
    for s, e in zip(bounds[:-1], bounds[1:]):
        w_en = earth.transport_rate_n(lat0, motion.h0_m, nav[strapdown.V])
        strapdown.integrate(nav, mem, imu.t[s:e], imu.gyro[s:e], imu.accel[s:e], np.zeros(3), np.zeros(3),
                            w_ie, w_en, g_n)
        out[e - 1] = nav[strapdown.P]
    return nav, pos[1:], vel[1:], yaw[1:], out


def test_stationary_ideal_imu_with_earth_rate_stays_put():
    motion = syn.stationary(duration_s=300.0, yaw0=0.7)
    nav, pos, _, yaw, _ = _run_free_inertial(motion, 64.0, chunks=np.array([0, 300 * 64]))
    assert np.linalg.norm(nav[strapdown.P] - pos[-1]) < 0.01
    assert np.linalg.norm(nav[strapdown.V]) < 1e-4
    roll, pitch, yaw_est = frames.euler_from_quat_xyzw(nav[strapdown.Q])
    assert abs(roll) < 1e-6 and abs(pitch) < 1e-6 and abs(frames.wrap_angle(yaw_est - yaw[-1])) < 1e-6


def test_straight_line_with_acceleration_tracks_truth():
    motion = syn.straight(still_s=5.0, accel_s=10.0, cruise_s=100.0, accel=1.5)
    nav, pos, vel, _, _ = _run_free_inertial(motion, 64.0, chunks=np.arange(0, 115 * 64 + 1, 32))
    assert np.linalg.norm(nav[strapdown.V] - vel[-1]) < 1e-3
    assert np.linalg.norm(nav[strapdown.P] - pos[-1]) < 0.1  # Earth terms held at the datum here


def test_circle_tracks_truth_with_rotation_and_transport_terms():
    motion = syn.circle(still_s=2.0, accel_s=10.0, straight_s=2.0, turn_s=200.0, accel=1.0, yaw_rate=0.1)
    nav, pos, vel, yaw, _ = _run_free_inertial(motion, 100.0, chunks=np.arange(0, 214 * 100 + 1, 50))
    assert np.linalg.norm(nav[strapdown.P] - pos[-1]) < 0.2
    assert np.linalg.norm(nav[strapdown.V] - vel[-1]) < 5e-3
    yaw_est = frames.euler_from_quat_xyzw(nav[strapdown.Q])[2]
    assert abs(frames.wrap_angle(yaw_est - yaw[-1])) < 1e-4


@settings(max_examples=20, deadline=None)
@given(st.lists(st.integers(min_value=1, max_value=199), min_size=0, max_size=8, unique=True),
       st.integers(min_value=0, max_value=2**31))
def test_chunking_does_not_change_the_result(cuts, seed):
    rng = np.random.default_rng(seed)
    n = 200
    t = np.arange(1, n + 1) / 64.0
    gyro = rng.normal(0, 0.5, (n, 3))
    accel = rng.normal(0, 2.0, (n, 3)) + [0, 0, 9.8]
    args = (np.zeros(3), np.zeros(3), earth.earth_rate_n(0.8), np.zeros(3), earth.gravity_n(0.8))
    one = strapdown.new_state([0, 0, 0, 1.0], np.zeros(3), np.zeros(3))
    mem1 = strapdown.new_memory(0.0)
    strapdown.integrate(one, mem1, t, gyro, accel, *args)
    many = strapdown.new_state([0, 0, 0, 1.0], np.zeros(3), np.zeros(3))
    mem2 = strapdown.new_memory(0.0)
    bounds = [0, *sorted(cuts), n]
    for s, e in zip(bounds[:-1], bounds[1:]):
        strapdown.integrate(many, mem2, t[s:e], gyro[s:e], accel[s:e], *args)
    np.testing.assert_array_equal(one, many)
    assert abs(np.linalg.norm(one[strapdown.Q]) - 1.0) < 1e-12


def test_coning_correction_recovers_attitude_of_a_coning_motion():
    """Classical coning: the body axis z sweeps a cone; the two-sample algorithm must beat plain integration."""
    alpha, big_omega, rate = 0.02, 2 * np.pi * 5.0, 64.0
    n = int(10 * rate)
    t = np.arange(0, n + 1) / rate

    def true_quat(tt):
        # q(t) = Rz(Wt) Rx(alpha) Rz(-Wt): a cone of half-angle alpha about z
        return (frames.rotation_from_euler(0.0, 0.0, big_omega * tt) * frames.rotation_from_euler(alpha, 0.0, 0.0)
                * frames.rotation_from_euler(0.0, 0.0, -big_omega * tt))

    rots = true_quat(t)
    dtheta = (rots[:-1].inv() * rots[1:]).as_rotvec()  # exact body rotation over each interval
    # increments of a real sensor are integrals of the rate: approximate with a fine sum
    fine = 64
    tf = np.arange(0, n * fine + 1) / (rate * fine)
    rf = true_quat(tf)
    dth_f = (rf[:-1].inv() * rf[1:]).as_rotvec()
    dtheta = dth_f.reshape(n, fine, 3).sum(axis=1)
    nav = strapdown.new_state(rots[0].as_quat(), np.zeros(3), np.zeros(3))
    mem = strapdown.new_memory(0.0)
    zero = np.zeros(3)
    strapdown.integrate(nav, mem, t[1:], dtheta * rate, np.zeros((n, 3)), zero, zero, zero, zero, zero)
    err = (frames.Rotation.from_quat(nav[strapdown.Q]) * rots[-1].inv()).magnitude()
    # without the coning term the drift is alpha^2 * Omega * T / 2 ~ 0.063 rad (minus sampling): far above
    naive = frames.Rotation.from_quat(rots[0].as_quat())
    for d in dtheta:
        naive = naive * frames.Rotation.from_rotvec(d)
    naive_err = (naive * rots[-1].inv()).magnitude()
    assert err < 0.1 * naive_err
