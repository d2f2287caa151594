"""sensor_health's ay bias test on the straights at speed: a step is named with its onset, a healthy drive and a gz
step give none, a record without fixes says not observable (core only, a small synthetic drive)."""
import numpy as np

from sensor_health.lateral_track import LateralTrackMonitor, z_gate
from test_sensor_health_scale import _drive

BUDGET = 0.1


def _run(t, x, gnss):
    mon = LateralTrackMonitor(2e-3, 1.5e-3, 2e-3, BUDGET)
    events = mon.push_gnss(*gnss) if gnss else []
    for a in range(0, len(t), 64 * 30):
        events += mon.push_imu(t[a:a + 64 * 30], x[a:a + 64 * 30, 2], x[a:a + 64 * 30, 4])
    return mon, events


def test_an_ay_bias_step_on_a_straight_is_named_and_a_gz_step_is_not_one():
    t, x, gnss = _drive(31, duration_s=300.0)  # 10 m/s, 90-degree turns every 20 s, 12-s straights
    mon, events = _run(t, x, gnss)
    assert events == [] and mon.observability().startswith("observable")
    gz = x.copy()
    gz[t >= 245.0, 2] += 4e-3  # a gz knock: ay - v gz would move by 0.04 m/s^2; ay itself does not
    assert _run(t, gz, gnss)[1] == []
    x[t >= 245.0, 4] += 0.02  # 10 x the bias sd, in mid-straight
    _, events = _run(t, x, gnss)
    assert [(e.effect, e.channels) for e in events] == [("bias_shift", ["ay"])]
    assert 0 < events[0].t_s - 245.0 <= 5.0 and abs(events[0].onset_s - 245.0) <= 1.0
    lo, hi = events[0].interval_95
    assert lo <= 0.02 <= hi


def test_without_fixes_the_ay_bias_is_not_observable():
    t, x, _ = _drive(32, duration_s=60.0)
    x[t >= 30.0, 4] += 0.05
    mon, events = _run(t, x, None)
    assert events == [] and "no GNSS fixes" in mon.observability()


def test_the_ay_gate_sits_above_a_single_gaussian_test():
    from scipy import stats
    single = stats.norm.isf(BUDGET / 36000.0 / 2)  # one test per straight second, 10 h
    assert single - 0.5 < z_gate(BUDGET) < single + 1.5


def test_nan_samples_and_a_nan_fix_are_skipped_and_a_later_step_is_still_named():
    t, x, (tf, lat, lon) = _drive(31, duration_s=300.0)
    x[(t >= 100.0) & (t < 102.0), 4] = np.nan  # two seconds of a NaN ay: those blocks are left out, nothing else
    lat = lat.copy()
    lat[50] = np.nan  # one NaN fix: skipped, its neighbours' chords still give the speed
    mon, events = _run(t, x, (tf, lat, lon))
    assert events == [] and mon.observability().startswith("observable")
    x[t >= 245.0, 4] += 0.02
    _, events = _run(t, x, (tf, lat, lon))
    assert [(e.effect, e.channels) for e in events] == [("bias_shift", ["ay"])]
    assert 0 < events[0].t_s - 245.0 <= 5.0
