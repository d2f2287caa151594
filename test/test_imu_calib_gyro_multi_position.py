"""imu_calib.gyro_multi_position: gyro scale factors and misalignment from the moves between static positions."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import shared_data
from imu_calib.gyro_multi_position import fit_gyro
from imu_calib.multi_position import apply_to_model, multi_position
from nav_core import sensor_model
from nav_core.datasets import load_imutk
from nav_core.earth import normal_gravity
from nav_core.recording import ImuRecording
from nav_core.units import DEG

RATE_HZ = 100.0
LAT = 45.0 * DEG
GYRO_SCALE = np.array([0.012, -0.018, 0.007])
GYRO_MIS = np.array([[0.0, 0.011, -0.006], [0.004, 0.0, 0.009], [-0.013, 0.005, 0.0]])
GYRO_BIAS = np.array([2e-3, -1.5e-3, 1e-3])


def _recording(seed, gyro_scale=GYRO_SCALE, gyro_mis=GYRO_MIS, n_pos=30, static_s=4.0, move_s=2.0,
               gyro_noise=2e-3):
    """Static poses joined by moves about random body axes (smooth 1 - cos rate); both triads through their models."""
    rng = np.random.default_rng(seed)
    g = normal_gravity(LAT)
    pose = Rotation.random(random_state=rng.integers(1 << 31))  # body -> world
    n_move = int(move_s * RATE_HZ)
    edges = np.linspace(0.0, 1.0, n_move + 1)
    # mean rate over each sample of phi'(t) = angle/T (1 - cos 2 pi t/T): differences of its integral
    shape = np.diff(edges - np.sin(2 * np.pi * edges) / (2 * np.pi)) * RATE_HZ
    accel, gyro = [], []
    for i in range(n_pos):
        f_body = pose.inv().apply([0.0, 0.0, g])
        n_static = int((30.0 if i == 0 else static_s) * RATE_HZ)
        accel.append(np.tile(f_body, (n_static, 1)))
        gyro.append(np.zeros((n_static, 3)))
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(60.0, 150.0) * DEG
        rates = np.outer(shape * angle, axis)  # body rad/s, sample means
        steps = Rotation.from_rotvec(np.cumsum(rates, axis=0) / RATE_HZ)
        accel.append((pose * steps).inv().apply([0.0, 0.0, g]) + 3.0 * rng.standard_normal((n_move, 3)))
        gyro.append(rates)
        pose = pose * steps[-1]
    accel, gyro = np.concatenate(accel), np.concatenate(gyro)
    n = len(accel)
    G = np.eye(3) + np.diag(gyro_scale) + gyro_mis
    gyro_meas = gyro @ G.T + GYRO_BIAS + gyro_noise * rng.standard_normal((n, 3))
    accel_meas = accel + 1e-2 * rng.standard_normal((n, 3))
    return ImuRecording(np.arange(n) / RATE_HZ, gyro_meas, accel_meas, source="synthetic multi-position"), n_pos


def test_gyro_scale_and_misalignment_are_recovered_from_the_moves():
    rec, n_pos = _recording(1)
    res = multi_position(rec, gravity=normal_gravity(LAT))
    assert len(res.segments) == n_pos and res.gyro.n_moves == n_pos - 1
    np.testing.assert_allclose(res.gyro.scale_factor, GYRO_SCALE, atol=1e-3)
    np.testing.assert_allclose(res.gyro.misalignment, GYRO_MIS, atol=1e-3)
    assert np.sqrt(np.mean(res.gyro.residuals ** 2)) < 0.1 * np.sqrt(np.mean(res.gyro.residuals_before ** 2))


@pytest.mark.slow
def test_gyro_intervals_cover_the_truth_in_most_seeds():
    inside, total = 0, 0
    for seed in range(10, 20):
        gyro = multi_position(_recording(seed)[0], gravity=normal_gravity(LAT)).gyro
        lo, hi = gyro.intervals["scale_factor"][:, 0], gyro.intervals["scale_factor"][:, 1]
        inside += np.sum((lo <= GYRO_SCALE) & (GYRO_SCALE <= hi))
        mlo, mhi = gyro.intervals["misalignment"][..., 0], gyro.intervals["misalignment"][..., 1]
        off = ~np.eye(3, dtype=bool)
        inside += np.sum((mlo <= GYRO_MIS) & (GYRO_MIS <= mhi) & off)
        total += 9
    assert inside / total >= 0.9, inside / total


def test_gyro_raw_counts_are_handled_by_the_common_scale_scan():
    rec, _ = _recording(2, gyro_noise=1e-3)
    counts_per_rps = 6258.0  # imu_tk's Xsens gyro: about 6258 counts per rad/s
    rec = ImuRecording(rec.t, rec.gyro * counts_per_rps, rec.accel, source=rec.source)
    gyro = multi_position(rec, gravity=normal_gravity(LAT)).gyro
    np.testing.assert_allclose(gyro.matrix(), counts_per_rps * (np.eye(3) + np.diag(GYRO_SCALE) + GYRO_MIS),
                               rtol=0, atol=counts_per_rps * 1e-3)


def test_gyro_calibration_goes_into_the_sensor_model_yaml(tmp_path):
    res = multi_position(_recording(3)[0], gravity=normal_gravity(LAT))
    back = sensor_model.load(sensor_model.save(apply_to_model(sensor_model.SensorModel(), res), tmp_path / "m.yaml"))
    np.testing.assert_allclose(back.gyro.scale_factor, res.gyro.scale_factor)
    np.testing.assert_allclose(back.gyro.misalignment, res.gyro.misalignment)
    assert back.gyro.intervals["misalignment"].shape == (3, 3, 2)


def test_gyro_calibration_needs_enough_moves():
    with pytest.raises(ValueError, match="moves"):
        fit_gyro([], RATE_HZ)


def test_imutk_xsens_gyro_stage_explains_the_gravity_direction_after_every_move():
    rec = load_imutk(shared_data("imutk_multiposition", "xsens_acc.mat"),
                     shared_data("imutk_multiposition", "xsens_gyro.mat"))
    gyro = multi_position(rec, gravity=9.81).gyro  # raw counts
    rms_after = np.sqrt(np.mean(gyro.residuals ** 2))
    assert rms_after < 0.5 * np.sqrt(np.mean(gyro.residuals_before ** 2))
    assert rms_after < 2.0 * DEG
    assert np.all(np.isfinite(gyro.matrix()))
