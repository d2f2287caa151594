"""wmra_filter evidence: simulated rate-table (Fig. 4) and road (Fig. 5) runs, the real car recording."""
import numpy as np
import pytest

from conftest import shared_data
from nav_core.datasets import read_balzer_csv
from wmra_filter import evaluation as ev
from wmra_filter.wmra import WmraConfig


def test_snr_and_rms_of_a_known_error():
    clean = np.tile(np.array([[1.0], [-1.0]]), (500, 1))  # variance 1
    noisy = clean + 0.1 * np.tile(np.array([[1.0], [-1.0]]), (500, 1))  # error power 0.01
    assert ev.snr_db(clean, noisy)[0] == pytest.approx(20.0)
    assert ev.rms_error(clean, noisy)[0] == pytest.approx(0.1)


def test_rise_time_and_overshoot_of_a_known_ramp():
    t = np.arange(0, 10, 0.01)
    clean = np.where(t >= 5, 2.0, 0.0)
    ramp = np.clip((t - 5) / 1.0, 0, 1) * 2.0 + np.where((t > 6) & (t < 6.5), 0.3, 0.0)
    rise, overshoot = ev.step_response(t, ramp, clean, 5.0, 0.0, 2.0)
    assert rise == pytest.approx(0.8, abs=0.011)   # 10 % at 5.1 s, 90 % at 5.9 s
    assert overshoot == pytest.approx(15.0)        # 0.3 over a step of 2


@pytest.mark.parametrize("mode", ["hard", "hard_soft"])
def test_rate_table_steps_survive_while_noise_drops(mode):
    sc = ev.rate_table_run(np.random.default_rng(11))
    out = ev.evaluate(sc, WmraConfig.for_bandwidth(64.0, vehicle="rate_table", mode=mode))
    gz = 2
    assert out["snr_db"]["wmra"][gz] > out["snr_db"]["raw"][gz] + 4.0
    assert out["rms"]["wmra"][gz] < 0.7 * out["rms"]["raw"][gz]
    dt = 1 / sc.sample_rate_hz
    for step in out["steps"]:
        assert step["rise_wmra_s"] <= 3 * dt + 1e-9          # the linear peer needs 7 samples
        assert step["rise_wmra_s"] <= 0.5 * step["rise_lowpass_s"]
    assert np.mean([s["overshoot_wmra_pct"] for s in out["steps"]]) < \
        np.mean([s["overshoot_lowpass_pct"] for s in out["steps"]])


def test_road_run_transitions_survive_while_noise_drops():
    sc = ev.road_run(np.random.default_rng(12))
    out = ev.evaluate(sc, WmraConfig.for_bandwidth(64.0))
    gain = out["snr_db"]["wmra"] - out["snr_db"]["raw"]
    assert np.all(gain > 4.0), gain
    assert np.all(out["rms"]["wmra"] < 0.7 * out["rms"]["raw"])
    assert all(np.isfinite(s["rise_raw_s"]) for s in out["steps"])
    for step in out["steps"]:
        assert step["rise_wmra_s"] <= step["rise_raw_s"] + 2 / sc.sample_rate_hz
        assert step["rise_wmra_s"] < step["rise_lowpass_s"]
        assert step["overshoot_wmra_pct"] < step["overshoot_lowpass_pct"] + 1.0


def test_real_car_residual_lies_above_the_kept_band():
    rec = read_balzer_csv(shared_data("balzer_car", "2014-03-26-000-Data.csv"))
    assert rec.rate_hz == pytest.approx(50.0)
    cfg = WmraConfig.for_bandwidth(50.0, noise="mad")
    out = ev.evaluate_real(rec, cfg)
    # what was removed is high-frequency: almost none of the residual power lies in the 5 Hz motion band
    assert np.all(out["residual_power_in_band"] < 0.05), out["residual_power_in_band"]
    assert np.all(out["raw_power_removed"] < 0.5)
    assert np.all(np.abs(out["denoised"].mean(axis=0) - out["raw"].mean(axis=0)) < 1e-6 + 0.01 * np.abs(
        out["raw"].mean(axis=0)))


def test_balzer_reader_names_the_file_on_missing_columns(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("millis,ax\n1,2\n3,4\n")
    with pytest.raises(ValueError, match="bad.csv: missing column"):
        read_balzer_csv(bad)
