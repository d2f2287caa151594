"""Every CLI on bad input: one line and exit 2, never a traceback (unless --debug); outputs checked first, never
half-overwritten."""


import numpy as np  # noqa: E402
import pytest  # noqa: E402

from conftest import one_error_line  # noqa: E402
from imu_calib import cli as calib_cli  # noqa: E402
from imu_sim import cli as sim_cli  # noqa: E402
from ins_gps_kf import replay as kf_cli  # noqa: E402
from nav_bringup import convert as convert_cli  # noqa: E402
from nav_core import recording, sensor_model  # noqa: E402
from nav_core.recording import ImuRecording  # noqa: E402
from wmra_filter import report as wmra_report  # noqa: E402

UNWRITABLE = "/proc/nav_bad_input_test/out"  # not creatable, even as root
SCENARIO = """latitude_deg: 30
longitude_deg: 1
segments:
  - {type: stand, duration_s: 3}
  - {type: accelerate, duration_s: 3, speed_mps: 2}
"""


@pytest.fixture
def scenario(tmp_path):
    path = tmp_path / "scenario.yaml"
    path.write_text(SCENARIO)
    return path


def _static_csv(path, seconds=150.0, rate=64.0, seed=0):
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    rec = ImuRecording(np.arange(n) / rate, rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-2, (n, 3)) + [0, 0, 9.8])
    return recording.write_imu_csv(path, rec)


# -- recordings through the CLIs -------------------------------------------------------------------------


def test_a_20_byte_mcap_is_one_line_in_both_clis(tmp_path, capsys):
    tiny = tmp_path / "tiny.mcap"
    tiny.write_bytes(b"\x89MCAP0\r\n" + bytes(12))
    assert calib_cli.main(["allan", str(tiny), "--out", str(tmp_path / "a"), "--no-progress"]) == 2
    one_error_line(capsys, "tiny.mcap")
    model = sensor_model.save(sensor_model.SensorModel(), tmp_path / "m.yaml")
    assert kf_cli.main(["replay", "--recording", str(tiny), "--model", str(model), "--out",
                        str(tmp_path / "t.csv"), "--quiet"]) == 2
    one_error_line(capsys, "tiny.mcap")


