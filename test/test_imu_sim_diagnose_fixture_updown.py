"""An up/down on a hand-turned fixture: no line from the ramp between two tilted holds, a known constant fitted before
the effect that mimics it."""
import functools

import numpy as np

from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import collinear, engine, noise_candidates
from imu_sim.diagnose.candidate import evidence
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
NORTH = tuple((r, p, 90.0) for r, p, _ in ROLL)
"""The same turned about north."""
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



def test_a_g_sensitivity_reproduces_the_earth_rate_of_an_up_down_turned_about_north():
    """Turned about the north axis, only the Earth rate's vertical part flips, along gravity: a g-sensitivity on the
    axes that see gravity reproduces all of it; z turned about east, the north part flips too, on y, which sees no
    gravity: the g-sensitivity reproduces the vertical part's share, sin^2(lat)."""
    north = _case(NORTH, NORTH, 14.0, False, False)
    by = {c.effect: c for c in engine.evaluate(*_args(north), factors={})}
    assert collinear.mimicked_fraction(north, by["earth_rotation"], by["gyro_g_sensitivity"]) > 0.99
    turned = ((0.0, 0.0, 0.0), (180.0, 0.0, 0.0))  # z up, then down, turned about x (east): the north part on y
    east = _case(turned, turned, 14.0, False, False)
    by = {c.effect: c for c in engine.evaluate(*_args(east), factors={})}
    share = collinear.mimicked_fraction(east, by["earth_rotation"], by["gyro_g_sensitivity"])
    assert abs(share - np.sin(np.radians(14.0)) ** 2) < 0.02, share


def _args(case):
    return case, case.model, residual(case, case.model)


def _ranked(case, earth_rank: float, gs_rank: float) -> dict:
    """The record's Earth rate and g-sensitivity candidates, significant, with the given ranking keys."""
    by = {c.effect: c for c in engine.evaluate(*_args(case), factors={})
          if c.effect in ("earth_rotation", "gyro_g_sensitivity")}
    for c, rank in ((by["earth_rotation"], earth_rank), (by["gyro_g_sensitivity"], gs_rank)):
        c.stat, c.threshold, c.identifiable, c.rank = rank + 10.0, 10.0, True, rank
    gs = by["gyro_g_sensitivity"]  # a value of its own, not the Earth rate's vertical part
    gs.intervals = {m: [5e-6, 6e-6] for m in gs.params}
    return by


def test_the_earth_rate_is_fitted_before_a_g_sensitivity_that_mimics_it():
    """Blind seed 9's navigation up/down: the Earth rate significant (its evidence 2.7e4) and a g-sensitivity equal on
    y and z (6.8e4) named first. Where the g-sensitivity reproduces the constant's pattern, the constant (zero free
    parameters) goes first and the g-sensitivity is tested given it; where it reproduces only the vertical part's
    share (z turned about east at 14 deg: 6 %), both keep their own evidence."""
    by = _ranked(_case(NORTH, NORTH, 14.0, False, False), 2.7e4, 6.8e4)
    collinear.constant_before_mimic(_case(NORTH, NORTH, 14.0, False, False), by)
    assert evidence(by["earth_rotation"]) == 2.7e4
    assert evidence(by["gyro_g_sensitivity"]) < 2.7e4 and "fitted first" in by["gyro_g_sensitivity"].reason
    east = _case(((0.0, 0.0, 0.0), (180.0, 0.0, 0.0)), ((0.0, 0.0, 0.0), (180.0, 0.0, 0.0)), 14.0, False, False)
    by = _ranked(east, 2.7e4, 6.8e4)
    collinear.constant_before_mimic(east, by)
    assert evidence(by["gyro_g_sensitivity"]) == 6.8e4


def test_a_g_sensitivity_that_is_the_left_out_earth_rates_vertical_part_is_not_sensor_physics():
    """The up/down turned about north at latitude 14 deg, its heading stated 20 deg off: the g-sensitivity's y and z
    coefficients are Omega sin(lat) / g (1.8e-6 rad/s per m/s^2), what the left-out Earth rate makes on a still hold.
    With the Earth rate in the user's model, the same record has no such g-sensitivity to rank."""
    stated = tuple((r, p, y + 20.0) for r, p, y in NORTH)
    by = {c.effect: c for c in engine.evaluate(*_args(_case(NORTH, stated, 14.0, False, False)), factors={})}
    gs = by["gyro_g_sensitivity"]
    assert not gs.significant and "vertical part" in gs.reason, (gs.stat, gs.params, gs.reason)
    k0 = 7.292115e-5 * np.sin(np.radians(14.0)) / 9.78
    assert all(abs(v / k0 - 1.0) < 0.2 for v in gs.params.values()), gs.params
