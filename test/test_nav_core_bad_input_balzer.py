"""The balzer82 car CSV reader (``nav-convert balzer``, ``wmra-report --balzer``, the filter's evaluation) on damaged
files: every good row is read, a damaged one is dropped and named by file, line and column, an unusable file is a
RecordingError naming the file (was: a numpy traceback, a message without the file, or NaN written into the bag)."""
import numpy as np
import pytest

from nav_core import datasets
from nav_core.recording import RecordingError

HEADER = ("date,time,millis,ax,ay,az,rollrate,pitchrate,yawrate,roll,pitch,yaw,speed,course,latitude,longitude,"
          "altitude,pdop,hdop,vdop,epe,fix,satellites_view,satellites_used,temp")
N = 400


def _lines(seed=0):
    """A clean car log: 20 ms rows, a GPS fix (``time`` column changes) every 5 rows."""
    rng = np.random.default_rng(seed)
    out = [HEADER]
    for k in range(N):
        imu = rng.normal(0, 0.5, 6) + [0, 0, -9.8, 0, 0, 0]
        fix = k // 5
        out.append(",".join(f"{v:.15g}" for v in [260314, 123825300 + 100 * fix, 1395837505000.0 + 20.0 * k, *imu,
                                                  0, 0, 0, 5.0, 10.0, 51.0 + 1e-5 * fix, 13.7, 110.0, 2, 2, 1, 3.0,
                                                  3, 7, 5, 40.0]))
    return out


def _write(tmp_path, lines, name="car.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def clean(tmp_path):
    path = _write(tmp_path, _lines(), "clean.csv")
    return datasets.read_balzer_csv(path), datasets.read_balzer_gnss(path)


@pytest.mark.parametrize("column, junk", [("yawrate", "nan"), ("yawrate", "oops"), ("ax", "inf"), ("millis", "nan")])
def test_one_bad_field_drops_that_row_names_line_and_column_and_no_nan_reaches_the_samples(tmp_path, clean, column,
                                                                                           junk):
    lines = _lines()
    fields = lines[201].split(",")
    fields[HEADER.split(",").index(column)] = junk
    lines[201] = ",".join(fields)
    imu = datasets.read_balzer_csv(_write(tmp_path, lines))
    assert np.all(np.isfinite(imu.gyro)) and np.all(np.isfinite(imu.accel))  # was: NaN in 2-3 samples, exit 0
    assert imu.damage and "car.csv" in imu.damage and "line 202" in imu.damage
    if junk != "oops":  # a field that is not a number at all is the CSV reader's bad row, named as it names them
        assert f"column {column!r}" in imu.damage
    assert len(imu) == len(clean[0])
    far = np.abs(imu.t - (200 * 0.02)) > 0.05  # away from the dropped row the samples are the clean ones
    np.testing.assert_array_equal(imu.gyro[far], clean[0].gyro[far])


def test_a_bad_row_after_blank_lines_is_named_by_its_own_line(tmp_path):
    lines = _lines()
    fields = lines[201].split(",")
    fields[HEADER.split(",").index("ax")] = "nan"
    lines[201] = ",".join(fields)
    lines[100:100] = ["", ""]  # blank lines are no rows, but they are lines of the file: the bad row is now line 204
    imu = datasets.read_balzer_csv(_write(tmp_path, lines))
    assert "line 204: column 'ax'" in imu.damage, imu.damage


def test_a_file_cut_mid_line_keeps_every_whole_row(tmp_path, clean):
    text = "\n".join(_lines()) + "\n"
    path = tmp_path / "cut.csv"
    path.write_text(text[: len(text) // 2 + 11])  # was: numpy's "Some errors were detected" without the file
    imu, gnss = datasets.read_balzer_csv(path), datasets.read_balzer_gnss(path)
    assert "cut.csv" in imu.damage and "skipped 1 bad row" in imu.damage
    n = len(imu)
    np.testing.assert_array_equal(imu.gyro, clean[0].gyro[:n])
    np.testing.assert_array_equal(gnss.t, clean[1].t[:len(gnss)])


@pytest.mark.parametrize("content, words", [("", "empty file"), (HEADER + "\n", "0 usable row"),
                                            (HEADER.replace("millis", "milis") + "\n1,2\n", "missing column")])
def test_an_empty_header_only_or_misnamed_file_is_a_recording_error_naming_it(tmp_path, content, words):
    path = tmp_path / "bad.csv"
    path.write_text(content)  # was: an IndexError traceback (empty, header only)
    for reader in (datasets.read_balzer_csv, datasets.read_balzer_gnss):
        with pytest.raises(RecordingError, match=f"bad.csv: .*{words}"):
            reader(path)


def test_a_row_stamped_back_is_dropped_and_named_and_a_clock_step_back_refuses_the_file(tmp_path, clean):
    lines = _lines()
    lines[201], lines[202] = lines[202], lines[201]
    imu = datasets.read_balzer_csv(_write(tmp_path, lines))
    assert "1 row(s) stamped before an earlier row dropped (line 203" in imu.damage
    assert np.all(np.diff(imu.t) > 0)
    lines = _lines()
    for k in range(200, N + 1):  # the logger's clock steps back 1 s: the times after it are not this file's
        f = lines[k].split(",")
        f[2] = f"{float(f[2]) - 1000.0:.6f}"
        lines[k] = ",".join(f)
    with pytest.raises(RecordingError, match=r"car.csv: 49 row\(s\) stamped before an earlier row.*not used"):
        datasets.read_balzer_csv(_write(tmp_path, lines))


def test_clean_rows_read_as_before_repeated_millis_dropped_without_a_word(tmp_path, clean):
    lines = _lines()
    lines.insert(100, lines[99])  # the logger repeats a row now and then
    imu, gnss = datasets.read_balzer_csv(_write(tmp_path, lines)), datasets.read_balzer_gnss(tmp_path / "car.csv")
    assert imu.damage is None and gnss.damage is None
    np.testing.assert_array_equal(imu.gyro, clean[0].gyro)
    np.testing.assert_array_equal(gnss.t, clean[1].t)
    assert len(clean[1]) == N // 5 and clean[0].rate_hz == pytest.approx(50.0)