def test_a_truncated_sqlite_bag_without_the_topic_is_exit_2_naming_topic_and_topics(tmp_path, capsys):
    n = 64 * 60
    rec = ImuRecording(1.7e9 + np.arange(n) / 64, np.zeros((n, 3)), np.tile([0, 0, 9.8], (n, 1)))
    bag = recording.write_bag(tmp_path / "bag", rec, storage="sqlite3")
    db = next(bag.glob("*.db3"))
    with open(db, "r+b") as fh:
        fh.truncate(db.stat().st_size // 2)
    model = sensor_model.save(sensor_model.SensorModel(), tmp_path / "m.yaml")
    code = kf_cli.main(["replay", "--recording", str(bag), "--model", str(model), "--out", str(tmp_path / "t.csv"),
                        "--quiet"])
    assert code == 2
    one_error_line(capsys, "imu/data_corrected", "imu/data_raw")
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("cli, option", [("replay", "--imu-topic"), ("replay", "--gps-topic"), ("allan", "--topic")])
def test_a_topic_given_with_a_csv_is_exit_2_naming_file_and_option_not_silently_ignored(tmp_path, capsys, cli, option):
    csv = _static_csv(tmp_path / "imu.csv", seconds=5)
    if cli == "replay":
        argv = ["replay", "--recording", str(csv), "--model", "default", "--out", str(tmp_path / "t.csv"), "--quiet",
                option, "imu/other"]
        code = kf_cli.main(argv)
    else:
        code = calib_cli.main(["allan", str(csv), "--out", str(tmp_path / "a"), "--no-progress", option, "imu/other"])
    assert code == 2  # was: the topic silently ignored and the CSV read
    one_error_line(capsys, "imu.csv", f"{option} imu/other", "not a rosbag2 bag")
    assert not (tmp_path / "t.csv").exists() and not (tmp_path / "a").exists()


def test_allan_skips_one_bad_row_and_refuses_a_mostly_bad_csv(tmp_path, capsys, monkeypatch):
    import imu_calib.characterise
    seen = []

    def characterise(rec, **kwargs):  # what the noise fit is given is the point here, not the fit
        seen.append(len(rec))
        raise ValueError("stopped after reading")
    monkeypatch.setattr(imu_calib.characterise, "characterise", characterise)
    path = _static_csv(tmp_path / "imu.csv", seconds=40.0)
    lines = path.read_text().splitlines()
    n = len(lines) - 1
    lines.insert(100, "0.1,0.2,oops,0,0,0,9.8")  # a corrupt line between two good ones: no gap in time
    path.write_text("\n".join(lines) + "\n")
    assert calib_cli.main(["allan", str(path), "--out", str(tmp_path / "one"), "--no-progress"]) == 2
    out = capsys.readouterr()
    assert seen == [n]  # every good row; was: the 99 before the bad one
    assert "line 101" in out.err and "skipped 1 bad row" in out.err
    for k in range(200, 300):
        lines[k] = "garbage"
    path.write_text("\n".join(lines) + "\n")
    assert calib_cli.main(["allan", str(path), "--out", str(tmp_path / "many"), "--no-progress"]) == 2
    one_error_line(capsys, "imu.csv", "101 bad row", "not used")
    assert seen == [n]  # refused before the fit
    assert not (tmp_path / "many").exists()


# -- outputs ----------------------------------------------------------------------------------------------


def test_simulate_into_an_existing_folder_changes_nothing_and_force_replaces_it_whole(tmp_path, scenario, capsys,
                                                                                     monkeypatch):
    monkeypatch.setattr(sim_cli, "overview_png", lambda res, path: (path.write_bytes(b"png"), path)[1])
    out = tmp_path / "sim"
    assert sim_cli.main(["simulate", "--scenario", str(scenario), "--out", str(out), "--format", "csv"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    assert sim_cli.main(["simulate", "--scenario", str(scenario), "--out", str(out), "--seed", "5"]) == 2
    one_error_line(capsys, str(out), "--force")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing overwritten, no bag added
    assert sim_cli.main(["simulate", "--scenario", str(scenario), "--out", str(out), "--seed", "5", "--force"]) == 0
    assert (out / "bag").is_dir() and "seed: 5" in (out / "sim_info.yaml").read_text()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folder left


@pytest.mark.parametrize("target", ["file", "unwritable"])
def test_a_bad_out_fails_before_any_computation_in_every_cli(tmp_path, scenario, monkeypatch, capsys, target):
    import imu_calib.characterise
    import nav_bringup.convert
    import wmra_filter.evaluation

    def forbidden(*args, **kwargs):
        raise AssertionError("computed before checking --out")

    monkeypatch.setattr(sim_cli, "simulate", forbidden)
    monkeypatch.setattr(imu_calib.characterise, "characterise", forbidden)
    monkeypatch.setattr(kf_cli, "replay_files", forbidden)
    monkeypatch.setattr(nav_bringup.convert, "convert", forbidden)
    monkeypatch.setattr(wmra_filter.evaluation, "rate_table_run", forbidden)
    afile = tmp_path / "afile"
    afile.write_text("mine\n")
    out = str(afile) if target == "file" else UNWRITABLE
    csv = _static_csv(tmp_path / "imu.csv", seconds=5)
    calls = [
        (sim_cli.main, ["simulate", "--scenario", str(scenario), "--out", out]),
        (calib_cli.main, ["allan", str(csv), "--out", out, "--no-progress"]),
        (kf_cli.main, ["replay", "--recording", str(csv), "--model", "default", "--out",
                       str(tmp_path) if target == "file" else UNWRITABLE + ".csv", "--quiet"]),
        (convert_cli.main, ["katwijk", "--out", out]),
        (wmra_report.main, ["--out", out]),
    ]
    for main, argv in calls:
        assert main(argv) == 2, argv
        one_error_line(capsys, "error")
    assert afile.read_text() == "mine\n"


def test_replay_refuses_to_overwrite_its_output_unless_forced(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    out.write_text("precious\n")
    csv = _static_csv(tmp_path / "imu.csv", seconds=5)
    assert kf_cli.main(["replay", "--recording", str(csv), "--model", "default", "--out", str(out)]) == 2
    one_error_line(capsys, "traj.csv", "--force")
    assert out.read_text() == "precious\n"


def test_allan_refuses_a_non_empty_out_folder(tmp_path, capsys):
    out = tmp_path / "allan"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    csv = _static_csv(tmp_path / "imu.csv", seconds=5)
    assert calib_cli.main(["allan", str(csv), "--out", str(out), "--no-progress"]) == 2
    one_error_line(capsys, "not empty", "--force")
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


# -- values and --debug -------------------------------------------------------------------------------------


@pytest.mark.parametrize("rate", ["-5", "0", "inf", "1e9", "nan", "abc"])
def test_rate_hz_out_of_range_is_a_usage_error(tmp_path, scenario, capsys, rate):
    with pytest.raises(SystemExit) as exit_:
        sim_cli.main(["simulate", "--scenario", str(scenario), "--out", str(tmp_path / "o"), f"--rate-hz={rate}"])
    assert exit_.value.code == 2
    assert "--rate-hz" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_scenario_typo_is_one_line_naming_file_segment_key_and_suggestion(tmp_path, capsys):
    path = tmp_path / "typo.yaml"
    path.write_text(SCENARIO.replace("speed_mps", "speed"))
    assert sim_cli.main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "o")]) == 2
    one_error_line(capsys, "typo.yaml", "segments[1]", "'speed'", "did you mean 'speed_mps'")
    assert not (tmp_path / "o").exists()


def test_debug_shows_the_traceback_and_a_bug_is_one_line_exit_1(tmp_path, scenario, monkeypatch, capsys):
    path = tmp_path / "typo.yaml"
    path.write_text(SCENARIO.replace("speed_mps", "speed"))
    from imu_sim.scenario import ScenarioError
    with pytest.raises(ScenarioError, match="did you mean"):
        sim_cli.main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "o"), "--debug"])

    def bug(*args, **kwargs):
        raise ZeroDivisionError("a bug")
    monkeypatch.setattr(sim_cli, "simulate", bug)
    assert sim_cli.main(["simulate", "--scenario", str(scenario), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "internal error: ZeroDivisionError: a bug" in err and "--debug" in err and "Traceback" not in err
