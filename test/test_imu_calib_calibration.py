"""imu_calib deterministic calibration: two-position (eqs. 1-4), rate table (eqs. 5-7), multi-position LSQ."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import shared_data
from imu_calib import synthetic
from nav_core.datasets import load_imutk, load_ucalgary_updown
from imu_calib.multi_position import detect_static, multi_position
from imu_calib.rate_table import earth_rate_along, rate_table
from imu_calib.two_position import apply_to_model, two_position, two_position_from_recordings
from nav_core import sensor_model
from nav_core.earth import RATE, normal_gravity
from nav_core.recording import ImuRecording
from nav_core.units import DEG

LAT = 21.0 * DEG
RATE_HZ = 64.0


def _white(n, n_coef, seed):
    return synthetic.noise(n, RATE_HZ, synthetic.NoiseTerms(N=n_coef), np.random.default_rng(seed))


def test_two_position_recovers_the_papers_accel_z_bias_and_scale():
    bias, scale, n = 0.1330, 0.0041, int(600 * RATE_HZ)
    g = normal_gravity(LAT, 15.0)
    up = bias + (1 + scale) * g + _white(n, 1.2e-3, 1)
    down = bias - (1 + scale) * g + _white(n, 1.2e-3, 2)
    res = two_position(up, down, LAT, 15.0, axis=2)
    assert res.bias == pytest.approx(bias, abs=2e-4)
    assert res.scale_factor == pytest.approx(scale, abs=2e-5)
    assert res.bias_interval[0] <= bias <= res.bias_interval[1]
    assert res.gravity == pytest.approx(9.7866, abs=1e-3)  # WGS-84 at 21 deg, not 9.80665


def test_two_position_uses_local_gravity_not_standard_gravity():
    g_pole, g_equator = normal_gravity(90 * DEG), normal_gravity(0.0)
    up, down = np.full(10, g_pole), np.full(10, -g_pole)
    assert two_position(up, down, 90 * DEG).scale_factor == pytest.approx(0.0, abs=1e-12)
    assert two_position(up, down, 0.0).scale_factor == pytest.approx(g_pole / g_equator - 1, rel=1e-9)


def test_two_position_rejects_swapped_recordings():
    with pytest.raises(ValueError, match="swapped"):
        two_position(np.full(10, -9.8), np.full(10, 9.8), LAT)


def test_two_position_gyro_bias_cancels_the_vertical_earth_rate():
    w_v, b = RATE * np.sin(LAT), 1e-3
    res = two_position(np.full(50, 9.8), np.full(50, -9.8), LAT, gyro_up_rps=np.full(50, b + w_v),
                       gyro_down_rps=np.full(50, b - w_v))
    assert res.gyro_bias == pytest.approx(b, abs=1e-12)


def test_rate_table_recovers_the_papers_gyro_z_bias_and_scale_with_earth_rate_from_latitude():
    bias, scale = 0.3172 * DEG, -0.0070
    w_ex = earth_rate_along(LAT, "up")
    assert w_ex == pytest.approx(RATE * np.sin(LAT))
    n = int(600 * RATE_HZ)
    rates = (30 * DEG, -30 * DEG)
    g1, g2 = ((1 + scale) * (w + w_ex) + bias + _white(n, 8.7e-4, i) for i, w in enumerate(rates))
    res = rate_table(g1, rates[0], g2, rates[1], LAT, "up", axis=2)
    assert res.bias / DEG == pytest.approx(0.3172, abs=2e-3)
    assert res.scale_factor == pytest.approx(scale, abs=1e-4)
    assert res.bias_interval[0] <= bias <= res.bias_interval[1]
    assert res.earth_rate_component == pytest.approx(w_ex)


def test_earth_rate_along_axis_depends_on_direction():
    assert earth_rate_along(LAT, "east") == 0.0
    assert earth_rate_along(LAT, "north") == pytest.approx(RATE * np.cos(LAT))
    assert earth_rate_along(LAT, "down") == pytest.approx(-RATE * np.sin(LAT))
    with pytest.raises(ValueError, match="direction"):
        earth_rate_along(LAT, "sideways")


def _multi_position_recording(seed, bias, scale, mis, n_pos=24, static_s=6.0, move_s=2.0):
    """Static orientations (first one 30 s) separated by vigorous moves; accel through the error model."""
    rng = np.random.default_rng(seed)
    g = normal_gravity(LAT)
    rots = Rotation.random(n_pos, random_state=rng.integers(1 << 31))
    A = np.eye(3) + np.diag(scale) + mis
    chunks = []
    for i, rot in enumerate(rots):
        n_static = int((30.0 if i == 0 else static_s) * RATE_HZ)
        chunks.append(np.tile(rot.inv().apply([0.0, 0.0, g]), (n_static, 1)))
        n_move = int(move_s * RATE_HZ)
        chunks.append(rot.inv().apply([0.0, 0.0, g]) + 4.0 * rng.standard_normal((n_move, 3)))
    true = np.concatenate(chunks)
    n = len(true)
    accel = true @ A.T + bias + 1e-3 * np.sqrt(RATE_HZ) * rng.standard_normal((n, 3))
    gyro = np.array([1e-3, -2e-3, 5e-4]) + 1e-3 * rng.standard_normal((n, 3))
    return ImuRecording(np.arange(n) / RATE_HZ, gyro, accel, source="synthetic multi-position"), n_pos


def test_multi_position_recovers_bias_scale_and_misalignment():
    bias, scale = np.array([0.12, -0.08, 0.2]), np.array([0.004, -0.006, 0.002])
    mis = np.zeros((3, 3))
    mis[0, 1], mis[0, 2], mis[1, 2] = 0.01, -0.005, 0.008
    rec, n_pos = _multi_position_recording(4, bias, scale, mis)
    res = multi_position(rec, LAT, with_gyro=False)  # the gyro here is bias + noise only
    assert len(res.segments) == n_pos
    np.testing.assert_allclose(res.bias, bias, atol=2e-3)
    np.testing.assert_allclose(res.scale_factor, scale, atol=3e-4)
    np.testing.assert_allclose(res.misalignment, mis, atol=3e-4)
    lo, hi = res.intervals["bias"][:, 0], res.intervals["bias"][:, 1]
    assert np.mean((lo <= bias) & (bias <= hi)) >= 2 / 3
    assert res.rms_residual < 0.1 * np.sqrt(np.mean(res.residuals_before ** 2))


def test_multi_position_result_goes_into_the_sensor_model_yaml(tmp_path):
    from imu_calib.multi_position import apply_to_model as apply_mp

    mis = np.zeros((3, 3))
    rec, _ = _multi_position_recording(5, np.zeros(3), np.zeros(3), mis)
    model = apply_mp(sensor_model.SensorModel(), multi_position(rec, LAT, with_gyro=False))
    back = sensor_model.load(sensor_model.save(model, tmp_path / "m.yaml"))
    np.testing.assert_allclose(back.accel.misalignment, model.accel.misalignment)
    assert back.accel.intervals["misalignment"].shape == (3, 3, 2)


def test_static_detection_needs_an_initial_static_interval():
    with pytest.raises(ValueError, match="too short"):
        detect_static(np.zeros((10, 3)), 64.0)


def test_ucalgary_adi_two_position_gives_small_bias_and_scale():
    up = load_ucalgary_updown(shared_data("ucalgary_adi_updown", "x_adi_up.txt"))
    down = load_ucalgary_updown(shared_data("ucalgary_adi_updown", "x_adi_down.txt"))
    res = two_position_from_recordings(up, down, "x", 51.0784 * DEG, 1100.0)
    assert abs(res.bias) < 0.05 and abs(res.scale_factor) < 0.01
    assert res.gravity == pytest.approx(9.808, abs=2e-3)
    model = apply_to_model(sensor_model.SensorModel(), res)
    assert model.accel.bias[0] == res.bias and model.accel.intervals["bias"].shape == (3, 2)


def test_imutk_xsens_multi_position_fits_gravity_to_a_milli_g():
    rec = load_imutk(shared_data("imutk_multiposition", "xsens_acc.mat"),
                     shared_data("imutk_multiposition", "xsens_gyro.mat"))
    res = multi_position(rec, gravity=9.81, with_gyro=False)  # raw counts in, m/s^2 magnitude out
    assert len(res.segments) >= 30
    assert res.rms_residual < 0.01
    assert res.rms_residual < 0.05 * np.sqrt(np.mean(res.residuals_before ** 2))
    assert np.all(np.isfinite(res.gyro_bias))
