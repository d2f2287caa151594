"""An up/down on a hand-turned fixture: no line from the ramp between two tilted holds."""
import functools

import numpy as np

from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import engine, noise_candidates
from imu_sim.diagnose.case import make_case, residual
from imu_sim.scenario import from_dict
from imu_sim.simulate import simulate

SPANS = [(0.0, 60.0), (63.0, 123.0)]


def _scenario(poses, lat_deg: float = 51.0784) -> dict:
    """An up/down at 20 Hz: two holds at ``poses`` (roll, pitch, yaw deg), the simulator's turn between them."""
    segs = [{"t0": a, "t1": b, "roll_deg": r, "pitch_deg": p, "yaw_deg": y} for (a, b), (r, p, y) in zip(SPANS, poses)]
    return {"latitude_deg": lat_deg, "longitude_deg": -114.13, "height_m": 1100.0, "static_segments": segs,
            "rate_hz": 20.0, "gps": False}


def _model(physics: dict) -> SensorModel:
    """A navigation-grade unit, white noise only."""
    return SensorModel(gyro=TriadModel(white_noise=np.full(3, 2e-6)), accel=TriadModel(white_noise=np.full(3, 2e-5)),
                       sample_rate_hz=20.0, physics=physics, provenance={"grade": "navigation"})


@functools.lru_cache(maxsize=4)
def _case(truth_poses: tuple, stated_poses: tuple, lat_deg: float, line: bool, earth_in_model: bool):
    """The record of ``truth_poses`` diagnosed against the scenario stating ``stated_poses``; ``line``: the unit
    vibrates at 3 Hz (1e-3 m/s^2 on accel z)."""
    sensor = _model({"earth_rotation": {}, "gravity_model": {}})
    if line:
        sensor.physics["vibration"] = {"sinusoids": [{"frequency_hz": 3.0, "phase_rad": 0.0,
                                                      "gyro_amplitude_rad_per_s": [0.0, 0.0, 0.0],
                                                      "accel_amplitude_mps2": [0.0, 0.0, 1e-3]}]}
    res = simulate(from_dict(_scenario(truth_poses, lat_deg), where="truth"), sensor, seed=7, with_bytes=False)
    rec = ImuRecording(res.imu.t, res.imu.gyro, res.imu.accel, res.imu.temp_c, source="test")
    user = _model({"earth_rotation": {}, "gravity_model": {}} if earth_in_model else {"gravity_model": {}})
    return make_case(rec, from_dict(_scenario(stated_poses, lat_deg), where="stated"), user)


ROLL = ((45.0, 0.0, 0.0), (-135.0, 0.0, 0.0))
"""The y-z diagonal up, then down: turned about body x, east at yaw 0 (ENU)."""
TILTED = ((46.0, 0.8, 0.3), (-136.0, -0.9, -0.6))


def _line(case):
    return next(c for c in engine.evaluate(case, case.model, residual(case, case.model), factors={})
                if c.effect == "vibration")


def test_the_fill_between_two_tilted_holds_is_no_vibration_line(monkeypatch):
    """Each hold's tilt puts its own level on the level accelerometers (0.17 m/s^2 apart here); the unstated move's fill
    ramps from one to the other in 3 s, whose 1/f^2 power at the line search's lower edge (1 Hz) was a line."""
    case = _case(TILTED, ROLL, 51.0784, False, True)
    assert not _line(case).significant, _line(case).stat
    monkeypatch.setattr(noise_candidates, "line_residual", lambda case, resid: resid)
    ramp = _line(case)
    assert ramp.significant and ramp.params["frequency_hz"] < 1.1, (ramp.stat, ramp.params)


def test_a_real_line_on_the_tilted_up_down_is_still_found():
    line = _line(_case(TILTED, ROLL, 51.0784, True, True))
    assert line.significant and abs(line.params["frequency_hz"] - 3.0) < 0.01, (line.stat, line.params)
    assert abs(line.params["accel_amplitude_mps2[z]"]) > 5e-4
