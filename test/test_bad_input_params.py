"""Parameters: every declared range is enforced with one ConfigError naming the parameter (node and offline)."""
from __future__ import annotations

import importlib
import math
import sys

import pytest

from nav_core.params import ConfigError, Param, did_you_mean

NODE_MODULES = ("imu_calib.allan_node", "imu_driver.bag_play_node", "imu_driver.bag_record_node",
                "imu_driver.bp3010_driver_node", "nav_bringup.scenario_player_node", "wmra_filter.wmra_node")


@pytest.mark.parametrize("value", [-3, 0, 70000, 2.5, "x", True, None])
def test_int_param_rejects_out_of_range_and_wrong_types(value):
    p = Param("hop", 8, "samples", 1, 65536)
    with pytest.raises(ConfigError, match=r"parameter 'hop'.*int in \[1, 65536\]"):
        p.check(value)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, -1.0, "1.0", False])
def test_float_param_rejects_non_finite_and_out_of_range(value):
    with pytest.raises(ConfigError, match="parameter 'rate_hz'"):
        Param("rate_hz", 64.0, "Hz", 0.5, 1000.0).check(value)


def test_nan_is_accepted_only_where_the_default_means_unset():
    Param("datum_lat_deg", math.nan, "deg; NaN = first fix", -90.0, 90.0).check(math.nan)
    Param("rate_hz", 64.0, "Hz", 0.5, 1000.0).check(64)  # an int for a float is fine
    with pytest.raises(ConfigError, match="one of"):
        Param("mode", "a", "mode", choices=("a", "b")).check("c")


def test_did_you_mean_suggests_the_closest_known_name():
    assert "speed_mps" in did_you_mean("speed", ["type", "duration_s", "speed_mps"])
    assert did_you_mean("zzz", ["type"]) == ""


