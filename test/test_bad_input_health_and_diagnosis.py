"""The newest CLIs on a damaged recording: ``sensor-health`` and ``imu-sim diagnose`` on seconds missing, a duplicated
stamp, a file cut mid-line, a NaN row and a GNSS CSV whose header has a typo. Each gives an error naming the file,
the column or the sample, or runs on what is good and says what it skipped.

``imu-sim diagnose`` pairs samples with its scenario by index, so a gap, a duplicated stamp or a NaN sample is an
input error naming the file and the sample: test_imu_sim_bad_input.py checks those. One ``sensor-health`` run on
one recording with all four kinds of damage serves the tests of this file (a few seconds).
"""
import contextlib
import io
import json
import logging

import numpy as np
import pytest
import yaml

from nav_core import recording
from nav_core.recording import GnssRecording, ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel, save as save_model

RATE = 50.0
N = 1500  # 30 s
GAP = slice(300, 450)  # 3 s missing after t = 6.0 s
DUPLICATE, NAN = 700, 900  # rows of the written file (samples after the gap), as 0-based sample indices


def _damaged_csv(folder):
    """A 50-Hz CSV with 3 s missing, one row written twice, one NaN gy and the last row cut mid-line; and a
    model, a static scenario and a GNSS CSV whose header says ``lat_dge``."""
    rng = np.random.default_rng(4)
    t = np.arange(1, N + 1) / RATE
    keep = np.ones(N, bool)
    keep[GAP] = False
    rec = ImuRecording(t[keep], rng.normal(0, 1e-3, (N, 3))[keep], rng.normal(0, 1e-2, (N, 3))[keep] + [0, 0, 9.8])
    rec.gyro[NAN, 1] = np.nan
    lines = recording.write_imu_csv(folder / "imu.csv", rec).read_text().splitlines(keepends=True)
    lines.insert(DUPLICATE + 2, lines[DUPLICATE + 1])  # line 1 is the header: sample k is line k + 2
    text = "".join(lines)
    (folder / "imu.csv").write_text(text[:-len(lines[-1]) // 2])  # the last row cut mid-line
    model = save_model(SensorModel(gyro=TriadModel(white_noise=np.full(3, 1e-4)),
                                   accel=TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=RATE),
                       folder / "model.yaml")
    scenario = {"latitude_deg": 45.0, "longitude_deg": 7.0, "height_m": 200.0, "rate_hz": RATE, "gps": False,
                "static_segments": [{"t0": 0.0, "t1": N / RATE + 1.0, "roll_deg": 0, "pitch_deg": 0, "yaw_deg": 0}]}
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario))
    n = 30
    gnss = recording.write_gnss_csv(folder / "gnss.csv", GnssRecording(
        np.arange(1.0, n + 1), np.full(n, np.radians(45.0)), np.full(n, np.radians(7.0)), np.full(n, 200.0),
        np.ones((n, 3))))
    gnss.write_text(gnss.read_text().replace("lat_deg", "lat_dge", 1))
    return folder / "imu.csv", model, folder / "scenario.yaml", gnss


@pytest.fixture(scope="module")
def health_run(tmp_path_factory):
    """One ``sensor-health`` run on the damaged CSV: (exit code, stdout, stderr, health.json, input files)."""
    from sensor_health.cli import main

    folder = tmp_path_factory.mktemp("damaged")
    files = _damaged_csv(folder)
    out, err = io.StringIO(), io.StringIO()
    said = logging.StreamHandler(err)  # the readers' warnings (the CLI's handler holds the stderr of its start)
    logging.getLogger().addHandler(said)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["--recording", str(files[0]), "--model", str(files[1]), "--out", str(folder / "health"),
                         "--no-progress"])
    finally:
        logging.getLogger().removeHandler(said)
    doc = json.loads((folder / "health" / "health.json").read_text()) if code == 0 else {}
    return code, out.getvalue(), err.getvalue(), doc, files


def _events(doc, effect):
    return [e for e in doc["events"] if e["effect"] == effect]


