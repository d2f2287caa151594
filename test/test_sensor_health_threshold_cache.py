"""The monitor's Monte Carlo cached on disk per model: a warm start gives the computed gates bit for bit (so the same
events), the key follows the model's numbers and not its provenance, and an unreadable or stale entry is recomputed
with a log line, never used."""
import dataclasses
import logging

import numpy as np
import pytest

from sensor_health import threshold_cache as tc
from sensor_health.monitor import HealthConfig, HealthMonitor
from sensor_health.thresholds import Thresholds
from test_sensor_health_core import _drive, _model

SMALL = HealthConfig(mc_windows=2000, bias_mc_hours=50.0)
"""A short Monte Carlo: the cache's behaviour does not depend on its length."""


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(tc.ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def _same(a, b) -> bool:
    """Every field equal, arrays bit for bit and of one dtype, scalars of one type."""
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if type(x) is not type(y):
            return False
        if isinstance(x, np.ndarray):
            if x.dtype != y.dtype or not np.array_equal(x, y, equal_nan=True):
                return False
        elif x != y:
            return False
    return True


def test_a_warm_start_reads_the_computed_gates_bit_for_bit_and_names_the_same_events(cache, monkeypatch):
    cold = HealthMonitor(_model(), SMALL)
    assert sorted(p.name.split("-")[0] for p in cache.iterdir()) == ["ax_gate", "startup", "thresholds"]
    monkeypatch.setattr("sensor_health.thresholds.monte_carlo", lambda *a, **k: pytest.fail("recomputed"))
    warm = HealthMonitor(_model(), SMALL)
    assert _same(cold.thr, warm.thr) and _same(cold.startup.sth, warm.startup.sth)
    assert warm.along_track.gate == cold.along_track.gate
    t, x = _drive(5, 60.0)
    x[t >= 30.0, 3] = x[np.argmax(t >= 30.0), 3]  # ax frozen: an event in both
    events = [[e.to_json() for e in mon.push(t, x[:, :3], x[:, 3:])] for mon in (cold, warm)]
    assert events[0] and events[0] == events[1]


def test_the_key_is_the_models_numbers_not_its_provenance():
    model = _model()
    other = _model()
    other.provenance = {"tool": "imu-calib allan", "created_utc": "2026-11-28T00:00:00Z"}
    assert tc.key_of("thresholds", (model, 1.0)) == tc.key_of("thresholds", (other, 1.0))
    other.accel.white_noise = other.accel.white_noise * (1 + 1e-12)
    assert tc.key_of("thresholds", (model, 1.0)) != tc.key_of("thresholds", (other, 1.0))
    assert tc.key_of("thresholds", (model, 1.0)) != tc.key_of("thresholds", (model, 1.0 + 1e-15))


@pytest.mark.parametrize("damage", ["truncated", "garbage", "stale key"])
def test_an_unusable_entry_is_recomputed_with_a_log_line_and_rewritten(cache, caplog, damage):
    calls = []

    def compute():
        calls.append(1)
        return 4.854885254487467

    assert tc.cached("ax_gate", (0.1, "m"), compute) == 4.854885254487467
    (path,) = cache.iterdir()
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:100])
    elif damage == "garbage":
        path.write_bytes(b"not an npz")
    else:  # an entry written under another key at this name
        tc._write(path, "0" * 64, 1.0)
    with caplog.at_level(logging.WARNING, logger="sensor_health.threshold_cache"):
        assert tc.cached("ax_gate", (0.1, "m"), compute) == 4.854885254487467
    assert len(calls) == 2 and "recomputing" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="sensor_health.threshold_cache"):
        assert tc.cached("ax_gate", (0.1, "m"), compute) == 4.854885254487467
    assert len(calls) == 2 and not caplog.text  # rewritten: read back


def test_off_computes_every_time_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(tc.ENV, tc.OFF)
    monkeypatch.chdir(tmp_path)
    assert tc.cache_dir() is None
    assert [tc.cached("ax_gate", (0.1,), lambda: 2.0) for _ in range(2)] == [2.0, 2.0]
    assert not list(tmp_path.iterdir())


def test_a_dataclass_with_numpy_scalars_round_trips_with_its_types(cache):
    value = Thresholds(**{f.name: None for f in dataclasses.fields(Thresholds)})
    value.window_s, value.noise_k, value.bias_h = 1.0, np.float64(0.25), np.array([1.5, np.inf, 2.0])
    value.bias_h_how, value.mc_windows = ["split", "", "measured"], 8000
    tc.cached("thresholds", ("x",), lambda: value, Thresholds)
    back = tc.cached("thresholds", ("x",), lambda: pytest.fail("recomputed"), Thresholds)
    assert _same(value, back)