def test_params_module_imports_no_ros():
    import subprocess
    import sys
    code = ("import sys, nav_core.params; "
            "sys.exit(any(m.split('.')[0] in ('rclpy', 'rcl_interfaces') for m in sys.modules))")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def _declare(params, overrides):
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from nav_core.params_ros import declare_parameters
    node = Node("bad_param_probe",
                parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    try:
        return declare_parameters(node, params)
    finally:
        node.destroy_node()


def _ranged(module_name):
    mod = importlib.import_module(module_name)
    return [p for p in mod.PARAMS if p.low is not None and isinstance(p.default, (int, float))
            and not isinstance(p.default, bool)]


@pytest.mark.parametrize("module_name", NODE_MODULES)
def test_every_node_range_is_a_config_error_not_a_traceback(rclpy_context, module_name):
    ranged = _ranged(module_name)
    assert ranged, f"{module_name} declares no ranged parameter"
    for p in ranged:
        below = type(p.default)(p.low) - (1 if isinstance(p.default, int) else abs(p.low) + 1.0)
        with pytest.raises(ConfigError, match=f"parameter '{p.name}'.*expected"):
            _declare([p], {p.name: below})


def test_node_parameter_of_the_wrong_type_is_a_config_error(rclpy_context):
    from imu_driver.bp3010_driver_node import PARAMS
    baud = next(p for p in PARAMS if p.name == "baud")
    with pytest.raises(ConfigError, match="parameter 'baud'.*wrong type"):
        _declare([baud], {"baud": "fast"})
    assert _declare([baud], {"baud": 115200}) == {"baud": 115200}


def test_a_value_for_a_parameter_the_node_does_not_have_is_a_config_error_with_a_suggestion(rclpy_context):
    with pytest.raises(ConfigError, match=r"unknown parameter\(s\) \['hopp'\] for bad_param_probe "
                                          r"\(did you mean 'hop'\?\)"):
        _declare([Param("hop", 8, "samples", 1, 65536)], {"hopp": 3})


WILDCARD_FILE = """
/**:
  ros__parameters:
    imu_rate_hz: 64.0        # shared by several nodes: not every one has it
    shared_only: 1
wmra_node:
  ros__parameters:
    hopp: 3
/**/ins_gps_kf_node:
  ros__parameters:
    gate: 0.5
/*:
  ros__parameters:
    nested: {deep: 1}
"""


def test_only_keys_of_wildcard_params_file_sections_count_as_shared(tmp_path):
    from nav_core.params_ros import shared_only_keys

    f = tmp_path / "params.yaml"
    f.write_text(WILDCARD_FILE)
    args = ["node", "--ros-args", "--disable-stdout-logs", "--params-file", str(f), "-p", "shared_only:=2", "--",
            "-p", "nested.deep:=1"]  # after "--": not ROS arguments
    # hopp and gate are under a node's own name, shared_only also comes with -p: errors
    assert shared_only_keys(args) == {"imu_rate_hz", "nested.deep"}
    assert shared_only_keys(["node", "--params-file", str(f)]) == set()  # not a ROS argument
    assert shared_only_keys(["node", "--ros-args", "--params-file", str(tmp_path / "missing.yaml")]) == set()


@pytest.mark.ros  # rclpy initialised with the test's own command line, on DDS like the process tests
def test_a_key_only_a_wildcard_section_gives_is_a_warning_and_a_node_section_key_an_error(
        tmp_path, ros_env, monkeypatch):
    import rclpy
    from rclpy.node import Node

    from nav_core.params_ros import check_unknown_overrides, declare_parameters
    f = tmp_path / "params.yaml"
    for node_name, expect_error in (("probe_elsewhere", False), ("wmra_node", True)):
        f.write_text(WILDCARD_FILE)
        monkeypatch.setattr(sys, "argv", ["probe", "--ros-args", "--params-file", str(f)])
        rclpy.init()  # parses sys.argv, as a node's main does
        node = Node(node_name)
        try:
            if expect_error:  # wmra_node's own section holds hopp
                with pytest.raises(ConfigError, match=r"\['hopp'\] for wmra_node \(did you mean 'hop'\?\)"):
                    declare_parameters(node, [Param("hop", 8, "samples", 1, 65536)])
            else:
                assert declare_parameters(node, [Param("hop", 8, "samples", 1, 65536)]) == {"hop": 8}
                assert check_unknown_overrides(node, ["hop"]) == ["imu_rate_hz", "nested.deep", "shared_only"]
        finally:
            node.destroy_node()
            rclpy.try_shutdown()


NODE_CLASSES = {"imu_calib.allan_node": "AllanNode", "imu_driver.bag_play_node": "BagPlayer",
                "imu_driver.bag_record_node": "BagRecorder", "imu_driver.bp3010_driver_node": "Bp3010Driver",
                "nav_bringup.scenario_player_node": "ScenarioPlayer", "wmra_filter.wmra_node": "WmraNode",
                "ins_gps_kf.ins_gps_kf_node": "InsGpsKfNode"}


@pytest.mark.ros  # each node is built in this process, on DDS like the process tests
@pytest.mark.parametrize("module_name", sorted(NODE_CLASSES))
def test_every_node_refuses_an_unknown_parameter_given_with_p(module_name, ros_env):
    import rclpy

    cls = getattr(importlib.import_module(module_name), NODE_CLASSES[module_name])
    rclpy.init(args=["node", "--ros-args", "-p", "no_such_param:=1"])
    try:
        with pytest.raises(ConfigError, match=r"unknown parameter\(s\) \['no_such_param'\]"):
            cls()
    finally:
        rclpy.try_shutdown()


@pytest.mark.ros
def test_a_node_given_an_unknown_parameter_exits_2_with_one_line_naming_it(ros_env):
    from nav_core.processes import NodeProcess

    node = NodeProcess("wmra_node", env=ros_env, ros_args={"hopp": 3})
    try:
        node.proc.wait(timeout=30.0)
    finally:
        code = node.stop()
    lines = [ln for ln in node.output.splitlines() if "configuration" in ln]
    assert code == 2 and len(lines) == 1, node.output
    assert "'hopp'" in lines[0] and "did you mean 'hop'?" in lines[0], node.output
    assert "Traceback" not in node.output


def test_an_unparsable_params_file_is_one_configuration_line_and_exit_2(tmp_path, ros_env, capsys):
    from nav_core.ros_node import run_node
    bad = tmp_path / "params.yaml"
    bad.write_text("wmra_node:\n  ros__parameters:\n    hop: [1, 2\n")
    built = []
    for path in (bad, tmp_path / "missing.yaml"):
        assert run_node(lambda: built.append(1), args=["node", "--ros-args", "--params-file", str(path)]) == 2
        out = capsys.readouterr().out
        lines = [ln for ln in out.splitlines() if "configuration" in ln]
        assert len(lines) == 1 and path.name in lines[0] and "/project/src" not in lines[0], out
    assert not built  # the node is never built
