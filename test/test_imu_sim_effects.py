"""imu_sim physical effects (the diagnosis vocabulary) and GPS errors, each switched on alone."""
import numpy as np
import pytest

from nav_core import earth
from nav_core.sensor_model import SensorModel
from nav_core.units import DEG, G0

from imu_sim import scenario as scenario_mod
from imu_sim.effects import EffectError
from imu_sim.simulate import simulate


def _static(duration_s=60.0, yaw_deg=0.0, **extra):
    return scenario_mod.from_dict({"latitude_deg": 45.0, "longitude_deg": 10.0, "height_m": 0.0,
                                   "static_segments": [{"t0": 0, "t1": duration_s, "roll_deg": 0, "pitch_deg": 0,
                                                        "yaw_deg": yaw_deg}], **extra})


def _run(physics, scen=None, **kw):
    return simulate(scen or _static(), SensorModel(physics=physics), seed=1, with_bytes=False, **kw)


def test_no_physics_section_is_the_naive_simulator():
    res = _run(None)
    np.testing.assert_allclose(res.imu.accel, [[0, 0, G0]] * len(res.imu), atol=1e-12)
    np.testing.assert_allclose(res.imu.gyro, 0.0, atol=1e-18)


def test_earth_rotation_and_gravity_model_switch_on_separately():
    lat = 45 * DEG
    rot = _run({"earth_rotation": {}})
    grav = _run({"gravity_model": {}})
    assert rot.imu.gyro[:, 1].mean() == pytest.approx(earth.RATE * np.cos(lat), rel=1e-9)
    assert rot.imu.accel[:, 2].mean() == pytest.approx(G0, abs=1e-12)
    assert grav.imu.accel[:, 2].mean() == pytest.approx(earth.normal_gravity(lat, 0.0), abs=1e-12)
    np.testing.assert_allclose(grav.imu.gyro, 0.0, atol=1e-18)


def test_coriolis_pushes_a_northbound_car_sideways_by_2_omega_v():
    scen = scenario_mod.from_dict({"latitude_deg": 45.0, "longitude_deg": 0.0, "yaw0_deg": 90.0, "segments": [
        {"type": "accelerate", "duration_s": 10, "speed_mps": 20}, {"type": "cruise", "duration_s": 10}],
        "gps": False})
    on, off = _run({"coriolis": {}}, scen), _run({}, scen)
    cruise = on.imu.t > 12
    lateral = (on.imu.accel - off.imu.accel)[cruise, 1].mean()
    # Northern hemisphere: the Earth pushes a northbound car east (to its right, -y); the road pushes back left.
    assert lateral == pytest.approx(2 * earth.RATE * np.sin(45 * DEG) * 20.0, rel=0.02)


def test_temperature_bias_is_linear_in_temperature_and_written_with_the_recording():
    params = {"gyro_coeff_rad_per_s_per_degc": [1e-5, 2e-5, 3e-5], "accel_coeff_mps2_per_degc": [0, 0, 1e-3],
              "reference_temp_c": 25.0}
    scen = _static(temperature={"start_c": 15.0, "end_c": 45.0, "time_constant_s": 20.0})
    res = _run({"temperature_bias": params}, scen)
    d_temp = res.imu.temp_c - 25.0
    np.testing.assert_allclose(res.imu.gyro, np.outer(d_temp, [1e-5, 2e-5, 3e-5]), atol=1e-15)
    np.testing.assert_allclose(res.imu.accel[:, 2] - G0, 1e-3 * d_temp, atol=1e-12)


def test_temperature_bias_without_a_temperature_profile_is_a_clear_error():
    with pytest.raises(EffectError, match="temperature_bias"):
        _run({"temperature_bias": {"gyro_coeff_rad_per_s_per_degc": 1e-5}})


def test_gyro_g_sensitivity_adds_g_times_specific_force():
    res = _run({"gyro_g_sensitivity": {"gyro_coeff_rad_per_s_per_mps2": [1e-4, 2e-4, 3e-4]}})
    np.testing.assert_allclose(res.imu.gyro[:, 2], 3e-4 * G0, rtol=1e-12)


def test_warmup_drift_decays_with_its_time_constant():
    res = _run({"warmup_drift": {"gyro_amplitude_rad_per_s": [0, 0, 1e-3], "time_constant_s": 10.0}})
    t = res.imu.t
    np.testing.assert_allclose(res.imu.gyro[:, 2], 1e-3 * np.exp(-(t - t[0]) / 10.0), rtol=1e-12)


def test_sinusoidal_vibration_aliases_with_the_interval_mean_amplitude():
    res = _run({"vibration": {"sinusoids": [{"frequency_hz": 60.0, "accel_amplitude_mps2": [0, 0, 1.0]}]}})
    z = res.imu.accel[:, 2] - G0
    spectrum = np.abs(np.fft.rfft(z)) * 2 / len(z)
    freqs = np.fft.rfftfreq(len(z), 1 / 64)
    assert freqs[np.argmax(spectrum)] == pytest.approx(4.0, abs=0.05)  # 60 Hz seen at 64 - 60 Hz
    assert spectrum.max() == pytest.approx(abs(np.sinc(60 / 64)), rel=0.02)


