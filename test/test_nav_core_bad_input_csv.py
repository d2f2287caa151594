"""The recording CSVs as users bring them: a byte-order mark, a misspelt column, a status that is not a
NavSatStatus; each is read or refused with the file and the column named."""
import numpy as np
import pytest

from nav_core import recording as rec_io
from nav_core.recording import GnssRecording, ImuRecording, RecordingError


def _imu(n=200):
    rng = np.random.default_rng(0)
    return ImuRecording(np.arange(1, n + 1) / 64, rng.normal(0, 0.01, (n, 3)), rng.normal(0, 0.1, (n, 3)) + [0, 0, 9.8])


def _gnss(n=30):
    return GnssRecording(np.arange(n, dtype=float), np.full(n, 0.8), np.full(n, 0.1), np.zeros(n), np.ones((n, 3)),
                         np.zeros(n, dtype=int))


def test_a_csv_saved_with_a_byte_order_mark_reads_as_without(tmp_path):
    path = rec_io.write_imu_csv(tmp_path / "imu.csv", _imu())
    path.write_text("\ufeff" + path.read_text(), encoding="utf-8")  # as Excel's "CSV UTF-8" writes it
    back = rec_io.read_imu(path)  # was: "missing column(s) ['t']; header is ['\ufefft', ...]"
    np.testing.assert_allclose(back.gyro, _imu().gyro, rtol=1e-12)
    assert back.damage is None


@pytest.mark.parametrize("wrong, right", [("gzz", "gz"), ("long_deg", "lon_deg"), ("std_E", "std_e")])
def test_a_misspelt_column_is_named_with_the_one_meant(tmp_path, wrong, right):
    path = (rec_io.write_imu_csv(tmp_path / "x.csv", _imu()) if right == "gz"
            else rec_io.write_gnss_csv(tmp_path / "x.csv", _gnss()))
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace(right, wrong)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=f"x.csv: missing column.*'{right}' did you mean '{wrong}'"):
        rec_io.read_imu(path) if right == "gz" else rec_io.read_gnss(path)


@pytest.mark.parametrize("value", ["nan", "0.5", "7", "-3"])
def test_a_status_that_is_not_a_navsatstatus_makes_that_fix_no_fix_and_is_named(tmp_path, value):
    path = rec_io.write_gnss_csv(tmp_path / "gnss.csv", _gnss())
    lines = path.read_text().splitlines()
    fields = lines[11].split(",")
    fields[-1] = value
    lines[11] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    back = rec_io.read_gnss(path)  # was: 0.5 read as 0 (a valid fix), NaN cast to a huge negative int with a warning
    assert back.status[10] == -1 and np.all(np.delete(back.status, 10) == 0)
    assert "gnss.csv" in back.damage and "t = 10 s" in back.damage and "taken as no fix" in back.damage
