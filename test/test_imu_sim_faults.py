"""A scenario's ``faults:`` section: validated with errors naming the entry, applied to the simulated IMU output."""
from pathlib import Path

import numpy as np
import pytest

from imu_sim import faults
from imu_sim.scenario import ScenarioError, from_dict
from imu_sim.simulate import simulate

BASE = {"latitude_deg": 45.0, "longitude_deg": 7.0, "rate_hz": 64,
        "segments": [{"type": "stand", "duration_s": 20.0}], "gps": {"enabled": False}}


def test_each_fault_changes_its_channel_from_its_start_only():
    t = np.arange(0, 20, 1 / 64)
    rates = np.random.default_rng(0).normal(0, 0.01, (len(t), 6))
    specs = [{"effect": "stuck_output", "channel": "gx", "start_s": 5},
             {"effect": "vibration", "channel": "gy", "start_s": 10, "frequency_hz": 12.5, "amplitude": 0.05},
             {"effect": "bias_shift", "channel": "az", "start_s": 8, "end_s": 12, "step": 0.1},
             {"effect": "saturation", "channel": "ax", "start_s": 0, "level": 0.005},
             {"effect": "white_noise_increase", "channel": "ay", "start_s": 10, "factor": 3}]
    out = faults.apply(faults.parse(specs, "s.yaml"), t, rates, np.random.default_rng(1))
    before = t < 5
    np.testing.assert_array_equal(out[before, :3][:, [0, 2]], rates[before][:, [0, 2]])
    assert np.all(out[t >= 5, 0] == out[np.argmax(t >= 5), 0])
    np.testing.assert_allclose(out[t >= 10, 1] - rates[t >= 10, 1], 0.05 * np.sin(2 * np.pi * 12.5 * t[t >= 10]),
                               atol=1e-12)
    on = (t >= 8) & (t < 12)
    np.testing.assert_allclose(out[:, 5] - rates[:, 5], np.where(on, 0.1, 0.0))
    assert np.abs(out[:, 3]).max() <= 0.005
    ratio = np.std(np.diff(out[t >= 10, 4])) / np.std(np.diff(out[t < 10, 4]))
    assert 2.6 < ratio < 3.4


@pytest.mark.parametrize("entry, words", [
    ({"effect": "wobble", "channel": "gx"}, "effect 'wobble'"),
    ({"effect": "vibration", "channel": "gx", "frequency_hz": 3}, "needs amplitude"),
    ({"effect": "stuck_output", "channel": "gw"}, "channel 'gw'"),
    ({"effect": "stuck_output", "channel": "gx", "level": 1}, "unknown key(s) ['level']"),
    ({"effect": "bias_shift", "channel": "gx", "step": "big"}, "step: expected a finite number"),
])
def test_a_bad_fault_is_a_scenario_error_naming_the_entry(entry, words):
    with pytest.raises(ScenarioError, match=r"s\.yaml: faults\[0\]") as err:
        from_dict({**BASE, "faults": [entry]}, "s.yaml")
    assert words in str(err.value)


def test_the_simulation_carries_the_scenarios_fault():
    model = Path(__file__).resolve().parents[1] / "config" / "sensor_models" / "bp3010.yaml"
    clean = simulate(from_dict(BASE, "s.yaml"), model=model, seed=3)
    faulty = simulate(from_dict({**BASE, "faults": [{"effect": "stuck_output", "channel": "gz", "start_s": 10}]},
                                "s.yaml"), model=model, seed=3)
    late = faulty.imu.t >= 10
    assert np.ptp(faulty.imu.gyro[late, 2]) < 1e-12 < np.ptp(clean.imu.gyro[late, 2])
    np.testing.assert_allclose(faulty.imu.gyro[~late], clean.imu.gyro[~late], atol=1e-12)
