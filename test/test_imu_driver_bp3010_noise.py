"""The BP3010's white noise has one home (imu_driver.bp3010_codec): the driver's default stddevs, the simulator's
BP3010-grade model and the shipped sensor model config/sensor_models/bp3010.yaml all carry it."""
import math
from pathlib import Path

import numpy as np

from imu_driver import bp3010_driver_node as driver
from imu_driver.bp3010_codec import ACCEL_WHITE_NOISE, GYRO_WHITE_NOISE
from imu_sim.models import bp3010_grade_model
from nav_core import sensor_model

MODEL = Path(__file__).resolve().parents[1] / "config" / "sensor_models" / "bp3010.yaml"


def test_driver_simulator_and_shipped_model_carry_the_one_white_noise():
    shipped = sensor_model.load(MODEL)
    grade = bp3010_grade_model()
    for model in (shipped, grade):
        np.testing.assert_array_equal(model.gyro.white_noise, GYRO_WHITE_NOISE)
        np.testing.assert_array_equal(model.accel.white_noise, ACCEL_WHITE_NOISE)
    params = {p.name: p.default for p in driver.PARAMS}
    assert params["angular_velocity_stddev"] == GYRO_WHITE_NOISE * math.sqrt(64.0)
    assert params["linear_acceleration_stddev"] == ACCEL_WHITE_NOISE * math.sqrt(64.0)
