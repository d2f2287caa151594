"""The diagnosis on recordings it did not make: files from benchmarks/independent_gen.py (no imu_sim code)."""
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from imu_sim.cli import main
from imu_sim.diagnose import reference, share
from imu_sim.diagnose.case import DiagnosisInputError, deterministic, load_case, residual
from imu_sim.diagnose.effect_tests import regression
from imu_sim.diagnose.candidate import Context
from imu_sim.diagnose.engine import _rank_by_share, diagnose, evaluate
from imu_sim.diagnose.ranking import heldout_fraction
from imu_sim.diagnose.regressors import Design
from imu_sim.diagnose.spectral import Whitener
from nav_core.earth import RATE as EARTH_RATE, normal_gravity
from nav_core.sensor_model import SensorModel, TriadModel, save as save_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_diagnosis_independent as bench  # noqa: E402
import independent_gen as gen  # noqa: E402


def test_independent_generator_agrees_with_first_principles_at_rest():
    site = gen.Site(51.0784, -114.13, 1100.0)
    _, gyro, accel = site.true_imu(gen.Poses([(0, 0, 0), (0, 0, 90)], 5.0, 2.0), 20.0)
    lat = np.radians(51.0784)
    # level, x east: the Earth rate's north part on y, its vertical part on z; specific force up on z
    np.testing.assert_allclose(gyro[0], [0, EARTH_RATE * np.cos(lat), EARTH_RATE * np.sin(lat)], atol=1e-12)
    # two independent gravity formulas (nav_core's and the generator's) agree to well below any sensor
    np.testing.assert_allclose(accel[0], [0, 0, normal_gravity(lat, 1100.0)], atol=1e-9)
    # yawed 90 deg left: x points north
    np.testing.assert_allclose(gyro[-1, :2], [EARTH_RATE * np.cos(lat), 0], atol=1e-12)


def _static_files(tmp_path, seconds=60.0, rate=50.0, cover_s=None, digits=10):
    site = gen.Site(*bench.SITE)
    t, gyro, accel = site.true_imu(gen.Poses([(0, 0, 0)], seconds, 1.0), rate)
    rng = np.random.default_rng(5)
    gyro = gyro + rng.normal(0, bench.GYRO_WHITE * np.sqrt(rate), gyro.shape)
    accel = accel + rng.normal(0, bench.ACCEL_WHITE * np.sqrt(rate), accel.shape)
    rec = gen.write_csv(tmp_path / "imu.csv", {"t": t, "gx": gyro[:, 0], "gy": gyro[:, 1], "gz": gyro[:, 2],
                                               "ax": accel[:, 0], "ay": accel[:, 1], "az": accel[:, 2]}, digits)
    sc = {"latitude_deg": bench.SITE[0], "longitude_deg": bench.SITE[1], "height_m": bench.SITE[2], "rate_hz": rate,
          "gps": False, "static_segments": [{"t0": 0.0, "t1": cover_s or seconds, "roll_deg": 0.0, "pitch_deg": 0.0,
                                             "yaw_deg": 0.0}]}
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump(sc))
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, bench.GYRO_WHITE)),
                        accel=TriadModel(white_noise=np.full(3, bench.ACCEL_WHITE)), sample_rate_hz=rate,
                        physics={"earth_rotation": {}, "gravity_model": {}})
    return rec, tmp_path / "scenario.yaml", save_model(model, tmp_path / "model.yaml")


def test_ten_digit_csv_lattice_is_a_property_of_the_file_not_quantization(tmp_path):
    case = load_case(*_static_files(tmp_path, digits=10))
    quant = next(c for c in evaluate(case, case.model, case.measured - case.measured.mean(axis=0))
                 if c.effect == "quantization")
    assert not quant.significant
    assert "print precision" in quant.reason and "significant digits" in quant.reason


def test_truth_that_does_not_cover_the_recording_is_an_input_error(tmp_path, capsys):
    rec, sc, model = _static_files(tmp_path, seconds=60.0, cover_s=30.0)
    with pytest.raises(DiagnosisInputError, match="must cover the recording"):
        load_case(rec, sc, model)
    code = main(["diagnose", "--recording", str(rec), "--scenario", str(sc), "--model", str(model),
                 "--out", str(tmp_path / "out")])
    assert code == 2 and "must cover the recording" in capsys.readouterr().err


def test_scenario_the_simulator_cannot_build_is_an_input_error(tmp_path):
    rec, sc, model = _static_files(tmp_path)
    (tmp_path / "truth.csv").write_text("t,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n0,51,-114,1100,0,0,0\n")
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump({"trajectory": "truth.csv", "rate_hz": 50.0, "gps": False}))
    with pytest.raises(ValueError, match="bad.yaml|truth.csv"):
        load_case(rec, tmp_path / "bad.yaml", model)


