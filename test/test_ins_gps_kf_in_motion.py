"""Alignment in motion: a vehicle that never stands still gets level, heading and velocity while driving."""


import numpy as np
import pytest

from nav_core import frames
from nav_core.earth import LocalFrame
from nav_core.recording import GnssRecording, ImuRecording
from nav_core.units import DEG
from ins_gps_kf import alignment, config, synthetic as syn
from ins_gps_kf.filter import NAVIGATING, InsGpsFilter
from ins_gps_kf.offline import run

RATE = 32.0
START_S = 5.0  # the recording begins here, already moving and still accelerating


def _moving_start(seed, params=None, gps_std=1.0, gps_rate_hz=5.0, gyro_bias=(2e-4, -1e-4, 3e-4)):
    """Accelerate 20 s to 10 m/s, 40 s straight, then a constant turn; recorded from t = 5 s (moving)."""
    motion = syn.Motion((20.0, 40.0, 240.0), (0.5, 0.0, 0.0), (0.0, 0.0, 0.02), yaw0=1.1)
    rng = np.random.default_rng(seed)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, np.array(gyro_bias),
                             np.array([0.005, -0.004, 0.003]), 0.02 * DEG, 2e-3)
    gnss = syn.gnss(motion, RATE, gps_std, rng, gps_rate_hz=gps_rate_hz)
    k, g = imu.t >= START_S, gnss.t >= START_S
    imu = ImuRecording(imu.t[k], imu.gyro[k], imu.accel[k])
    gnss = GnssRecording(gnss.t[g], gnss.lat[g], gnss.lon[g], gnss.h[g], gnss.std_enu[g], gnss.status[g])
    filt = InsGpsFilter(config.from_params({"alignment_mode": "in_motion", **(params or {})}))
    return motion, filt, run(filt, imu, gnss)


def _errors(motion, filt, est):
    t_ref, pos, _, yaw = syn.truth(motion, RATE)
    idx = np.clip(np.round(np.array([e.t for e in est]) * RATE).astype(int), 0, len(t_ref) - 1)
    origin = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m)
    pos_f = filt.frame.to_enu(*origin.to_geodetic(pos[idx]))
    d = np.array([e.position_n for e in est]) - pos_f
    eul = np.column_stack(frames.euler_from_quat_xyzw(np.array([e.quat_xyzw for e in est])))
    return np.hypot(d[:, 0], d[:, 1]), frames.wrap_angle(eul[:, 2] - yaw[idx]), eul[:, :2]


def test_quadratic_track_fit_recovers_velocity_and_acceleration():
    t = np.linspace(0.0, 3.0, 16)
    vel0, acc = np.array([3.0, -2.0, 0.1]), np.array([0.2, 0.4, 0.0])
    enu = vel0 * t[:, None] + 0.5 * acc * t[:, None] ** 2
    pos, vel, a, resid = alignment.fit_track(t, enu, 3.0)
    np.testing.assert_allclose(vel, vel0 + 3.0 * acc, atol=1e-9)
    np.testing.assert_allclose(a, acc, atol=1e-9)
    np.testing.assert_allclose(pos, enu[-1], atol=1e-9)
    assert np.all(resid < 1e-9)


def test_in_motion_alignment_waits_for_constant_velocity_then_navigates():
    motion, filt, est = _moving_start(seed=3)
    nav = [e for e in est if e.status == NAVIGATING]
    assert nav, "never aligned in motion"
    # accelerating at 0.5 m/s^2 until t = 20 s: above the 0.2 m/s^2 limit, so no window accepted before
    assert nav[0].t >= 20.0
    assert filt.alignment.accel_h <= 0.2
    horiz, yaw_err, level = _errors(motion, filt, nav)
    # the course of a 10-s quadratic fit of 1-m fixes at 10 m/s: within a degree or two, as claimed
    assert abs(yaw_err[0]) < min(3.0 * filt.alignment.yaw_std, 3.0 * DEG)
    late = np.array([e.t for e in nav]) > nav[0].t + 30.0
    yaw_sd = np.sqrt([e.cov[8, 8] for e in nav])
    assert np.max(np.abs(yaw_err[late]) / yaw_sd[late]) < 3.0
    assert np.sqrt(np.mean(horiz[late] ** 2)) < 1.0  # below the 1 m per-axis GPS noise (1.4 m horizontal)
    assert np.max(np.abs(level[late])) < 1.0 * DEG


def test_in_motion_alignment_takes_roll_and_pitch_from_parameters():
    _, filt, est = _moving_start(seed=4, params={"initial_roll_deg": 2.0, "initial_pitch_deg": -1.0})
    assert filt.alignment.roll == pytest.approx(2.0 * DEG)
    assert filt.alignment.pitch == pytest.approx(-1.0 * DEG)
    assert any(e.status == NAVIGATING for e in est)


def test_in_motion_alignment_finds_large_horizontal_gyro_biases():
    bias = (-0.03, 0.05, 0.0)  # rad/s: the order of the balzer car's uncalibrated roll/pitch gyros (2-3 deg/s)
    _, filt, est = _moving_start(seed=6, gyro_bias=bias)
    # 10 s of 0.02 deg/sqrt(s) white noise: ~1e-4 rad/s
    np.testing.assert_allclose(filt.alignment.gyro_bias[:2], bias[:2], atol=5e-4)
    _, filt0, _ = _moving_start(seed=6, gyro_bias=bias, params={"motion_alignment_gyro_bias": False})
    assert np.all(filt0.alignment.gyro_bias == 0.0)


def test_bad_alignment_mode_is_a_config_error():
    with pytest.raises(config.FilterConfigError, match="alignment_mode"):
        config.from_params({"alignment_mode": "sideways"})
