"""``imu-sim diagnose`` on a damaged recording: it pairs samples with the scenario by index, so a gap, a repeated
or stepped-back stamp or a NaN sample is an input error naming the file, the sample and its time (a 5-s gap had
given no finding at all, silently; a NaN sample an error naming neither)."""
import numpy as np
import pytest
import yaml

from imu_sim.cli import main
from imu_sim.diagnose.case import DiagnosisInputError, load_case
from nav_core import recording
from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel, save as save_model

RATE = 50.0
N = 1500


def _files(tmp_path, damage=None):
    rng = np.random.default_rng(2)
    t = np.arange(1, N + 1) / RATE
    gyro, accel = rng.normal(0, 1e-3, (N, 3)), rng.normal(0, 1e-2, (N, 3)) + [0, 0, 9.8]
    if damage == "gap":
        keep = np.ones(N, bool)
        keep[700:850] = False  # 3 s lost
        t, gyro, accel = t[keep], gyro[keep], accel[keep]
    elif damage == "repeat":
        t[700] = t[699]
    elif damage == "back":
        t[700], t[701] = t[701], t[700]
    elif damage == "nan":
        gyro[700, 1] = np.nan
    elif damage == "in_g":
        accel = accel / 9.80665
    rec = recording.write_imu_csv(tmp_path / "imu.csv", ImuRecording(t, gyro, accel))
    sc = {"latitude_deg": 45.0, "longitude_deg": 7.0, "height_m": 200.0, "rate_hz": RATE, "gps": False,
          "static_segments": [{"t0": 0.0, "t1": N / RATE + 1.0, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0}]}
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump(sc))
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, 1e-4)), accel=TriadModel(white_noise=np.full(3, 1e-3)),
                        sample_rate_hz=RATE)
    return rec, tmp_path / "scenario.yaml", save_model(model, tmp_path / "model.yaml")


def test_a_clean_recording_is_paired_sample_by_sample(tmp_path):
    case = load_case(*_files(tmp_path))
    assert case.n == N and np.allclose(np.diff(case.t), 1 / RATE)


@pytest.mark.parametrize("damage, words", [
    ("gap", ["gaps longer than", "sample 700: 14.000000 -> 17.020000 s", "by index"]),
    ("repeat", ["duplicate stamps", "sample 700"]),
    ("back", ["time going backwards", "sample 701"]),
    ("nan", ["NaN or infinite", "sample 700", "t = 14.020000 s"]),
    ("in_g", ["accelerometer columns", "0.102 x", "g?"]),  # was: no finding, the turn-on bias took it
])
def test_a_gap_repeat_step_back_or_nan_sample_is_an_input_error_naming_file_and_sample(tmp_path, capsys, damage,
                                                                                        words):
    rec, sc, model = _files(tmp_path, damage)
    with pytest.raises(DiagnosisInputError) as err:
        load_case(rec, sc, model)
    for w in ["imu.csv", *words]:
        assert w in str(err.value), (w, str(err.value))
    code = main(["diagnose", "--recording", str(rec), "--scenario", str(sc), "--model", str(model),
                 "--out", str(tmp_path / "out")])
    out = capsys.readouterr().err
    assert code == 2 and "Traceback" not in out and not (tmp_path / "out").exists()


# -- a GNSS track (KF-GINS text) for ``gnss_track:`` ----------------------------------------------------------