def test_coning_gives_the_rectified_rate_and_sculling_the_rectified_force():
    amp, freq, acc = 1e-3, 20.0, 0.5
    res = _run({"coning_sculling": {"coning_amplitude_rad": amp, "frequency_hz": freq, "sculling_accel_mps2": acc}})
    assert res.imu.gyro[:, 2].mean() == pytest.approx(0.5 * amp**2 * 2 * np.pi * freq, rel=1e-9)
    assert res.imu.accel[:, 2].mean() - G0 == pytest.approx(-amp * acc, rel=1e-6)


def test_model_override_effects_set_scale_factor_and_quantization():
    res = _run({"scale_factor": {"accel": [0, 0, 0.01]}, "quantization": {"accel_lsb_mps": 5e-5}})
    inc = res.imu.accel[:, 2] / 64
    assert np.allclose(np.round(inc / 5e-5), inc / 5e-5, atol=1e-6)
    assert np.sum(inc) / 60.0 == pytest.approx(1.01 * G0, abs=1e-5)


def test_unknown_effect_parameter_is_named():
    with pytest.raises(EffectError, match=r"physics.warmup_drift: unknown parameter\(s\) \['tau'\]"):
        _run({"warmup_drift": {"tau": 3}})


# ----------------------------------------------------------------------------- GPS


def _gps_run(physics, yaw_deg=0.0, **gps):
    scen = _static(120.0, yaw_deg, gps={"rate_hz": 1, "sigma_m": gps.pop("sigma_m", 0.0), **gps},
                   gps_lever_arm_m=[1.0, 0.5, 1.5])
    res = _run(physics, scen)
    enu = _frame(scen).to_enu(res.gnss.lat / DEG, res.gnss.lon / DEG, res.gnss.h)
    return res, enu


def _frame(scen):
    return earth.LocalFrame(scen.latitude_deg, scen.longitude_deg, scen.height_m)


def test_gps_lever_arm_comes_from_the_scenario_when_the_physics_lists_it():
    _, enu = _gps_run({"gps_lever_arm": {}}, yaw_deg=90.0)
    np.testing.assert_allclose(enu, [[-0.5, 1.0, 1.5]] * len(enu), atol=1e-6)  # body x north, y west
    _, enu_naive = _gps_run({})
    np.testing.assert_allclose(enu_naive, 0.0, atol=1e-6)


def test_gps_white_and_coloured_noise_have_their_sigma_and_correlation():
    res, enu = _gps_run({"colored_gps_noise": {"sigma_m": [2.0, 2.0, 0.0], "correlation_time_s": 30.0}},
                        sigma_m=[0.0, 0.0, 0.5])
    lag1 = np.corrcoef(enu[:-1, 0], enu[1:, 0])[0, 1]
    assert lag1 > 0.8  # coloured: exp(-1/30) = 0.97 expected
    assert abs(np.corrcoef(enu[:-1, 2], enu[1:, 2])[0, 1]) < 0.3  # white
    assert np.std(enu[:, 2]) == pytest.approx(0.5, rel=0.25)
    np.testing.assert_allclose(res.gnss.std_enu[0], [2.0, 2.0, 0.5])


def test_gps_latency_reports_the_position_of_an_earlier_time():
    scen = scenario_mod.from_dict({"latitude_deg": 10.0, "longitude_deg": 0.0, "segments": [
        {"type": "accelerate", "duration_s": 5, "speed_mps": 10}, {"type": "cruise", "duration_s": 20}],
        "gps": {"sigma_m": 0.0}})
    late, ontime = _run({"gps_latency": {"latency_s": 0.2}}, scen), _run({}, scen)
    frame = _frame(scen)
    e_late = frame.to_enu(late.gnss.lat / DEG, late.gnss.lon / DEG, late.gnss.h)[:, 0]
    e_now = frame.to_enu(ontime.gnss.lat / DEG, ontime.gnss.lon / DEG, ontime.gnss.h)[:, 0]
    assert (e_now - e_late)[late.gnss.t > 10].mean() == pytest.approx(2.0, abs=1e-3)


def test_gps_outage_fixes_are_no_fix_or_dropped():
    res, _ = _gps_run({}, outages=[[10, 20]])
    inside = (res.gnss.t >= 10) & (res.gnss.t < 20)
    assert np.all(res.gnss.status[inside] == -1) and np.all(np.isnan(res.gnss.lat[inside]))
    dropped, _ = _gps_run({}, outages=[[10, 20]], outage_mode="drop")
    assert len(dropped.gnss) == len(res.gnss) - 10