def test_an_effect_with_some_constant_regressors_is_tested_on_the_others(tmp_path):
    case = load_case(*_static_files(tmp_path, seconds=20.0))
    rng = np.random.default_rng(1)
    ramp = np.linspace(-1, 1, case.n)
    resid = rng.normal(0, 1e-3, (case.n, 6))
    resid[:, 0] += 3e-3 * ramp
    cols = {0: np.column_stack([ramp, np.zeros(case.n)]), 1: np.column_stack([np.zeros(case.n), np.ones(case.n)])}
    design = Design("scale_factor", cols, ["gyro[x]", "gyro[y]"], lambda th: {"gyro": list(th) + [0.0]})
    ctx = Context(case, case.model, resid, Whitener.from_model(case.model, resid, case.dt),
                  np.fft.rfft(resid, axis=0), 16, {})
    cand = regression(ctx, design)
    assert cand.identifiable and cand.significant
    assert list(cand.params) == ["gyro[x]"] and "gyro[y]" in cand.reason
    lo, hi = cand.intervals["gyro[x]"]
    assert lo < 3e-3 < hi
    assert cand.physics == {"gyro": [pytest.approx(cand.params["gyro[x]"]), 0.0, 0.0]}


def test_findings_are_ordered_by_their_share_of_the_mismatch():
    findings = [{"effect": "vibration", "mismatch_energy": 3.0}, {"effect": "quantization", "mismatch_energy": 0.0},
                {"effect": "earth_rotation", "mismatch_energy": 97.0}]
    details = ["v", "q", "e"]
    _rank_by_share(findings, details)
    assert [f["effect"] for f in findings] == ["earth_rotation", "vibration", "quantization"]
    assert details == ["e", "v", "q"]
    assert [f["share_of_mismatch"] for f in findings] == [0.97, 0.03, 0.0]
    assert share.shares([0.0, 0.0]) == [0.0, 0.0]


def test_findings_are_ranked_by_the_held_out_fraction_they_explain_not_by_their_energy():
    # the blind rate table: a warm-up of 0.1 m/s^2 on an accelerometer carried the energy (held-out gain 0.465 %),
    # the concealed gyro scale factor the evidence (held-out gain 92.4 %)
    warm = {"effect": "warmup_drift", "drop_one_energy": 900.0, "mismatch_energy": 0.0, "free_parameters": 7,
            "held_out_evidence": heldout_fraction(1.0, 1.0 - 0.00465, "RMS of held-out block means")}
    scale = {"effect": "scale_factor", "drop_one_energy": 100.0, "mismatch_energy": 0.0, "free_parameters": 3,
             "held_out_evidence": heldout_fraction(1.0, 1.0 - 0.924, "RMS of held-out block means")}
    walk = {"effect": "bias_random_walk", "drop_one_energy": 5e4, "mismatch_energy": 0.0, "free_parameters": 6,
            "held_out_evidence": heldout_fraction(2.0, 1.2, "Whittle deviance per bin")}
    findings, details = [warm, walk, scale], ["w", "r", "s"]
    _rank_by_share(findings, details)
    assert details == ["s", "r", "w"]
    assert [f["share_of_mismatch"] for f in findings] == [0.002, 0.9804, 0.0176]  # the share is still the energy
    assert heldout_fraction(1.0, 1.1, "RMS") == 0.0 and heldout_fraction(2.0, 1.0, "a deviance") == 0.5


def test_lines_of_the_trajectory_itself_are_flagged_as_harmonics(tmp_path):
    case = load_case(*_static_files(tmp_path, seconds=100.0))
    f0 = 0.25  # a periodic motion: the truth's rate has lines at f0 and 3 f0
    case.gyro_true = case.gyro_true + np.column_stack([np.sin(2 * np.pi * f0 * case.t),
                                                       0.1 * np.sin(2 * np.pi * 3 * f0 * case.t), 0 * case.t])
    freqs = np.fft.rfftfreq(case.n, case.dt)
    mask = reference.harmonic_bins(case)
    assert mask[np.argmin(abs(freqs - f0))] and mask[np.argmin(abs(freqs - 3 * f0))]
    assert mask.sum() <= 6


def test_rate_table_ramps_the_scenario_does_not_state_carry_no_information(tmp_path):
    # a table's ramps, each with its own acceleration and shape, typed as its dwells only (as a user does)
    site, rate, scale = gen.Site(*bench.SITE), 50.0, 1e-3
    table = gen.DwellTable([30, -60, 45], [4.0, 5.0, 4.0], [0.4, 1.5, 2.0, 0.8],
                           ["linear", "smooth", "quintic", "linear"], rest_s=3.0)
    t, gyro, accel = site.true_imu(table, rate)
    gyro[:, 2] *= 1.0 + scale
    rec = gen.write_csv(tmp_path / "imu.csv", {"t": t, "gx": gyro[:, 0], "gy": gyro[:, 1], "gz": gyro[:, 2],
                                               "ax": accel[:, 0], "ay": accel[:, 1], "az": accel[:, 2]})
    sc = {"latitude_deg": bench.SITE[0], "longitude_deg": bench.SITE[1], "height_m": bench.SITE[2], "rate_hz": rate,
          "gps": False, "static_segments": bench._table_holds(table)}
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump(sc))
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, 1e-6)), accel=TriadModel(white_noise=np.full(3, 1e-5)),
                        sample_rate_hz=rate, physics={"earth_rotation": {}, "gravity_model": {}})
    case = load_case(rec, tmp_path / "scenario.yaml", save_model(model, tmp_path / "model.yaml"))
    gap = case.unstated
    assert gap is not None and 0.1 < gap.mean() < 0.4 and "carry no information" in " ".join(case.notes)
    # the simulator's own move between two dwells is off by far more than any sensor effect ...
    assert np.abs(case.measured - deterministic(case, model))[gap, 2].max() > 0.05
    # ... so there the truth is 0 and the residual carries nothing; on the dwells it is the scale factor alone
    resid = residual(case, model)
    assert np.all(case.gyro_true[gap] == 0.0)
    assert resid[~gap, 2].min() - 1e-6 <= resid[gap, 2].min() and resid[gap, 2].max() <= resid[~gap, 2].max() + 1e-6
    np.testing.assert_allclose(resid[~gap, 2], scale * case.gyro_true[~gap, 2], atol=2e-7)


