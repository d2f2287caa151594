"""Diagnosis on concealed effects: right name first, intervals, held-out improvement; nulls stay quiet."""
import json

import numpy as np
import pytest

from nav_core.recording import write_gnss_csv, write_imu_csv
from nav_core.sensor_model import load as load_model, save as save_model

from imu_sim.cli import main
from imu_sim.diagnose.case import make_case
from imu_sim.diagnose.engine import diagnose
from imu_sim.diagnose.suite import (TRUE_PARAMS, concealment, drive_scenario, make_inputs,
                                    make_recording, run_case, suite_scenario)

import yaml


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["earth_rotation", "scale_factor", "warmup_drift", "vibration", "quantization",
                                    "axis_misalignment", "gps_latency", "gps_lever_arm", "colored_gps_noise"])
def test_concealed_effect_is_named_first_and_its_interval_covers_the_truth(effect):
    row = run_case(effect, seed=11)
    assert row["first"] == effect
    assert row["fit_after"] < row["fit_before"]
    if TRUE_PARAMS.get(effect):
        assert row["covered"] >= max(1, row["n_params"] - 1)


@pytest.mark.slow
def test_nothing_missing_gives_no_finding():
    row = run_case("null_nothing_missing", seed=12)
    assert row["n_findings"] == 0


@pytest.mark.slow
def test_coloured_gps_noise_without_latency_gives_no_finding():
    row = run_case("null_colored_gps_noise", seed=14)
    assert row["n_findings"] == 0
    value, threshold = row["stats"]["gps_latency"]
    assert value < threshold


@pytest.mark.slow
def test_single_orientation_says_earth_rate_is_not_identifiable():
    rec, sc, model = make_recording("null_single_orientation", 13)
    res = diagnose(make_case(rec, sc, model), max_effects=1).result
    earth = next(t for t in res["tested"] if t["effect"] == "earth_rotation")
    assert not earth["identifiable"] and "bias" in earth["note"]
    assert "earth_rotation" not in [f["effect"] for f in res["findings"]]
    coning = next(t for t in res["tested"] if t["effect"] == "coning_sculling")
    assert not coning["identifiable"] and "turn-on bias" in coning["note"]


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["gauss_markov_bias", "bias_random_walk"])
def test_slow_wander_effect_is_told_from_its_rivals_on_the_long_run(effect):
    row = run_case(effect, seed=11)
    assert row["first"] == effect
    assert row["fit_after"] < row["fit_before"]
    assert row["covered"] >= row["n_params"] - 1


@pytest.mark.slow
def test_long_run_random_walk_is_concealed_in_samples_and_allan_plot():
    hidden = concealment("bias_random_walk", 11)
    assert hidden["peak_over_noise"] < 0.5
    assert hidden["allan_ratio_max"] < 2.0


def test_concealed_effect_is_below_the_per_sample_noise():
    rec, _, model = make_recording("gyro_g_sensitivity", 3)
    rec0, _, _ = make_recording("null_nothing_missing", 3)
    added = rec.gyro - rec0.gyro
    assert np.max(np.abs(added)) < 0.5 * np.std(rec0.gyro[:500] - rec0.gyro[:500].mean(axis=0))


@pytest.mark.slow
def test_cli_writes_json_updated_model_and_report(tmp_path):
    rec, _, model = make_recording("warmup_drift", 5)
    csv = write_imu_csv(tmp_path / "imu.csv", rec)
    scen = tmp_path / "scenario.yaml"
    scen.write_text(yaml.safe_dump(suite_scenario()))
    mpath = save_model(model, tmp_path / "model.yaml")
    assert main(["diagnose", "--recording", str(csv), "--scenario", str(scen), "--model", str(mpath),
                 "--out", str(tmp_path / "out"), "--max-effects", "1"]) == 0
    res = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    assert res["mismatch"] and res["findings"][0]["effect"] == "warmup_drift"
    for key in ("effect", "channels", "time_span_s", "band", "parameters", "intervals", "fit_before", "fit_after",
                "metric", "explanation"):
        assert key in res["findings"][0]
    assert len(res["tested"]) == 16
    updated = load_model(tmp_path / "out" / "model_updated.yaml")
    assert updated.has_physics("warmup_drift") and updated.has_physics("earth_rotation")
    assert (tmp_path / "out" / "report.html").exists() and (tmp_path / "out" / "allan.png").exists()
    span = res["findings"][0]["time_span_s"]
    assert span[0] < 60.0  # the warm-up is at the start


def test_cli_rejects_unusable_input_with_a_message(tmp_path, capsys):
    bad = tmp_path / "imu.csv"
    bad.write_text("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.8\n")
    scen = tmp_path / "scenario.yaml"
    scen.write_text(yaml.safe_dump(suite_scenario()))
    from imu_sim.diagnose.suite import suite_model
    mpath = save_model(suite_model(), tmp_path / "model.yaml")
    code = main(["diagnose", "--recording", str(bad), "--scenario", str(scen), "--model", str(mpath),
                 "--out", str(tmp_path / "out")])
    assert code != 0
    assert "imu.csv" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_with_gnss_names_the_latency_and_says_lever_arm_z_is_not_identifiable(tmp_path):
    rec, _, model, gnss = make_inputs("gps_latency", 6)
    csv = write_imu_csv(tmp_path / "imu.csv", rec)
    gcsv = write_gnss_csv(tmp_path / "gnss.csv", gnss)
    scen = tmp_path / "scenario.yaml"
    scen.write_text(yaml.safe_dump(drive_scenario()))
    mpath = save_model(model, tmp_path / "model.yaml")
    assert main(["diagnose", "--recording", str(csv), "--scenario", str(scen), "--model", str(mpath),
                 "--gnss", str(gcsv), "--out", str(tmp_path / "out"), "--max-effects", "1"]) == 0
    res = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    first = res["findings"][0]
    assert first["effect"] == "gps_latency" and first["fit_after"] < first["fit_before"]
    lo, hi = first["intervals"]["latency_s"]
    assert lo < 0.03 < hi
    arm = next(t for t in res["tested"] if t["effect"] == "gps_lever_arm")
    assert "lever_arm_m[z]" in arm["note"]
    assert load_model(tmp_path / "out" / "model_updated.yaml").has_physics("gps_latency")
    assert (tmp_path / "out" / "gnss_residual.png").exists()
