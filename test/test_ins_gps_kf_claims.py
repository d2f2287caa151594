"""The claim experiments' building blocks: WMRA input via wmra_filter, Allan-derived noise model via imu_calib."""


import numpy as np

from nav_core.recording import ImuRecording
from nav_core.units import DEG
from ins_gps_kf import error_model as em
from nav_eval import claims as evaluate


def _static(seed, rate=64.0, seconds=60.0, gyro_white=0.05 * DEG, accel_white=3e-3):
    rng = np.random.default_rng(seed)
    n = int(rate * seconds)
    t = np.arange(n) / rate
    gyro = rng.normal(0, gyro_white * np.sqrt(rate), (n, 3)) + [1e-3, -2e-3, 5e-4]
    accel = rng.normal(0, accel_white * np.sqrt(rate), (n, 3)) + [0.0, 0.0, 9.81]
    return ImuRecording(t, gyro, accel, source="synthetic static")


def test_wmra_input_removes_white_noise_and_keeps_the_mean():
    imu = _static(1)
    model = em.default_mems_model()
    model.gyro.white_noise[:] = 0.05 * DEG
    model.accel.white_noise[:] = 3e-3
    model.gyro.bias[:] = 0.5  # deterministic terms must not be applied: the filter sees the same calibration
    out = evaluate.wmra_denoised(imu, model, "road_vehicle")
    assert np.all(out.gyro.std(axis=0) < 0.8 * imu.gyro.std(axis=0))
    np.testing.assert_allclose(out.gyro.mean(axis=0), imu.gyro.mean(axis=0), atol=2e-4)
    np.testing.assert_allclose(out.accel.mean(axis=0), imu.accel.mean(axis=0), atol=2e-3)


def test_completed_allan_model_has_every_term_the_filter_needs():
    imu = _static(2, seconds=45.0)
    raw = evaluate.allan_model(imu, 44.0)
    done = evaluate.allan_model(imu, 44.0, completed=True)
    for name in ("gyro", "accel"):
        tri = done.triad(name)
        assert np.all(tri.white_noise > 0) and np.all(tri.bias_instability > 0)
        # terms the fit resolved are kept as fitted
        fitted = raw.triad(name).white_noise > 0
        np.testing.assert_array_equal(tri.white_noise[fitted], raw.triad(name).white_noise[fitted])
    # 45 s of white noise: the white level is found within 20 %
    np.testing.assert_allclose(done.gyro.white_noise, 0.05 * DEG, rtol=0.2)
