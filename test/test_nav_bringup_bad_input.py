"""``nav-demo`` on bad input: a missing or misspelt params file, a sensor model with a typo, something that is not
a bag, an unreadable truth are one line and exit 2 before any node starts (was: the graph started, a node died
with a configuration error or rcl's "Couldn't parse params file", and nav-demo exited 1)."""
import pytest
import yaml

from nav_bringup import demo
from nav_bringup.graph import GraphError
from nav_core import recording, sensor_model
from nav_core.recording import ImuRecording

import numpy as np


@pytest.fixture
def bag(tmp_path):
    n = 64 * 3
    rec = ImuRecording(1.7e9 + np.arange(n) / 64, np.zeros((n, 3)), np.tile([0, 0, 9.8], (n, 1)))
    return recording.write_bag(tmp_path / "bag", rec, storage="mcap")


@pytest.fixture
def no_graph(monkeypatch):
    def start(self, *args, **kwargs):
        raise AssertionError("the graph started before the inputs were checked")
    monkeypatch.setattr(demo.Graph, "start", start)
    monkeypatch.setattr(demo, "simulate_once", lambda *a, **k: (_ for _ in ()).throw(AssertionError("simulated")))


def _params(tmp_path, section):
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(section))
    return path


@pytest.mark.parametrize("case, words", [
    ("params_missing", ["nofile.yaml", "params file not found"]),
    ("params_typo", ["params.yaml", "alignment_tme_s", "did you mean 'alignment_time_s'"]),
    ("params_not_yaml", ["params.yaml", "not valid YAML"]),
    ("model_typo", ["model.yaml", "white_nois", "did you mean 'white_noise'"]),
    ("not_a_bag", ["empty_dir", "not a rosbag2 bag"]),
    ("truth_empty", ["truth.csv", "empty file"]),
])
def test_a_bad_input_file_is_one_line_and_exit_2_before_any_node_starts(tmp_path, bag, no_graph, capsys, case,
                                                                         words):
    argv = ["--recording", str(bag), "--out", str(tmp_path / "out")]
    if case == "params_missing":
        argv += ["--params", str(tmp_path / "nofile.yaml")]
    elif case == "params_typo":
        argv += ["--params", str(_params(tmp_path, {"ins_gps_kf_node": {"ros__parameters": {"alignment_tme_s": 2.0}}}))]
    elif case == "params_not_yaml":
        (tmp_path / "params.yaml").write_text("ins_gps_kf_node: [\n")
        argv += ["--params", str(tmp_path / "params.yaml")]
    elif case == "model_typo":
        model = sensor_model.save(sensor_model.SensorModel(), tmp_path / "model.yaml")
        model.write_text(model.read_text().replace("  white_noise:\n    value", "  white_nois:\n    value", 1))
        argv += ["--model", str(model)]
    elif case == "not_a_bag":
        (tmp_path / "empty_dir").mkdir()
        argv[1] = str(tmp_path / "empty_dir")
    elif case == "truth_empty":
        (tmp_path / "truth.csv").write_text("")
        argv += ["--truth", str(tmp_path / "truth.csv")]
    assert demo.main(argv) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("nav-demo: error:") and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_node_refusing_its_configuration_makes_nav_demo_exit_2(tmp_path, bag, monkeypatch, capsys):
    def start(self, *args, **kwargs):  # what Graph.start raises when a node exits 2 at start-up
        raise GraphError("wmra_node exited with code 2 before it was ready:\n[ERROR] configuration: ...", 2)
    monkeypatch.setattr(demo.Graph, "start", start)
    monkeypatch.setattr(demo.Graph, "stop", lambda self: {})
    assert demo.main(["--recording", str(bag), "--out", str(tmp_path / "out")]) == 2
    assert "exited with code 2" in capsys.readouterr().err


@pytest.mark.parametrize("broken", ["gnss.csv", "bp3010.bin"])
def test_scenario_player_on_an_empty_file_in_its_sim_dir_is_a_config_error_naming_it(tmp_path, rclpy_context, broken):
    from rclpy.parameter import Parameter

    from imu_driver.bp3010_codec import encode_stream
    from nav_bringup.scenario_player_node import ScenarioPlayer
    from nav_core.params import ConfigError

    (tmp_path / "bp3010.bin").write_bytes(encode_stream(np.zeros((64, 3)), np.tile([0, 0, 0.15], (64, 1))))
    recording.write_gnss_csv(tmp_path / "gnss.csv", recording.GnssRecording(
        np.arange(3.0), np.full(3, 0.8), np.full(3, 0.1), np.zeros(3), np.ones((3, 3))))
    (tmp_path / broken).write_bytes(b"")  # was: a RecordingError / ValueError traceback, exit 1
    with pytest.raises(ConfigError, match=f"parameter 'sim_dir': .*{broken}"):
        ScenarioPlayer(parameter_overrides=[Parameter("sim_dir", value=str(tmp_path)),
                                            Parameter("link", value=str(tmp_path / "port"))])


def test_the_report_of_a_run_that_never_aligned_says_the_imu_never_read_1_g(tmp_path):
    from nav_bringup.report import _no_odometry

    why = "IMU block ending at t=12.000 s reads |specific force| 1.002 m/s^2, not about 9.8: (accelerometer in g?)"
    diags = {"ins_gps_kf_node: ins_gps_kf": (0, "aligning", {"alignment": "0.0/45 s stationary",
                                                              "alignment_not_gravity": "12", "last_rejection": why})}
    text = _no_odometry(tmp_path, diags, {})  # was: "a run must last beyond that" on a 130-s bag in g
    assert why in text and "12 blocks refused" in text and "must last" not in text
    diags["ins_gps_kf_node: ins_gps_kf"][2]["alignment_not_gravity"] = "0"
    assert "must last beyond" in _no_odometry(tmp_path, diags, {})
