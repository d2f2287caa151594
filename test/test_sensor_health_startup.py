"""Faults present from the first sample are named against the sensor model (no healthy stretch to compare with):
noise x3, a vibration line, a turn-on bias far outside the model's stated repeatability at an unaccelerated start;
healthy starts give none, and a start that accelerates says the turn-on bias was not observable."""
import numpy as np
import pytest

from sensor_health import noise_sim
from sensor_health.events import CHANNELS
from sensor_health.monitor import HealthConfig, HealthMonitor
from sensor_health.startup import REPEATABILITY_KEY
from test_sensor_health_core import RATE, _drive, _model, _thresholds

GYRO_REP, ACCEL_REP = 1e-3, 1e-2
"""Stated turn-on repeatability (1 sd): rad/s, m/s^2."""


def _stated():
    model = _model()
    model.gyro.info[REPEATABILITY_KEY] = GYRO_REP
    model.accel.info[REPEATABILITY_KEY] = [ACCEL_REP] * 3
    return model


def _standing(seed, duration_s=20.0):
    """A unit standing level: the model's noise, a turn-on bias within the stated repeatability, gravity on az."""
    rng = np.random.default_rng(seed)
    n = int(duration_s * RATE)
    x = noise_sim.model_noise(_model(), n, 1 / RATE, rng)
    x += np.r_[rng.normal(0, GYRO_REP, 3), rng.normal(0, ACCEL_REP, 3)]
    x[:, 5] += 9.81
    return np.arange(n) / RATE, x


def _run(t, x, model=None):
    mon = HealthMonitor(model or _model(), HealthConfig(mc_windows=4000), thresholds=_thresholds())
    return mon, mon.push(t, x[:, :3], x[:, 3:])


@pytest.mark.parametrize("effect,channel", [("white_noise_increase", 1), ("vibration", 4)])
def test_noise_and_a_line_from_the_first_sample_are_named_at_once_and_held_while_they_last(effect, channel):
    t, x = _drive(21, 60.0)
    sd = 0.012 if channel < 3 else 0.016  # per-sample sd of the test model
    if effect == "white_noise_increase":
        x[:, channel] += np.random.default_rng(4).normal(0, np.sqrt(8) * sd, len(t))
    else:
        x[:, channel] += 3 * sd * np.sin(2 * np.pi * 9.7 * t + 0.3)
    mon, events = _run(t, x)
    assert [(e.effect, e.channels) for e in events] == [(effect, [CHANNELS[channel]])]
    e = events[0]
    assert e.onset_s == t[0] and e.t_s <= 5.0
    if effect == "vibration":
        assert abs(e.estimate["frequency_hz"] - 9.7) < 0.2
    else:
        assert e.interval_95[0][0] < 3.0 < e.interval_95[0][1]
    assert mon.channel_status(t[-1])[e.channels[0]][0] == "WARN"  # 60 s on, still there


def test_healthy_starts_give_no_event_and_the_turn_on_test_needs_a_stated_repeatability():
    for seed in (31, 32):
        t, x = _drive(seed, 40.0)
        mon, events = _run(t, x)
        assert events == []
        assert mon.observability()["turn_on_bias"].startswith("not tested: the model states no turn-on")
        t, x = _standing(seed)
        mon, events = _run(t, x, _stated())
        assert events == []
        assert mon.observability()["turn_on_bias"].startswith("tested at an unaccelerated start")
    gates = mon.startup.sth  # every look the tests use has a finite Monte Carlo gate on every channel
    assert np.isfinite(gates.line_h[2:]).all() and np.isfinite(gates.noise_h[1:]).all()


@pytest.mark.parametrize("channel,bias", [(0, 10 * GYRO_REP), (2, -10 * GYRO_REP), (5, 10 * ACCEL_REP)])
def test_a_turn_on_bias_ten_times_the_stated_repeatability_is_named_at_an_unaccelerated_start(channel, bias):
    t, x = _standing(41)
    x[:, channel] += bias
    mon, events = _run(t, x, _stated())
    assert [(e.effect, e.channels) for e in events] == [("turn_on_bias", [CHANNELS[channel]])]
    e = events[0]
    assert e.onset_s == t[0] and e.t_s <= 5.0
    assert abs(e.estimate - bias) < 0.3 * abs(bias)


def test_a_start_that_accelerates_leaves_the_turn_on_bias_unobserved():
    t, x = _drive(42, 20.0)  # ax swings 0.5 m/s^2 from the start
    x[:, 0] += 10 * GYRO_REP
    mon, events = _run(t, x, _stated())
    assert events == []
    assert mon.observability()["turn_on_bias"].startswith("not observable on this record")
