"""Runtime parameter changes are applied or refused, never accepted and ignored (``ros2 param set``).

Every node of the graph (the driver has its own test) is built in this process, as a composed
node would be, and asked to change parameters through ``set_parameters`` - the call the
``/<node>/set_parameters`` service makes: each is refused as read-only and keeps its value.
One process test checks the service path end to end.
"""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"


def _imu(n=640, rate=64.0):
    from nav_core.recording import ImuRecording

    t = 1_700_000_000.0 + np.arange(n) / rate
    return ImuRecording(t, np.zeros((n, 3)), np.tile([0.0, 0.0, 9.8], (n, 1)))


def _gnss(n=10):
    from nav_core.recording import GnssRecording

    return GnssRecording(np.arange(n, dtype=float), np.full(n, 0.9), np.full(n, 0.1), np.zeros(n), np.ones((n, 3)))


def _bag(tmp: Path) -> Path:
    from nav_core.recording import write_bag

    write_bag(tmp / "in_bag", imu=_imu(), gnss=_gnss())
    return tmp / "in_bag"


def _sim_dir(tmp: Path) -> Path:
    from imu_driver.bp3010_codec import encode_stream
    from nav_core.recording import write_gnss_csv

    sim = tmp / "sim"
    sim.mkdir()
    (sim / "bp3010.bin").write_bytes(encode_stream(np.zeros((64, 3)), np.tile([0, 0, 9.8 / 64], (64, 1))))
    write_gnss_csv(sim / "gnss.csv", _gnss())
    return sim


# module, class, parameters it needs to start, changes asked for at run time
NODES = {
    "wmra_node": ("wmra_filter.wmra_node", "WmraNode", lambda tmp: {"sensor_model_path": str(MODEL)},
                  {"hop": 16, "wavelet": "db4", "sensor_model_path": "/elsewhere.yaml"}),
    "ins_gps_kf_node": ("ins_gps_kf.ins_gps_kf_node", "InsGpsKfNode", lambda tmp: {},
                        {"gate_probability": 0.99, "lever_arm_x_m": 1.0, "imu_topic": "imu/other"}),
    "allan_node": ("imu_calib.allan_node", "AllanNode", lambda tmp: {"out_dir": str(tmp / "allan")},
                   {"duration_s": 5.0, "topic": "imu/other"}),
    "bag_play": ("imu_driver.bag_play_node", "BagPlayer",
                 lambda tmp: {"bag": str(_bag(tmp)), "start_delay_s": 30.0, "exit_when_done": False},
                 {"rate": 2.0, "loop": True}),
    "bag_record": ("imu_driver.bag_record_node", "BagRecorder", lambda tmp: {"output": str(tmp / "out_bag")},
                   {"topics": ["a", "b"], "storage": "sqlite3"}),
    "scenario_player": ("nav_bringup.scenario_player_node", "ScenarioPlayer",
                        lambda tmp: {"sim_dir": str(_sim_dir(tmp)), "link": str(tmp / "port"),
                                     "wait_timeout_s": 0.0, "exit_when_done": False},
                        {"rate": 4.0, "gps_offset_m": 10.0}),
}


def _ros_args(values: dict) -> list:
    """``--ros-args -p name:=value ...`` (values as YAML scalars)."""
    args = ["--ros-args"]
    for name, value in values.items():
        args += ["-p", f"{name}:={str(value).lower() if isinstance(value, bool) else value}"]
    return args


@pytest.mark.ros  # the nodes run in this process, but on DDS like the process tests
@pytest.mark.parametrize("name", sorted(NODES))
def test_set_parameters_at_run_time_is_refused_as_read_only(name, tmp_path, ros_env):
    import importlib

    import rclpy
    from rclpy.parameter import Parameter

    module, cls, needs, changes = NODES[name]
    rclpy.init(args=_ros_args(needs(tmp_path)))
    node = None
    try:
        node = getattr(importlib.import_module(module), cls)()
        declared = [n for n in node._parameters if n != "use_sim_time"]  # use_sim_time is rclpy's, applied live
        assert declared and all(d.read_only for d in node.describe_parameters(declared)), \
            [n for n, d in zip(declared, node.describe_parameters(declared)) if not d.read_only]
        before = {k: node.get_parameter(k).value for k in changes}
        results = node.set_parameters([Parameter(k, value=v) for k, v in changes.items()])
        assert all(not r.successful and "read-only" in r.reason for r in results), results
        assert {k: node.get_parameter(k).value for k in changes} == before
    finally:
        if node is not None:
            getattr(node, "close", lambda: None)()
            node.destroy_node()
        rclpy.try_shutdown()


@pytest.mark.ros
def test_the_set_parameters_service_refuses_a_change(tmp_path, ros_env, rclpy_context):
    """``ros2 param set /bag_record storage mcap`` answers 'read-only' and the node keeps recording."""
    import rclpy
    from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    exe = Path(sys.executable).parent / "bag_record"
    proc = subprocess.Popen([str(exe), "--ros-args", "-p", f"output:={tmp_path / 'bag'}"], env=ros_env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    node = rclpy.create_node("param_client")
    try:
        client = node.create_client(SetParameters, "/bag_record/set_parameters")
        assert client.wait_for_service(timeout_sec=30.0), "bag_record's parameter service did not appear"
        request = SetParameters.Request(parameters=[ParameterMsg(
            name="storage", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="mcap"))])
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        result = future.result().results[0]
        assert not result.successful and "read-only" in result.reason
        assert proc.poll() is None
    finally:
        node.destroy_node()
        proc.send_signal(2)
        try:
            out, _ = proc.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, _ = proc.communicate()
    assert proc.returncode == 0, out