def test_sensor_health_runs_on_the_good_samples_of_a_damaged_recording(health_run):
    code, _, _, doc, _ = health_run
    # every whole row but the NaN one's channel: 1350 written, one twice, the cut one lost
    assert code == 0 and doc["samples"] == N - (GAP.stop - GAP.start) - 1


def test_sensor_health_names_seconds_missing_as_a_dropout_at_their_time(health_run):
    _, stdout, _, doc, _ = health_run
    gap = _events(doc, "dropout")
    assert len(gap) == 1 and "150 sample intervals missing" in gap[0]["message"]
    assert gap[0]["onset_s"] == pytest.approx((GAP.start + 1) / RATE, abs=0.03)
    assert "dropout" in stdout


def test_sensor_health_skips_a_duplicated_stamp_and_says_which(health_run):
    # was: taken silently (no interval, but its values in the statistics), nothing said
    _, _, stderr, doc, files = health_run
    t = (DUPLICATE + 1 + GAP.stop - GAP.start) / RATE
    said = f"{files[0]}: 1 duplicate stamps (sample {DUPLICATE + 1}: {t:.6f} -> {t:.6f} s): skipped 1 sample(s)"
    assert said in stderr, stderr
    assert not _events(doc, "sample_rate_change") and len(_events(doc, "dropout")) == 1


def test_sensor_health_keeps_every_whole_row_of_a_file_cut_mid_line_and_names_the_line(health_run):
    _, _, stderr, _, files = health_run
    lines = len(files[0].read_text().splitlines())
    assert f"{files[0]}: skipped 1 bad row(s)" in stderr and f"line {lines}:" in stderr, stderr


def test_sensor_health_names_a_nan_sample_by_channel_and_time(health_run):
    _, _, _, doc, _ = health_run
    bad = _events(doc, "non_finite")
    assert len(bad) == 1 and bad[0]["channels"] == ["gy"] and bad[0]["level"] == "ERROR"
    assert bad[0]["t_s"] == pytest.approx((NAN + 1 + GAP.stop - GAP.start) / RATE)


def test_a_gnss_csv_header_typo_is_one_line_naming_file_column_and_suggestion_in_both_clis(health_run, capsys):
    from imu_sim.cli import main as imu_sim_main
    from sensor_health.cli import main as health_main

    imu, model, scenario, gnss = health_run[4]
    out = imu.parent / "typo"
    codes = [health_main(["--recording", str(imu), "--gnss", str(gnss), "--model", str(model), "--out", str(out)]),
             imu_sim_main(["diagnose", "--recording", str(imu), "--gnss", str(gnss), "--scenario", str(scenario),
                           "--model", str(model), "--out", str(out)])]
    said = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert codes == [2, 2] and len(said) == 2 and not out.exists(), said
    for line in said:
        assert f"{gnss}: " in line and "missing column(s) ['lat_deg']" in line and "did you mean 'lat_dge'" in line


def test_diagnose_keeps_every_whole_row_of_a_file_cut_mid_line_and_names_the_line(tmp_path, caplog):
    from imu_sim.diagnose.case import load_case

    rng = np.random.default_rng(5)
    t = np.arange(1, 401) / RATE
    path = recording.write_imu_csv(tmp_path / "imu.csv", ImuRecording(t, rng.normal(0, 1e-3, (400, 3)),
                                                                         rng.normal(0, 1e-2, (400, 3)) + [0, 0, 9.8]))
    text = path.read_text()
    path.write_text(text[:len(text) - 20])  # the last row cut mid-line
    (tmp_path / "inputs").mkdir()
    _, model, scenario, _ = _damaged_csv(tmp_path / "inputs")
    with caplog.at_level(logging.WARNING):
        case = load_case(path, scenario, model)
    assert case.n == 399
    said = " ".join(r.getMessage() for r in caplog.records)
    assert f"{path}: skipped 1 bad row(s)" in said and "line 401:" in said, said
