"""One description of the graph: the launch file, nav-demo and the tests start the same nodes; a valid scenario
or params file behaves the same through every entry point (a scenario without height_m, a ``/**`` params file)."""
import argparse
import importlib.util
import sys
import types
from pathlib import Path

import pytest

from ins_gps_kf import config as kfconfig
from nav_bringup import demo
from nav_bringup.description import GraphInputs, navigation_graph, scenario_datum
from nav_bringup.graph import REPO
from nav_bringup.truth import TruthTrack

LAUNCH = REPO / "src" / "nav_bringup" / "launch" / "navigation.launch.py"
SEGMENTS = "segments:\n  - {type: stand, duration_s: 3}\n  - {type: accelerate, duration_s: 2, speed_mps: 2}\n"


def _fake_launch_modules(monkeypatch, values: dict, share: Path):
    """Stand-ins for launch / launch_ros (not on PyPI): record what the launch file builds."""
    class Recorded:
        def __init__(self, *args, **kwargs):
            self.args, self.kwargs = args, kwargs

    class LaunchConfiguration:
        def __init__(self, name):
            self.name = name

        def perform(self, context):
            return values[self.name]

    mods = {"launch": {"LaunchDescription": Recorded}, "launch.actions": {"DeclareLaunchArgument": Recorded,
                                                                          "OpaqueFunction": Recorded},
            "launch.substitutions": {"LaunchConfiguration": LaunchConfiguration},
            "launch_ros": {}, "launch_ros.actions": {"Node": Recorded},
            "ament_index_python": {}, "ament_index_python.packages": {"get_package_share_directory": lambda _: str(share)}}
    for name, attrs in mods.items():
        monkeypatch.setitem(sys.modules, name, types.SimpleNamespace(**attrs))


