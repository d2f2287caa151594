"""Built-in sensor models for simulations: a BP3010-grade unit (ADXRS300 gyros, ADXL210E accelerometers).

Values are datasheet-level guesses for this class of sensor plus the paper's
calibration results (accel z bias 0.1330 m/s^2, scale 0.0041; gyro z bias
0.3172 deg/s, scale -0.0070); they are NOT the paper's Table 1, which imu_calib fits.
"""
import numpy as np

from imu_driver.bp3010_codec import ACCEL_WHITE_NOISE, GYRO_WHITE_NOISE, FrameFormat
from nav_core.sensor_model import SensorModel, TriadModel
from nav_core.units import DEG

BP3010_DTHETA_LSB_RAD = FrameFormat.dtheta_lsb_rad
BP3010_DV_LSB_MPS = FrameFormat.dv_lsb_mps


def bp3010_grade_model(physics: dict | None = None) -> SensorModel:
    """A BP3010-grade :class:`SensorModel` (SI); ``physics`` as in the YAML (None = naive)."""
    gyro = TriadModel(
        bias=np.array([0.05, -0.08, 0.3172]) * DEG, scale_factor=np.array([0.002, -0.003, -0.0070]),
        misalignment=np.array([[0, 1e-3, -5e-4], [-8e-4, 0, 6e-4], [4e-4, -7e-4, 0]]),
        quantization=np.full(3, BP3010_DTHETA_LSB_RAD / np.sqrt(12)), white_noise=np.full(3, GYRO_WHITE_NOISE),
        bias_instability=np.full(3, 1.7e-4), rate_random_walk=np.full(3, 1e-5), rate_ramp=np.full(3, 1e-7))
    accel = TriadModel(
        bias=np.array([0.03, -0.05, 0.1330]), scale_factor=np.array([0.001, -0.002, 0.0041]),
        misalignment=np.array([[0, 6e-4, -3e-4], [-5e-4, 0, 4e-4], [2e-4, -6e-4, 0]]),
        quantization=np.full(3, BP3010_DV_LSB_MPS / np.sqrt(12)), white_noise=np.full(3, ACCEL_WHITE_NOISE),
        bias_instability=np.full(3, 1e-3), rate_random_walk=np.full(3, 1e-4), rate_ramp=np.full(3, 1e-6))
    return SensorModel(gyro=gyro, accel=accel, sample_rate_hz=64.0,
                       provenance={"tool": "imu_sim.models.bp3010_grade_model", "source": "datasheet-level guess"},
                       physics=physics)