def _track(tmp_path, change=None, n=80):
    rows = [f"{456250.0 + k:.3f}  {30.4447858 + 1e-6 * k:.10f}  {114.4718661:.10f}  21.095  0.010  0.009  0.019"
            for k in range(n)]
    if change == "nan":
        rows[40] = rows[40].replace("21.095", "nan")
    elif change == "text":
        rows[40] = rows[40].replace("21.095", "abc")
    elif change == "swap":
        rows[40], rows[41] = rows[41], rows[40]
    elif change == "gap":
        del rows[30:50]
    text = "\n".join(rows) + "\n"
    if change == "cut":
        text = text[:len(text) // 2 + 5]
    path = tmp_path / "GNSS-RTK.txt"
    path.write_text(text)
    return path


@pytest.mark.parametrize("change, lost, words", [
    ("cut", None, ["skipped 1 bad row", "line 41"]),  # was: the whole file refused ("number of columns changed")
    ("text", 1, ["line 41", "column '4'"]),          # was: numpy's "could not convert" without the file
    ("nan", 1, ["not a finite number", "line 41"]),   # was: scipy's "Array must not contain infs or nans"
    ("swap", 1, ["stamped at or before an earlier row", "line 42"]),  # was: "x must be increasing if s > 0"
    ("gap", 0, ["1 gap(s) over 5 s", "line 30 to 31", "21 s"]),
])
def test_a_damaged_gnss_track_keeps_every_good_fix_and_names_the_line(tmp_path, caplog, change, lost, words):
    from imu_sim.trajectory import read_gnss_track

    path = _track(tmp_path, change)
    t, lat, lon, h, std = read_gnss_track(path)
    n = 60 if change == "gap" else 80
    if lost is not None:
        assert len(t) == n - lost
    assert np.all(np.diff(t) > 0) and np.all(np.isfinite(h))
    said = " ".join(r.getMessage() for r in caplog.records)
    for w in ["GNSS-RTK.txt", *words]:
        assert w in said, (w, said)


def test_a_gnss_track_of_another_format_is_one_error_naming_it(tmp_path):
    from imu_sim.trajectory import read_gnss_track
    from nav_core.recording import RecordingError

    path = tmp_path / "track.csv"
    path.write_text("456250.0,30.44,114.47,21.0\n456251.0,30.44,114.47,21.0\n")
    with pytest.raises(RecordingError, match="track.csv: expected whitespace-separated columns"):
        read_gnss_track(path)


# -- a truth CSV for ``trajectory:`` ---------------------------------------------------------------------------


def _truth_scenario(tmp_path, change=None):
    from nav_core.recording import Trajectory, write_trajectory_csv

    n = 400
    t = np.arange(n) / 20.0
    lat, lon = np.radians(45.0) + 1e-7 * t, np.full(n, np.radians(7.0))
    path = write_trajectory_csv(tmp_path / "truth.csv", Trajectory(t, lat, lon, np.full(n, 200.0), np.zeros(n),
                                                                   np.zeros(n), np.full(n, 1.57)))
    lines = path.read_text().splitlines()
    if change == "nan":
        f = lines[201].split(",")
        f[6] = "nan"
        lines[201] = ",".join(f)
    elif change == "swap":
        lines[201], lines[202] = lines[202], lines[201]
    elif change == "repeat":
        lines.insert(201, lines[201])
    path.write_text("\n".join(lines) + "\n")
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump({"trajectory": "truth.csv", "gps": False}))
    return tmp_path / "scenario.yaml"


@pytest.mark.parametrize("change, words", [
    ("nan", ["truth.csv: line 202: column 'yaw_deg' is not a finite number"]),  # was: exit 0 or an int16 error
    ("swap", ["truth.csv: line 203: t = ", "not after line 202"]),               # was: scipy's "x must be increasing"
])
def test_a_truth_csv_row_the_splines_cannot_take_is_named_by_line_and_column(tmp_path, capsys, change, words):
    sc = _truth_scenario(tmp_path, change)
    assert main(["simulate", "--scenario", str(sc), "--out", str(tmp_path / "out"), "--format", "csv"]) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err, (w, err)


def test_a_truth_row_written_twice_is_taken_once(tmp_path):
    from imu_sim.scenario import build_trajectory, load as load_scenario

    clean = build_trajectory(load_scenario(_truth_scenario(tmp_path)))
    twice = build_trajectory(load_scenario(_truth_scenario(tmp_path, "repeat")))
    ts = np.linspace(1.0, 18.0, 50)
    np.testing.assert_allclose(twice.position.enu(ts), clean.position.enu(ts), rtol=0, atol=1e-9)
    assert (twice.t0, twice.t1) == (clean.t0, clean.t1)
