"""imu-calib allan and the time line (issue 16): stamps going back and gaps are errors naming the sample, or with
--split-at-gaps the longest unbroken segment is analysed and the YAML records what was skipped."""
import re

import numpy as np
import pytest

from imu_calib import synthetic
from imu_calib.allan import AllanError
from imu_calib.characterise import characterise
from imu_calib.cli import main
from imu_calib.timeline import timeline
from nav_core import sensor_model
from nav_core.recording import ImuRecording, write_imu_csv

MODEL = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)),
                                 accel=sensor_model.TriadModel(white_noise=np.full(3, 2e-3)), sample_rate_hz=20.0)


def _recording(seconds=300.0, seed=0):
    return synthetic.static_recording(MODEL, seconds, np.random.default_rng(seed))


def _with_stamps(rec, t):
    return ImuRecording(t, rec.gyro, rec.accel, source="edited.csv")


@pytest.mark.parametrize("gap_s", [3600.0, 1e6])
def test_a_gap_is_an_error_naming_its_length_and_sample(gap_s):
    rec = _recording()
    t = rec.t.copy()
    t[4000:] += gap_s
    with pytest.raises(AllanError, match=rf"gap.*{re.escape(f'{gap_s + 0.05:.6g}')} s at sample 4000"):
        characterise(_with_stamps(rec, t))


def test_time_going_backwards_is_an_error_naming_the_sample():
    rec = _recording()
    t = rec.t.copy()
    t[2500:] -= 30.0
    with pytest.raises(AllanError, match="time goes backwards 1 time.*sample 2500"):
        characterise(_with_stamps(rec, t))


def test_a_stamp_repeated_with_other_values_is_a_break_but_not_a_step_back():
    rec = _recording(30.0)
    t = rec.t.copy()
    t[100] = t[99]
    line = timeline(_with_stamps(rec, t))
    assert [i for i, _, _ in line.repeated] == [100] and line.backward_steps == [] and line.broken
    with pytest.raises(AllanError, match="stamp repeated with different values 1 time.*sample 100") as err:
        characterise(_with_stamps(rec, t))
    assert "backwards" not in str(err.value)


def test_split_analyses_the_longest_segment_and_the_yaml_records_what_was_skipped(tmp_path):
    rec = _recording(600.0, 1)
    t = rec.t.copy()
    t[3000:] += 3600.0  # 150 s, one hour of nothing, then 450 s
    t[9000:] -= 100.0  # and a step back 300 s into the second part
    csv = write_imu_csv(tmp_path / "broken.csv", _with_stamps(rec, t))
    out = tmp_path / "out"
    assert main(["allan", str(csv), "--out", str(out), "--no-progress"]) == 2
    assert not (out / "sensor_model.yaml").exists()
    assert main(["allan", str(csv), "--out", str(out), "--no-progress", "--split-at-gaps"]) == 0
    model = sensor_model.load(out / "sensor_model.yaml")
    prov = model.provenance
    assert prov["n_samples"] == 6000 and prov["n_samples_in_file"] == 12000
    assert prov["duration_s"] == pytest.approx(300.0)
    line = prov["timeline"]
    assert line["segments"] == 3 and line["gaps"] == 1 and line["backward_steps"] == 1
    assert line["skipped_samples"] == 6000
    assert line["gap_total_s"] == pytest.approx(3600.05)
    assert line["used"]["first_sample"] == 3000


def test_an_unbroken_record_has_no_timeline_entry():
    result = characterise(_recording(120.0, 2))
    assert result.timeline is None and "timeline" not in result.model.provenance
    assert result.model.provenance["duration_s"] == pytest.approx(120.0)