def _launch_nodes(monkeypatch, values, share):
    _fake_launch_modules(monkeypatch, values, share)
    spec = importlib.util.spec_from_file_location("navigation_launch", LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    desc = module.generate_launch_description()
    opaque = desc.args[0][-1]
    return opaque.kwargs["function"](None)


@pytest.fixture
def sim_without_height(tmp_path):
    """A valid scenario that leaves height_m out, simulated as nav-demo does."""
    scen = tmp_path / "no_height.yaml"
    scen.write_text("latitude_deg: 48.1\nlongitude_deg: 11.6\n" + SEGMENTS + "gps: {rate_hz: 1, sigma_m: [1, 1, 2]}\n")
    out = tmp_path / "sim"
    sc = demo.simulate_scenario(scen, demo.DEFAULT_MODEL, 3, out, fmt="csv")
    assert sc.height_m == 0.0
    return scen, out


def test_the_launch_file_starts_the_description_s_nodes(monkeypatch, tmp_path, sim_without_height):
    _, sim = sim_without_height
    values = {"sim_dir": str(sim), "recording": "", "rate": "4.0", "port": "/tmp/p", "use_sim_time": "auto",
              "sensor_model": "m.yaml", "bag_out": "b"}
    nodes = _launch_nodes(monkeypatch, values, tmp_path)
    want = navigation_graph(GraphInputs("simulation", "m.yaml", sim_dir=str(sim), port="/tmp/p", rate=4.0,
                                        bag_out="b", played_topics=()))
    assert [(n.kwargs["package"], n.kwargs["executable"]) for n in nodes] == [(s.package, s.executable) for s in want]
    params = tmp_path / "config" / "navigation.yaml"
    assert [n.kwargs["parameters"] for n in nodes] == [[str(params), s.overrides] for s in want]
    kf = next(n for n in nodes if n.kwargs["executable"] == "ins_gps_kf_node").kwargs["parameters"][1]
    assert (kf["datum_lat_deg"], kf["datum_lon_deg"], kf["datum_h_m"]) == (48.1, 11.6, 0.0)  # the scenario's
    hardware = _launch_nodes(monkeypatch, dict(values, sim_dir=""), tmp_path)
    assert [n.kwargs["executable"] for n in hardware][0] == "bp3010_driver"
    assert all(n.kwargs["parameters"][1]["use_sim_time"] is False for n in hardware)
    assert "datum_lat_deg" not in next(n for n in hardware if n.kwargs["executable"] == "ins_gps_kf_node"
                                       ).kwargs["parameters"][1]


def test_nav_demo_starts_the_description_s_nodes_with_its_run_folders(tmp_path, sim_without_height):
    scen, sim = sim_without_height
    args = demo.parse_args(["--scenario", str(scen), "--out", str(tmp_path / "out"), "--rate", "2"])
    run = tmp_path / "run"
    specs = demo.graph_specs(args, run, sim)
    assert [s.executable for s in specs] == ["bp3010_driver", "wmra_node", "ins_gps_kf_node", "allan_node",
                                             "sensor_health_node", "bag_record", "scenario_player"]
    by = {s.executable: s.overrides for s in specs}
    assert by["scenario_player"]["link"] == by["bp3010_driver"]["port"] == str(run / "bp3010_port")
    assert by["bag_record"]["output"] == str(run / "bag") and by["allan_node"]["out_dir"] == str(run / "allan")
    assert by["ins_gps_kf_node"]["datum_h_m"] == 0.0
    assert by["sensor_health_node"]["sensor_model_path"] == by["wmra_node"]["sensor_model_path"]


def test_a_scenario_without_height_m_runs_through_demo_truth_and_datum(tmp_path, sim_without_height):
    scen, sim = sim_without_height
    args = demo.parse_args(["--scenario", str(scen), "--out", str(tmp_path / "out")])
    demo.check_inputs(args)  # no KeyError: the scenario is read by imu_sim.scenario.load
    truth = TruthTrack.from_sim_dir(sim)
    assert (truth.frame.lat0_deg, truth.frame.lon0_deg, truth.frame.h0_m) == (48.1, 11.6, 0.0)
    assert scenario_datum(sim) == {"datum_lat_deg": 48.1, "datum_lon_deg": 11.6, "datum_h_m": 0.0}


def test_a_wildcard_params_file_gives_the_filter_s_parameters_everywhere(tmp_path):
    params = tmp_path / "p.yaml"
    params.write_text("/**:\n  ros__parameters:\n    filter_rate_hz: 4.0\n    gps_topic: gps/fix2\n"
                      "    use_sim_time: true\n    wavelet: db4\n"  # another node's: shared, skipped
                      "/ins_gps_kf_node:\n  ros__parameters:\n    gps_std_m: 3.0\n    filter_rate_hz: 5.0\n")
    assert kfconfig.load_params_yaml(params) == {"filter_rate_hz": 5.0, "gps_std_m": 3.0, "gps_topic": "gps/fix2"}
    only_wild = tmp_path / "w.yaml"
    only_wild.write_text("/**:\n  ros__parameters:\n    filter_rate_hz: 4.0\n    zupt_enabled: false\n")
    assert kfconfig.load_params_yaml(only_wild) == {"filter_rate_hz": 4.0, "zupt_enabled": False}
    # the report's offline replay gets what the node got: nav-demo reads the section by the same rule
    specs = navigation_graph(GraphInputs("hardware", "m.yaml"))
    assert demo.filter_params(only_wild, specs)["filter_rate_hz"] == 4.0
    assert demo.filter_params(params, specs)["gps_topic"] == "gps/fix2"
    args = argparse.Namespace(params=only_wild, model=demo.DEFAULT_MODEL, recording=None, truth=None,
                              scenario=demo.DEFAULT_SCENARIO)
    demo.check_inputs(args)
    bad = tmp_path / "bad.yaml"
    bad.write_text("ins_gps_kf_node:\n  ros__parameters:\n    filter_rat_hz: 4.0\n")
    with pytest.raises(kfconfig.FilterConfigError, match="filter_rat_hz"):
        demo.check_inputs(argparse.Namespace(**{**vars(args), "params": bad}))



def test_a_recordings_wheel_speeds_are_played_when_the_filters_odometer_is_on(tmp_path):
    from nav_core import recording

    bag = recording.write_bag(tmp_path / "bag", gnss=recording.GnssRecording([1.0], [0.8], [0.2], [10.0], [[1, 1, 1]]),
                              wheel=recording.WheelSpeedRecording([1.0, 1.1], [2.0, 2.1]))
    params = tmp_path / "p.yaml"
    gps_readers = "gps/fix=ins_gps_kf_node,bag_record,sensor_health_node"
    for enabled, played, readers in ((False, ["gps/fix"], [gps_readers]),
                                     (True, ["gps/fix", "odom/wheel"], [gps_readers, "odom/wheel=ins_gps_kf_node"])):
        params.write_text(f"ins_gps_kf_node:\n  ros__parameters:\n    odometer_enabled: {str(enabled).lower()}\n")
        args = argparse.Namespace(params=params, model=demo.DEFAULT_MODEL, recording=bag, rate=1.0)
        specs = demo.graph_specs(args, tmp_path / "run", None)
        player = next(s for s in specs if s.executable == "bag_play")
        assert player.overrides["topics"] == played
        # the player waits for each reader by name: the topics have 1 to 3 readers, so no one count fits all
        assert player.overrides["wait_for_readers"] == readers
        assert "sensor_health_node" in [s.executable for s in specs]
