"""The blind validation generator's own physics (benchmarks/blind/blindgen): checked, not trusted."""
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "blind"))
from blindgen import cases, earth, ideal, motion, sensor  # noqa: E402

LAT, LON, H = 48.0, 11.0, 500.0
DT, M = 0.01, 4


def _static(pieces):
    total = sum(p.duration_s for p in pieces)
    n = int(round(total / DT))
    mot = motion.fixed_point(pieces, LAT, LON, H, np.arange(n * M + 1) * DT / M)
    return ideal.ideal_imu(mot, M)


def test_level_static_imu_reads_gravity_up_and_the_vertical_earth_rate():
    gyro, accel = _static([motion.Hold(motion.euler_rot(0, 0, 0), 2.0)])
    lat = np.radians(LAT)
    np.testing.assert_allclose(accel, [[0, 0, earth.normal_gravity(lat, H)]] * len(accel), atol=1e-12)
    omega = earth.EARTH_RATE_RAD_S
    np.testing.assert_allclose(gyro, [[0, omega * np.cos(lat), omega * np.sin(lat)]] * len(gyro), atol=1e-15)


def test_upside_down_and_nose_up_faces_flip_gravity_onto_the_right_axis():
    g = earth.normal_gravity(np.radians(LAT), H)
    _, down = _static([motion.Hold(motion.euler_rot(180, 0, 0), 1.0)])
    _, x_up = _static([motion.Hold(motion.euler_rot(0, -90, 0), 1.0)])
    np.testing.assert_allclose(down[0], [0, 0, -g], atol=1e-9)
    np.testing.assert_allclose(x_up[0], [g, 0, 0], atol=1e-9)


def test_normal_gravity_matches_wgs84_equator_and_pole():
    assert earth.normal_gravity(0.0, 0.0) == pytest.approx(9.7803253359, abs=1e-9)
    assert earth.normal_gravity(np.pi / 2, 0.0) == pytest.approx(9.8321849378, abs=1e-9)
    # free-air gradient about -3.086e-6 s^-2
    assert (earth.normal_gravity(0.7, 1000.0) - earth.normal_gravity(0.7, 0.0)) == pytest.approx(-3.086e-3, rel=2e-3)


def test_rate_table_dwell_reads_the_table_rate_and_an_injected_scale_factor_shows():
    rate = np.radians(40.0)
    spin = motion.Spin(motion.euler_rot(0, 0, 0), np.array([0.0, 0, 1]), rate, ramp_s=1.0, dwell_s=3.0)
    gyro, accel = _static([spin])
    t = np.arange(1, len(gyro) + 1) * DT
    dwell = (t > 1.2) & (t < 3.8)
    vertical = earth.EARTH_RATE_RAD_S * np.sin(np.radians(LAT))
    np.testing.assert_allclose(gyro[dwell, 2], rate + vertical, atol=1e-12)
    # the horizontal Earth rate turns in the body at the table rate: its magnitude stays Omega cos(lat)
    np.testing.assert_allclose(np.hypot(gyro[dwell, 0], gyro[dwell, 1]),
                               earth.EARTH_RATE_RAD_S * np.cos(np.radians(LAT)), rtol=1e-3)
    assert spin.angle(spin.duration_s) == pytest.approx(rate * (1.0 + 3.0), rel=1e-12)
    terms = {"sf": np.array([0.0, 0.0, 2e-3]), "mis": np.zeros((3, 3))}
    measured = sensor.apply_triad(gyro, terms, np.zeros(3))
    np.testing.assert_allclose((measured[dwell, 2] - gyro[dwell, 2]) / gyro[dwell, 2], 2e-3, rtol=1e-9)


def test_fixture_tilt_stays_within_the_stated_tolerance():
    rng = np.random.default_rng(3)
    faces = cases.six_face_order(rng)
    pieces, segs, _ = cases.fixture_sequence(rng, faces, [(1, 2)] * 6, (1, 2), 0.5)
    holds = [p for p in pieces if isinstance(p, motion.Hold)]
    for hold, seg in zip(holds, segs):
        nominal = motion.euler_rot(seg["roll_deg"], seg["pitch_deg"], seg["yaw_deg"])
        off = np.degrees((nominal.inv() * hold.rot).magnitude())
        assert 0.0 < off <= 0.5 * np.sqrt(2) + 1e-9


def test_drive_specific_force_holds_coriolis_and_the_road_dynamics():
    rng = np.random.default_rng(5)
    t = np.arange(0, 120 * 50 * M + 1) / (50.0 * M)
    mot, _ = motion.road_drive(rng, LAT, LON, H, t)
    f = ideal.specific_force_enu(mot)
    w_ie = earth.earth_rate_enu(mot.lat)
    expected = mot.vdot + np.cross(2 * w_ie, mot.v)
    expected[:, 2] += earth.normal_gravity(mot.lat, mot.h)
    # what is left is the transport-rate term w_en x v, of order v^2 / R
    left = np.linalg.norm(f - expected, axis=1)
    speed2 = np.sum(mot.v**2, axis=1)
    assert np.all(left <= speed2 * (1 + np.tan(np.radians(LAT))) / 6.33e6 + 1e-12)
    assert left.max() > 0.5 * speed2.max() / 6.4e6
    # position integrates velocity: the north displacement matches the meridian arc
    rm, _ = earth.radii(np.radians(LAT))
    north = np.trapezoid(mot.v[:, 1], t)
    assert (mot.lat[-1] - mot.lat[0]) * (rm + H) == pytest.approx(north, rel=1e-4, abs=1e-3)


def test_flicker_noise_has_the_allan_plateau_of_its_bias_instability():
    rng = np.random.default_rng(0)
    b, dt, n = 1e-3, 0.01, 2**17
    x = sensor.flicker_noise(rng, n, dt, np.full(3, b))[:, 0]
    m = 1000  # tau = 10 s, on the plateau
    means = x[: n // m * m].reshape(-1, m).mean(1)
    adev = np.sqrt(0.5 * np.mean(np.diff(means) ** 2))
    assert adev == pytest.approx(0.664 * b, rel=0.3)


@pytest.mark.parametrize("seed", range(4))
def test_no_move_between_static_attitudes_is_near_a_half_turn(seed):
    rng = np.random.default_rng(seed)
    for pieces in (cases.fixture_sequence(rng, cases.six_face_order(rng), [(1, 2)] * 6, (1, 2), 1.0)[0],
                   cases.rate_table_sequence(rng, 1.0)[0]):
        for move in (p for p in pieces if isinstance(p, motion.Move)):
            assert cases.move_angle_deg(move.start, move.stop) <= cases.MAX_MOVE_DEG + 2.0
