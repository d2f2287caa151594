"""Parameters: every declared range is enforced with one ConfigError naming the parameter (node and offline)."""
from __future__ import annotations

import importlib
import math

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


def test_a_value_for_a_parameter_the_node_does_not_have_is_named_in_a_warning(rclpy_context):
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from nav_core.params_ros import declare_parameters
    node = Node("unknown_param_probe", parameter_overrides=[Parameter("hopp", value=3)])
    try:
        declare_parameters(node, [Param("hop", 8, "samples", 1, 65536)])
        from nav_core.params_ros import warn_unknown_overrides
        assert warn_unknown_overrides(node, ["hop"]) == ["hopp"]
    finally:
        node.destroy_node()


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