@pytest.mark.slow
@pytest.mark.parametrize("name, effect, par, true", [("scale_factor_table", "scale_factor", "gyro[z]", 7e-4),
                                                     ("misalignment_table", "axis_misalignment", "gyro[xz]", 7e-4)])
def test_rate_table_from_a_truth_csv_identifies_gyro_scale_and_misalignment(tmp_path, name, effect, par, true):
    p = bench.generate(name, 7000, tmp_path)
    res = diagnose(load_case(p["recording"], p["scenario"], p["model"]), max_effects=1, seed=7000).result
    first = res["findings"][0]
    assert first["effect"] == effect
    lo, hi = first["intervals"][par]
    assert lo < true < hi
    assert first["share_of_mismatch"] == 1.0
    assert "accel" in next(t for t in res["tested"] if t["effect"] == effect)["note"]


@pytest.mark.slow
def test_navigation_grade_up_down_names_earth_rotation_first_with_most_of_the_mismatch(tmp_path):
    p = bench.generate("earth_rotation_updown", 7001, tmp_path)
    res = diagnose(load_case(p["recording"], p["scenario"], p["model"]), max_effects=3, seed=7001).result
    first = res["findings"][0]
    assert first["effect"] == "earth_rotation" and first["share_of_mismatch"] > 0.5
    lo, hi = first["intervals"]["earth_rate_rad_per_s"]
    assert lo < EARTH_RATE < hi
    assert "quantization" not in [f["effect"] for f in res["findings"]]


@pytest.mark.slow
def test_drive_from_a_truth_csv_with_nothing_missing_gives_no_finding(tmp_path):
    p = bench.generate("null_drive", 8001, tmp_path)
    res = diagnose(load_case(p["recording"], p["scenario"], p["model"], p["gnss"]), max_effects=2, seed=8001).result
    assert res["findings"] == []
    assert "reference trajectory's error" in next(t for t in res["tested"] if t["effect"] == "vibration")["note"]


@pytest.mark.slow
def test_chained_naive_model_from_imu_calib_allan_gives_no_finding_on_a_walk_it_fitted(tmp_path):
    # the user's route: imu-calib allan on the recording writes the model, imu-sim diagnose checks it
    p = bench.generate("null_single_naive", 8001, tmp_path)
    res = diagnose(load_case(p["recording"], p["scenario"], p["model"]), max_effects=2, seed=8001).result
    assert res["findings"] == []


def test_a_slow_curve_on_a_rate_table_is_scored_on_the_half_it_was_not_fitted_on():
    from types import SimpleNamespace
    from imu_sim.diagnose import metrics
    from imu_sim.diagnose.ranking import slow_curve_on_table
    table = SimpleNamespace(scenario=SimpleNamespace(source="static_segments", spec=[{"rate_dps": 0.0},
                                                                                     {"rate_dps": 30.0}]))
    fixture = SimpleNamespace(scenario=SimpleNamespace(source="static_segments", spec=[{"rate_dps": 0.0}]))
    warm = SimpleNamespace(effect="warmup_drift", kind="regression", columns={0: np.ones((10, 1))})
    scale = SimpleNamespace(effect="scale_factor", kind="regression", columns={0: np.ones((10, 1))})
    assert slow_curve_on_table(table, warm) and not slow_curve_on_table(table, scale)
    assert not slow_curve_on_table(fixture, warm)
    # wander in the last quarter of the run: tenths interleaved with the fit's own learn its shape, a curve fitted on
    # the first half cannot (it has to predict what it has not seen)
    n = 4000
    shape = np.where(np.arange(n) > 3 * n // 4, 1.0, 0.0)
    resid = np.random.default_rng(3).normal(0, 1.0, (n, 6))
    resid[:, 0] += 0.5 * shape
    cols = {0: shape[:, None]}
    b, a = metrics.heldout_rms(resid, cols, 1.0, 10.0)
    assert a < 0.9 * b
    b, a = metrics.heldout_rms(resid, cols, 1.0, 10.0, contiguous=True)
    assert a == pytest.approx(b, rel=1e-9)
