"""sensor_health's yaw scale-factor test against the GNSS course: a gz scale step in turns is named, a healthy
drive gives none, a straight drive says not observable (core only, small synthetic drives)."""
import numpy as np

from nav_core.earth import radii
from sensor_health import noise_sim
from sensor_health import thresholds as thr
from sensor_health.monitor import HealthConfig, HealthMonitor
from sensor_health.yaw_scale import YawScaleMonitor
from test_sensor_health_core import RATE, _model, _thresholds

LAT0, LON0 = np.deg2rad(45.0), np.deg2rad(7.0)


def _drive(seed, duration_s=560.0, turns=True, scale_step=0.0, step_s=400.0, gnss_sd_m=0.05, period_s=20.0):
    """10 m/s, 90-degree turns at 0.2 rad/s every period_s (left and right), z up; IMU at RATE, GNSS at 1 Hz with
    white position noise of gnss_sd_m."""
    rng = np.random.default_rng(seed)
    n = int(duration_s * RATE)
    t = np.arange(n) / RATE
    turn_s = (np.pi / 2) / 0.2
    phase = t % period_s
    direction = np.where((t // period_s) % 2 == 0, 1.0, -1.0)
    course_rate = np.where(turns & (phase >= period_s - turn_s), 0.2 * direction, 0.0)  # clockwise from north
    course = np.cumsum(course_rate) / RATE
    x = noise_sim.model_noise(_model(), n, 1 / RATE, rng)
    x[:, 2] += -course_rate * np.where(t >= step_s, 1.0 + scale_step, 1.0)
    x[:, 5] += 9.81
    north, east = np.cumsum(10.0 * np.cos(course)) / RATE, np.cumsum(10.0 * np.sin(course)) / RATE
    k = np.arange(0, n, int(RATE))
    rn, re = radii(LAT0)
    lat = LAT0 + (north[k] + rng.normal(0, gnss_sd_m, len(k))) / rn
    lon = LON0 + (east[k] + rng.normal(0, gnss_sd_m, len(k))) / (re * np.cos(LAT0))
    return t, x, (t[k], lat, lon)


def _run(t, x, gnss):
    mon = HealthMonitor(_model(), HealthConfig(mc_windows=4000), thresholds=_thresholds())
    events = mon.push_gnss(*gnss)
    for a in range(0, len(t), 64 * 60):
        events += mon.push(t[a:a + 64 * 60], x[a:a + 64 * 60, :3], x[a:a + 64 * 60, 3:])
    return mon, events


def test_a_two_percent_yaw_scale_step_in_turns_is_named_on_gz_near_its_onset():
    t, x, gnss = _drive(1, scale_step=0.02, period_s=15.0)
    mon, events = _run(t, x, gnss)
    assert events, mon.observability()
    e = events[0]
    assert (e.effect, e.channels) == ("scale_factor_change", ["gz"])
    assert 400.0 < e.t_s < 400.0 + 150.0
    assert abs(e.onset_s - 400.0) <= 20.0
    lo, hi = e.interval_95
    assert lo <= 0.02 <= hi and 0.01 < e.estimate < 0.03


def _scale_only(t, x, gnss):
    """The scale test alone (the rest of the monitor is covered by test_sensor_health_core)."""
    mon = YawScaleMonitor(_model(), 0.3 / thr.N_TESTS)
    return mon, mon.push_gnss(*gnss) + mon.push_imu(t, x[:, 2])


def test_healthy_drives_with_turns_give_no_scale_event_and_are_observable():
    for seed in (2, 3, 4):
        t, x, gnss = _drive(seed, duration_s=900.0)
        mon, events = _scale_only(t, x, gnss)
        assert events == []
        assert mon.observability().startswith("observable")


def test_a_straight_drive_says_not_observable_and_names_nothing():
    t, x, gnss = _drive(5, duration_s=400.0, turns=False, scale_step=0.05, step_s=200.0)
    mon, events = _scale_only(t, x, gnss)
    assert events == []
    assert mon.observability().startswith("not observable on this record")


def test_without_gnss_the_scale_factor_is_not_observable():
    t, x, _ = _drive(6, duration_s=100.0)
    mon, events = _run(t, x, (np.zeros(0), np.zeros(0), np.zeros(0)))
    assert events == []
    assert mon.observability()["scale_factor_change gz"] == "not observable on this record: no GNSS fixes"


def test_a_scenario_fault_multiplies_the_channel_from_its_start():
    from imu_sim import faults
    (f,) = faults.parse([{"effect": "scale_factor_change", "channel": "gz", "start_s": 1.0, "change": 0.02}], "s.yaml")
    t = np.arange(4) * 0.5
    out = faults.apply([f], t, np.ones((4, 6)), np.random.default_rng(0))
    assert out[:, 2].tolist() == [1.0, 1.0, 1.02, 1.02] and (out[:, [0, 1, 3, 4, 5]] == 1).all()
