"""imu-calib on the damage real recordings bring: NaN/inf samples, duplicated rows, repeated stamps, cut files,
empty files, bad cells, damaged archives, option typos. One line naming file, column and line (exit 2), or the
damage counted, skipped and recorded; never a traceback or a silent wrong answer."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import one_error_line
from imu_calib import characterise as char_mod
from imu_calib import cli, screen
from imu_calib.allan import AllanError
from imu_calib.timeline import timeline as timeline_of
from nav_core import datasets, recording, sensor_model
from nav_core.recording import ImuRecording, RecordingError

RATE = 100.0
N = 2000  # 20 s at 100 Hz: the Allan fit on it takes well under a second


def _rec(seed=0, z=9.8, t0=0.0):
    rng = np.random.default_rng(seed)
    return ImuRecording(t0 + np.arange(N) / RATE, rng.normal(0, 1e-3, (N, 3)),
                        rng.normal(0, 1e-2, (N, 3)) + [0, 0, z])


def _csv(tmp_path, name="imu.csv", rec=None):
    return recording.write_imu_csv(tmp_path / name, _rec() if rec is None else rec)


def _edit(path, line, column, text):
    """Set field ``column`` of 1-based ``line`` of a CSV to ``text``."""
    lines = path.read_text().splitlines()
    fields = lines[line - 1].split(",")
    fields[column] = text
    lines[line - 1] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    return path


def _allan(path, out, *extra):
    return cli.main(["allan", str(path), "--out", str(out), "--no-progress", *extra])


# -- allan: non-finite samples ----------------------------------------------------------------------------


@pytest.mark.parametrize("column,value,name", [(2, "nan", "gy"), (5, "inf", "ay"), (6, "-inf", "az")])
def test_a_non_finite_value_is_one_line_naming_file_column_line_time_and_split_option(tmp_path, capsys, column,
                                                                                       value, name):
    path = _edit(_csv(tmp_path, "nan.csv"), 702, column, value)  # line 702 = sample 700, t = 7 s
    assert _allan(path, tmp_path / "o") == 2
    one_error_line(capsys, "nan.csv", f"{name} 1", "sample 700", "line 702", "t = 7 s", "--split-at-gaps")
    assert not (tmp_path / "o").exists()


def test_split_at_gaps_breaks_the_record_at_a_non_finite_sample_and_records_it(tmp_path, capsys):
    path = _edit(_csv(tmp_path, "nan.csv"), 702, 2, "nan")
    assert _allan(path, tmp_path / "o", "--split-at-gaps") == 0
    assert "gy 1" in capsys.readouterr().err  # said on the terminal
    prov = sensor_model.load(tmp_path / "o" / "sensor_model.yaml").provenance
    line = prov["timeline"]
    assert line["non_finite_samples"] == 1 and line["non_finite_first"][0]["sample"] == 700
    assert line["used"] == {"first_sample": 701, "samples": N - 701, "from_s": 7.01, "to_s": 19.99}
    assert line["skipped_samples"] == 701 and prov["n_samples"] == N - 701 and prov["n_samples_in_file"] == N
    # exactly the analysis of the unbroken part after the NaN
    alone = char_mod.characterise(_rec().select(slice(701, None)))
    model = sensor_model.load(tmp_path / "o" / "sensor_model.yaml")
    np.testing.assert_allclose(model.gyro.white_noise, alone.model.gyro.white_noise, rtol=1e-9)


def test_a_nan_in_a_bag_is_named_by_its_message_field(tmp_path, capsys):
    rec = _rec(t0=1.7e9)
    rec.gyro[700, 1] = np.nan
    bag = recording.write_bag(tmp_path / "bag", rec, storage="mcap")
    assert _allan(bag, tmp_path / "o") == 2
    one_error_line(capsys, "bag", "gy (angular_velocity.y) 1", "sample 700", "t = 1700000007.000 s")


def test_a_live_nan_is_refused_by_the_node_core_without_split_and_breaks_the_record_with_it(tmp_path):
    rec = _rec()
    rec.gyro[1500, 2] = np.nan
    rec.source = "live imu/data_raw (2000 samples)"  # what allan_node hands its worker
    with pytest.raises(AllanError, match=r"gz \(angular_velocity.z\) 1.*sample 1500.*split_at_gaps"):
        char_mod.characterise_to_dir(rec, tmp_path / "a", split=False)
    values = char_mod.characterise_to_dir(rec, tmp_path / "b", split=True)
    assert values["non_finite_samples"] == 1 and values["samples"] == 1500
    assert "NaN or infinite" in values["warnings"]


# -- allan: duplicated rows and repeated stamps -------------------------------------------------------------


def test_an_exact_duplicate_row_is_dropped_counted_and_the_record_kept_whole(tmp_path, capsys):
    path = _csv(tmp_path, "dup.csv")
    lines = path.read_text().splitlines()
    lines.insert(702, lines[701])  # line 703 repeats line 702 (sample 700): a logging artefact
    path.write_text("\n".join(lines) + "\n")
    assert _allan(path, tmp_path / "o") == 0
    err = capsys.readouterr().err
    assert "dropped 1 exact duplicate row" in err and "sample 701 (line 703, t = 7 s)" in err
    assert "backwards" not in err
    model = sensor_model.load(tmp_path / "o" / "sensor_model.yaml")
    assert model.provenance["n_samples"] == N and model.provenance["timeline"]["exact_duplicates_dropped"] == 1
    clean = char_mod.characterise(_rec())
    np.testing.assert_allclose(model.gyro.white_noise, clean.model.gyro.white_noise, rtol=1e-9)


def test_a_repeated_stamp_with_other_values_is_refused_as_repeated_and_split_with_the_option(tmp_path, capsys):
    path = _csv(tmp_path, "rep.csv")
    lines = path.read_text().splitlines()
    fields = lines[701].split(",")
    fields[1] = "0.5"
    lines.insert(702, ",".join(fields))  # same stamp as sample 700, other values
    path.write_text("\n".join(lines) + "\n")
    assert _allan(path, tmp_path / "o") == 2
    line = one_error_line(capsys, "rep.csv", "stamp repeated with different values 1 time", "sample 701",
                           "line 703", "--split-at-gaps")
    assert "backwards" not in line
    assert _allan(path, tmp_path / "o", "--split-at-gaps") == 0
    prov = sensor_model.load(tmp_path / "o" / "sensor_model.yaml").provenance
    assert prov["timeline"]["repeated_stamps"] == 1 and prov["timeline"]["backward_steps"] == 0


# -- calibrations -------------------------------------------------------------------------------------------


def _up_down(tmp_path):
    up = _csv(tmp_path, "up.csv", _rec(1, 9.81))
    down = _csv(tmp_path, "down.csv", _rec(2, -9.81))
    return up, down


def _two_position(up, down, out):
    return cli.main(["two-position", "--up", str(up), "--down", str(down), "--axis", "z", "--lat-deg", "45",
                     "--out", str(out)])


def test_two_position_leaves_non_finite_samples_out_of_its_means_and_says_so(tmp_path, capsys):
    up, down = _up_down(tmp_path)
    assert _two_position(up, down, tmp_path / "clean.yaml") == 0
    lines = up.read_text().splitlines()
    clean_lines = lines[:501] + lines[502:]  # the file without line 502
    (tmp_path / "up_less.csv").write_text("\n".join(clean_lines) + "\n")
    assert _two_position(tmp_path / "up_less.csv", down, tmp_path / "less.yaml") == 0
    _edit(up, 502, 3, "nan")  # gz of sample 500
    _edit(up, 502, 6, "inf")  # az of the same sample
    _edit(up, 900, 1, "nan")  # gx: not a column of the z calibration, kept
    capsys.readouterr()
    assert _two_position(up, down, tmp_path / "nan.yaml") == 0
    err = capsys.readouterr().err
    assert "up.csv: 1 sample(s) with a NaN or infinite value (by column: gz 1, az 1), first at sample 500 " \
           "(line 502, t = 5 s); those samples were left out of the means" in err
    got, want = sensor_model.load(tmp_path / "nan.yaml"), sensor_model.load(tmp_path / "less.yaml")
    assert got.accel.bias[2] == want.accel.bias[2] and got.gyro.bias[2] == want.gyro.bias[2]
    assert np.isfinite(got.gyro.bias[2]) and got.gyro.bias[2] != sensor_model.load(tmp_path / "clean.yaml").gyro.bias[2]


def _rate_table(rec1, rec2, out):
    return cli.main(["rate-table", "--rec1", str(rec1), "--rate1-dps", "10", "--rec2", str(rec2), "--rate2-dps",
                     "-10", "--axis", "x", "--lat-deg", "45", "--out", str(out)])


def test_rate_table_leaves_a_non_finite_sample_of_its_axis_out_and_says_so(tmp_path, capsys):
    turning = [_rec(1), _rec(2)]
    for rec, rate in zip(turning, (10.0, -10.0)):
        rec.gyro[:, 0] += np.radians(rate)
    rec1, rec2 = _csv(tmp_path, "r1.csv", turning[0]), _csv(tmp_path, "r2.csv", turning[1])
    lines = rec1.read_text().splitlines()
    (tmp_path / "r1_less.csv").write_text("\n".join(lines[:301] + lines[302:]) + "\n")
    assert _rate_table(tmp_path / "r1_less.csv", rec2, tmp_path / "less.yaml") == 0
    _edit(rec1, 302, 1, "nan")
    capsys.readouterr()
    assert _rate_table(rec1, rec2, tmp_path / "m.yaml") == 0
    assert "r1.csv: 1 sample(s) with a NaN or infinite value (by column: gx 1), first at sample 300 (line 302" \
        in capsys.readouterr().err
    got, want = sensor_model.load(tmp_path / "m.yaml").gyro, sensor_model.load(tmp_path / "less.yaml").gyro
    assert got.scale_factor[0] == want.scale_factor[0] and got.bias[0] == want.bias[0]


def test_rate_table_refuses_recordings_that_do_not_show_the_table_rates(tmp_path, capsys):
    up, down = _up_down(tmp_path)  # static: no rate difference, a scale factor of -1 would be written
    assert _rate_table(up, down, tmp_path / "m.yaml") == 2
    one_error_line(capsys, "differ by 20 deg/s", "must be > -1")
    assert not (tmp_path / "m.yaml").exists()


def test_multi_position_refuses_a_non_finite_sample_naming_file_column_and_line(tmp_path, capsys):
    path = _edit(_csv(tmp_path, "mp.csv"), 1002, 4, "nan")
    assert cli.main(["multi-position", str(path), "--gravity", "9.81", "--out", str(tmp_path / "m.yaml")]) == 2
    one_error_line(capsys, "mp.csv", "ax 1", "sample 1000", "line 1002", "steps through every sample")
    assert not (tmp_path / "m.yaml").exists()


def test_multi_position_leaves_a_move_whose_stamps_break_out_of_the_gyro_fit():
    from test_imu_calib_gyro_multi_position import GYRO_MIS, GYRO_SCALE, LAT, _recording

    from imu_calib.multi_position import multi_position
    from nav_core.earth import normal_gravity

    rec, n_pos = _recording(1)
    lost = (rec.t >= 60.8) & (rec.t < 61.1)  # 0.3 s missing in the middle of move 5 (60-62 s)
    res = multi_position(rec.select(~lost), gravity=normal_gravity(LAT))
    assert [k for k, _, _ in res.moves_skipped] == [5] and res.moves_skipped[0][2] == pytest.approx(61.1)
    assert res.gyro.n_moves == n_pos - 2
    # integrated across the gap, that move cost 0.019 rad of misalignment; left out, the fit keeps its accuracy
    np.testing.assert_allclose(res.gyro.scale_factor, GYRO_SCALE, atol=1e-3)
    np.testing.assert_allclose(res.gyro.misalignment, GYRO_MIS, atol=1e-3)


# -- files cut, empty or not what they claim -------------------------------------------------------------


def test_a_last_line_without_line_end_is_not_used_and_said(tmp_path, capsys):
    path = _csv(tmp_path, "cut.csv")
    text = path.read_text()
    path.write_text(text[:text.rindex(".") + 1])  # "...,9.80312" cut to "...,9." still parses: a wrong value
    rec = cli.load_recording(path)
    assert len(rec) == N - 1
    np.testing.assert_allclose(rec.accel, _rec().accel[:-1], rtol=1e-13)  # the CSV keeps 15 digits
    assert f"line {N + 1}, the last, has no line end" in capsys.readouterr().err


@pytest.mark.parametrize("text,words", [("", ["empty file"]), ("t,gx,gy,gz,ax,ay,az\n", ["0 sample(s)", "header"]),
                                        ("t,gx,gy,gz,ax,ay,az", ["0 sample(s)"])])
def test_an_empty_or_header_only_file_is_one_line_naming_the_file(tmp_path, capsys, text, words):
    path = tmp_path / "bare.csv"
    path.write_text(text)
    assert _allan(path, tmp_path / "o") == 2
    one_error_line(capsys, "bare.csv", *words)


def test_a_non_numeric_cell_is_skipped_and_named_by_line_and_column(tmp_path):
    path = _edit(_csv(tmp_path), 702, 3, "abc")
    rec = recording.read_imu(path)
    assert len(rec) == N - 1 and rec.skipped_rows == (702,)
    assert "line 702: column 'gz': 'abc' is not a number" in rec.damage


def test_a_column_name_typo_is_one_line_naming_the_missing_column_and_the_header(tmp_path, capsys):
    path = _csv(tmp_path, "typo.csv")
    path.write_text(path.read_text().replace("gy", "gyy", 1))
    assert _allan(path, tmp_path / "o") == 2
    one_error_line(capsys, "typo.csv", "missing column(s) ['gy']", "'gyy'")


def _ucalgary(path, rec):
    rows = np.column_stack([rec.t, np.degrees(rec.gyro), rec.accel])
    np.savetxt(path, rows, fmt="%.7e")
    return path


def test_a_text_format_skips_a_bad_cell_and_a_cut_last_row_naming_line_and_column(tmp_path, capsys):
    path = _ucalgary(tmp_path / "x_up.txt", _rec())
    lines = path.read_text().splitlines()
    fields = lines[100].split()
    fields[2] = "abc"
    lines[100] = " ".join(fields)
    text = "\n".join(lines)
    path.write_text(text[:text.rindex(" ") + 3])  # the last row cut after its last value's first digit
    rec = datasets.load_ucalgary_updown(path)
    assert len(rec) == N - 1 and rec.skipped_rows == (101,)
    assert "line 101: column '3': 'abc' is not a number" in rec.damage
    rec = cli.load_recording(path, fmt="ucalgary")
    assert len(rec) == N - 2  # and the cut last row is not used
    err = capsys.readouterr().err
    assert "line 101" in err and f"line {N}, the last, has no line end" in err
    (tmp_path / "empty.txt").write_text("")
    with pytest.raises(RecordingError, match="empty.txt: no rows of 7"):
        datasets.load_ucalgary_updown(tmp_path / "empty.txt")


@pytest.mark.parametrize("content", [b"", b"hello\n", "cut"])
def test_a_damaged_npz_is_one_line_naming_the_file(tmp_path, capsys, content):
    path = tmp_path / "imu1.npz"
    if content == "cut":
        np.savez(path, gyro_counts=np.zeros((5000, 3), np.int16), accel_counts=np.zeros((5000, 3), np.int16),
                 gyro_lsb_dps=0.05, accel_lsb_g=0.00333, rate_hz=100.0)
        content = path.read_bytes()[:20000]
    path.write_bytes(content)
    assert _allan(path, tmp_path / "o", "--format", "adis") == 2
    one_error_line(capsys, "imu1.npz", "not a readable .npz")


def test_allan_reads_imutk_with_its_gyro_file_and_gyro_file_is_refused_for_other_formats(tmp_path, capsys):
    rec = _rec()
    for name, data in (("acc.mat", rec.accel), ("gyro.mat", rec.gyro)):
        np.savetxt(tmp_path / name, np.column_stack([rec.t, data]))
    assert _allan(tmp_path / "acc.mat", tmp_path / "o", "--format", "imutk", "--gyro-file",
                  str(tmp_path / "gyro.mat")) == 0
    assert sensor_model.load(tmp_path / "o" / "sensor_model.yaml").provenance["n_samples"] == N
    csv = _csv(tmp_path)
    assert _allan(csv, tmp_path / "p", "--gyro-file", str(tmp_path / "gyro.mat")) == 2
    one_error_line(capsys, "--gyro-file", "only --format imutk")


@pytest.mark.parametrize("argv,hint", [(["--split-at-gapz"], "'--split-at-gaps'"), (["--formt", "adis"], "'--format'"),
                                       (["--base-modle", "m.yaml"], "'--base-model'")])
def test_an_option_typo_is_a_usage_error_naming_the_closest_option(tmp_path, capsys, argv, hint):
    with pytest.raises(SystemExit) as exit_:
        _allan(_csv(tmp_path), tmp_path / "o", *argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"did you mean {hint}" in err and "unrecognized arguments" in err and "Traceback" not in err


def test_an_existing_model_that_is_not_valid_fails_before_the_calibration(tmp_path, capsys, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("calibrated before reading the existing --out")
    monkeypatch.setattr(cli.multi_position, "multi_position", forbidden)
    out = tmp_path / "m.yaml"
    out.write_text("garbage: [\n")
    assert cli.main(["multi-position", str(_csv(tmp_path)), "--gravity", "9.81", "--out", str(out)]) == 2
    one_error_line(capsys, "m.yaml", "YAML")
    assert out.read_text() == "garbage: [\n"


def test_lines_stay_the_files_after_duplicates_are_dropped(tmp_path):
    path = _csv(tmp_path)
    lines = path.read_text().splitlines()
    lines.insert(11, lines[10])  # an exact duplicate of line 11 (sample 9) at line 12
    path.write_text("\n".join(lines) + "\n")
    rec, notes = screen.refuse_non_finite(recording.read_imu(path), "why")
    assert len(rec) == N and "sample 10 (line 12" in notes[0]
    assert screen.where(rec, 700) == "sample 700 (line 703, t = 7 s)"  # sample 700 of what is left


def test_screen_names_the_line_of_a_sample_after_blank_and_skipped_rows(tmp_path):
    path = _csv(tmp_path)
    lines = path.read_text().splitlines()
    lines.insert(10, "")  # a blank line (not a sample) and a bad row (skipped) before sample 700
    lines.insert(20, "1,2,three,4,5,6,7")
    path.write_text("\n".join(lines) + "\n")
    rec = recording.read_imu(path)
    assert screen.where(rec, 700) == "sample 700 (line 704, t = 7 s)"
    assert lines[703].startswith("7,")


# -- allan_node: a NaN in the live stream --------------------------------------------------------------------


@pytest.mark.ros
@pytest.mark.slow
def test_allan_node_counts_a_live_nan_sample_and_analyses_the_longest_finite_segment(tmp_path, ros_env,
                                                                                      rclpy_context):
    import time

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import Imu

    from imu_calib import synthetic
    from nav_core.processes import NodeProcess
    from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays

    model = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)),
                                     accel=sensor_model.TriadModel(white_noise=np.full(3, 2e-3)), sample_rate_hz=50.0)
    out = tmp_path / "live"
    node = NodeProcess("allan_node", env=ros_env, ros_args={"duration_s": 4.0, "out_dir": str(out),
                                                            "diagnostics_period_s": 0.2})
    statuses = []
    try:
        probe = Probe({"/diagnostics": DiagnosticArray})
        probe.create_subscription(DiagnosticArray, "/diagnostics",
                                  lambda arr: statuses.extend(s for s in arr.status if "allan_node" in s.name), 50)
        feeder = rclpy.create_node("feeder")
        pub = feeder.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
        assert probe.spin_until(lambda p: pub.get_subscription_count() > 0, 20), node.output
        rec = synthetic.static_recording(model, 6.0, np.random.default_rng(0), t0=1000.0)
        rec.gyro[60, 1] = np.nan  # 1.2 s in: the segment after it is the longest
        for t, g, a in zip(rec.t, rec.gyro, rec.accel):
            pub.publish(imu_from_arrays(t, g, a))
            rclpy.spin_once(probe, timeout_sec=0.0)
            time.sleep(0.004)
        done = lambda p: any(s.message not in ("collecting", "characterising") for s in statuses)
        assert probe.spin_until(done, 30), node.output
        feeder.destroy_node()
        probe.destroy_node()
    finally:
        node.stop()
    assert "Traceback" not in node.output, node.output  # the NaN did not kill the node or its worker
    values = lambda s: {kv.key: kv.value for kv in s.values}
    collecting = [values(s) for s in statuses if s.message == "collecting"]
    assert any(v.get("non_finite_samples") == "1" for v in collecting), collecting[-3:]
    final = next(s for s in statuses if s.message not in ("collecting", "characterising"))
    assert final.level == DiagnosticStatus.OK, final.message
    v = values(final)
    assert v["non_finite_samples"] == "1" and "angular_velocity.y" in v["warnings"]
    assert 1 <= int(v["skipped_samples"]) <= 61  # those received before the NaN (best effort) and the NaN
    assert 150 <= int(v["samples"]) + int(v["skipped_samples"]) <= 202  # 4 s of stamps at 50 Hz, best effort
    assert sensor_model.load(out / "sensor_model.yaml").provenance["timeline"]["non_finite_samples"] == 1


@pytest.mark.parametrize("option,value", [("--lat-deg", "200"), ("--lat-deg", "nan"), ("--height-m", "inf")])
def test_a_site_out_of_range_is_a_usage_error_not_a_model(tmp_path, capsys, option, value):
    up, down = _up_down(tmp_path)  # --lat-deg 200 and nan wrote a model before
    argv = ["two-position", "--up", str(up), "--down", str(down), "--axis", "z", "--lat-deg", "45",
            "--out", str(tmp_path / "m.yaml"), f"{option}={value}"]
    with pytest.raises(SystemExit) as exit_:
        cli.main(argv)
    assert exit_.value.code == 2 and option in capsys.readouterr().err
    assert not (tmp_path / "m.yaml").exists()


@pytest.mark.parametrize("command", ["two-position", "rate-table", "multi-position"])
def test_an_unwritable_out_fails_before_any_calibration(tmp_path, capsys, monkeypatch, command):
    def forbidden(*args, **kwargs):
        raise AssertionError("calibrated before checking --out")
    for name in ("two_position_from_recordings", "rate_table", "multi_position"):
        for mod in (cli.two_position, cli.rate_table, cli.multi_position):
            if hasattr(mod, name):
                monkeypatch.setattr(mod, name, forbidden)
    up, down = _up_down(tmp_path)
    out = "/proc/nav_bad_input_test/m.yaml"  # not creatable, even as root
    argv = {"two-position": ["--up", str(up), "--down", str(down), "--axis", "z", "--lat-deg", "45"],
            "rate-table": ["--rec1", str(up), "--rate1-dps", "10", "--rec2", str(down), "--rate2-dps", "-10",
                           "--axis", "x", "--lat-deg", "45"],
            "multi-position": [str(up), "--gravity", "9.81"]}[command]
    assert cli.main([command, *argv, "--out", out]) == 2
    one_error_line(capsys, "/proc/nav_bad_input_test")


def test_a_non_finite_stamp_in_a_text_format_is_a_break_named_by_column_t(tmp_path, capsys):
    path = _ucalgary(tmp_path / "x_up.txt", _rec())
    lines = path.read_text().splitlines()
    lines[500] = "nan " + lines[500].split(None, 1)[1]
    path.write_text("\n".join(lines) + "\n")
    assert _allan(path, tmp_path / "o", "--format", "ucalgary") == 2
    one_error_line(capsys, "x_up.txt", "by column: t 1", "sample 500 (line 501, t = nan after 4.99 s)")


@settings(max_examples=60, deadline=None)
@given(n=st.integers(20, 300),
       events=st.lists(st.tuples(st.sampled_from(["nan", "inf_t", "dup", "repeat", "gap"]), st.integers(0, 299),
                                 st.integers(0, 5)), max_size=6, unique_by=lambda e: e[1]))
def test_timeline_segments_hold_every_finite_sample_once_and_nothing_broken(n, events):
    t = np.arange(n) / RATE
    v = np.random.default_rng(n).normal(0, 1, (n, 6))
    for kind, i, col in sorted(events, key=lambda e: e[1]):
        if i >= n or i == 0:
            continue
        if kind == "nan":
            v[i, col] = np.nan
        elif kind == "inf_t":
            t[i] = np.inf
        elif kind == "dup":
            t[i], v[i] = t[i - 1], v[i - 1]
        elif kind == "repeat":
            t[i] = t[i - 1]
        else:
            t[i:] += 0.5
    rec = ImuRecording(t, v[:, :3], v[:, 3:])
    try:
        line = timeline_of(rec)
    except AllanError:
        return  # too few usable samples, or too irregular: refused with a message
    bad = screen.non_finite_rows(rec)
    dup = screen.exact_duplicates(rec)
    used = [i for a, b in line.segments for i in range(a, b) if not dup[i]]
    assert sorted(used) == used and len(set(used)) == len(used)
    assert set(used) == set(np.flatnonzero(~bad & ~dup))  # every finite, non-duplicate sample, once
    for seg in line.segments:
        part = line.select(rec, seg)
        assert np.all(np.isfinite(screen.values(part))) and np.all(np.isfinite(part.t))
        dt = np.diff(part.t)
        assert np.all(dt > 0) and np.all(dt <= 1.5 * np.median(np.diff(rec.t[~bad & ~dup])) + 1e-12)
    assert line.broken == bool(bad.any() or len(line.segments) > 1)


def test_imutk_pairs_the_two_files_by_stamp_when_one_loses_a_row(tmp_path):
    rec = _rec()
    for name, data in (("acc.mat", rec.accel), ("gyro.mat", rec.gyro)):
        np.savetxt(tmp_path / name, np.column_stack([rec.t, data]))
    lines = (tmp_path / "gyro.mat").read_text().splitlines()
    lines[300] = lines[300][:20]  # a cut row in the gyro file only
    (tmp_path / "gyro.mat").write_text("\n".join(lines) + "\n")
    both = datasets.load_imutk(tmp_path / "acc.mat", tmp_path / "gyro.mat")
    assert len(both) == N - 1 and "gyro.mat" in both.damage and "line 301" in both.damage
    keep = np.arange(N) != 300
    np.testing.assert_array_equal(both.t, rec.t[keep])
    np.testing.assert_allclose(both.gyro, rec.gyro[keep], rtol=1e-15)
    np.testing.assert_allclose(both.accel, rec.accel[keep], rtol=1e-15)
