"""bp3010_driver end to end: emulator -> real pseudo-terminal -> driver process -> DDS -> rclpy probe."""
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu

from imu_driver.bp3010_codec import DEFAULT_FORMAT, to_counts
from imu_driver.emulator import builtin_increments
from nav_core import sensor_model
from nav_core.processes import NodeProcess
from nav_core.ros_node import Probe

pytestmark = pytest.mark.ros


def _start(tmp_path, env, emulator_args, driver_params=None):
    link = tmp_path / "bp3010"
    emu = NodeProcess("bp3010_emulator", ["--link", link, *emulator_args], env=env)
    assert emu.wait_for_line("PORT", 10), emu.output
    drv = NodeProcess("bp3010_driver", env=env, ros_args={"port": str(link), **(driver_params or {})})
    assert drv.wait_for_line("ready", 20), drv.output
    return emu, drv


def _diag_values(probe):
    out = []
    for _, arr in probe.received["/diagnostics"]:
        for st in arr.status:
            if "bp3010_driver" in st.name:
                out.append({kv.key: kv.value for kv in st.values})
    return out


def test_driver_publishes_the_increments_the_emulator_encoded_as_rates(tmp_path, rclpy_context):
    emu, drv = _start(tmp_path, rclpy_context, ["--source", "rotating", "--seconds", "40", "--seed", "3"])
    probe = Probe({"imu/data_raw": Imu})
    try:
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= 256, 30), drv.output
    finally:
        probe.destroy_node()
        assert drv.stop() == 0, drv.output
        emu.stop()
    msgs = [m for _, m in probe.received["imu/data_raw"]]
    counts = to_counts(*builtin_increments("rotating", 40 * 64, seed=3))
    rates = counts * DEFAULT_FORMAT.lsb() * 64.0
    got = np.array([[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z,
                     m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z] for m in msgs])
    start = int(np.argmin(np.abs(rates - got[0]).sum(axis=1)))
    np.testing.assert_allclose(got, rates[start:start + len(got)], rtol=0, atol=1e-9)
    assert msgs[0].header.frame_id == "imu_link" and msgs[0].orientation_covariance[0] == -1.0
    # Default noise: the shipped BP3010 model's white noise at 64 Hz (sigma per sample = N sqrt(rate)).
    model = sensor_model.load(Path(__file__).parents[1] / "config/sensor_models/bp3010.yaml")
    assert msgs[0].angular_velocity_covariance[0] == pytest.approx(np.max(model.gyro.white_noise) ** 2 * 64)
    assert msgs[0].linear_acceleration_covariance[0] == pytest.approx(np.max(model.accel.white_noise) ** 2 * 64)
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs]) * 1e-9
    # Counter-based stamps: one nominal period apart (to float rounding at epoch scale), no read jitter;
    # only a read more prompt than all before it moves the offset (by less than half a period, or slewed).
    steps = np.diff(stamps)
    assert np.all(steps >= 0.5 / 64 - 1e-6) and np.all(steps <= (1 + 200e-6) / 64 + 1e-6), steps
    assert np.mean(np.abs(steps - 1 / 64) < 1e-6) > 0.9, steps


def test_driver_survives_unplug_and_corrupt_bytes_and_reports_them(tmp_path, rclpy_context):
    emu, drv = _start(tmp_path, rclpy_context,
                      ["--source", "still", "--seconds", "60", "--flip-probability", "0.05",
                       "--garbage-every", "1.0", "--disconnect-at", "3", "--disconnect-for", "2"],
                      {"reconnect_period_s": 0.2})
    probe = Probe({"imu/data_raw": Imu})
    probe.create_subscription(DiagnosticArray, "/diagnostics",
                              lambda m: probe.received.setdefault("/diagnostics", []).append((time.monotonic(), m)),
                              10)
    probe.received["/diagnostics"] = []
    try:
        assert probe.spin_until(lambda p: emu.wait_for_line("PLUG /", 0), 20), emu.output
        plugged_at = time.monotonic()
        assert probe.spin_until(
            lambda p: sum(t > plugged_at + 1.0 for t, _ in p.received["imu/data_raw"]) > 64, 15), drv.output
        assert probe.spin_until(lambda p: any(int(d["reconnects"]) >= 1 for d in _diag_values(p)), 5)
        assert drv.proc.poll() is None, "the driver must not exit on a lost port"
    finally:
        probe.destroy_node()
        code = drv.stop()
        emu.stop()
    assert code == 0, drv.output
    last = _diag_values(probe)[-1]
    assert int(last["checksum_errors"]) > 0
    assert int(last["bytes_discarded"]) > 0 and int(last["resyncs"]) > 0
    # Flipped frames are dropped and show as counter gaps (gaps across a reconnect are not counted:
    # the 8-bit counter cannot tell how long the port was gone).
    assert int(last["lost_frames"]) > 0
    assert int(last["reconnects"]) >= 1
    assert last["port_state"] == "connected"
    assert int(last["duplicates"]) == 0  # flips and garbage are not repeats
    # across flips, garbage and the reconnect the stamps only go forward (re-anchored forward after the gap)
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in probe.received["imu/data_raw"]])
    assert np.all(np.diff(stamps) > 0)
    assert "disconnected" in drv.output or "waiting for port" in drv.output


def test_driver_with_an_invalid_rate_stops_with_a_message(ros_env):
    drv = NodeProcess("bp3010_driver", env=ros_env, ros_args={"rate_hz": 50, "port": "/nonexistent"})
    assert drv.proc.wait(timeout=30) == 2
    drv.stop()
    assert "rate_hz" in drv.output and "50" in drv.output


def test_driver_waits_for_a_missing_port_without_exiting(ros_env):
    drv = NodeProcess("bp3010_driver", env=ros_env, ros_args={"port": "/nonexistent/tty", "reconnect_period_s": 0.1})
    try:
        assert drv.wait_for_line("waiting for port", 20), drv.output
        time.sleep(1.0)
        assert drv.proc.poll() is None
    finally:
        assert drv.stop() == 0


def test_driver_with_an_out_of_range_baud_exits_2_with_one_line_naming_the_range(ros_env):
    drv = NodeProcess("bp3010_driver", env=ros_env, ros_args={"baud": 0, "port": "/nonexistent"})
    assert drv.proc.wait(timeout=30) == 2
    drv.stop()
    errors = [line for line in drv.lines if "baud" in line]
    assert len(errors) == 1 and "[1200, 4000000]" in errors[0], drv.output
    assert "Traceback" not in drv.output


def _set(probe, **values):
    """Call bp3010_driver's set_parameters; returns the results (successful, reason) by name."""
    client = probe.create_client(SetParameters, "/bp3010_driver/set_parameters")
    assert client.wait_for_service(timeout_sec=10)
    request = SetParameters.Request(parameters=[Parameter(name, value=v).to_parameter_msg()
                                                for name, v in values.items()])
    future = client.call_async(request)
    assert probe.spin_until(lambda p: future.done(), 10)
    probe.destroy_client(client)
    return dict(zip(values, future.result().results))


def test_runtime_parameter_changes_are_applied_or_refused(tmp_path, rclpy_context):
    emu, drv = _start(tmp_path, rclpy_context, ["--source", "still", "--seconds", "60"])
    other = NodeProcess("bp3010_emulator", ["--link", tmp_path / "other", "--source", "still", "--seconds", "60"],
                        env=rclpy_context)
    probe = Probe({"imu/data_raw": Imu})
    try:
        assert other.wait_for_line("PORT", 10)
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= 64, 20), drv.output
        refused = _set(probe, **{"frame.sync": 0x55})
        assert not refused["frame.sync"].successful and "read-only" in refused["frame.sync"].reason
        assert not _set(probe, rate_hz=50)["rate_hz"].successful  # out of its choices
        assert _set(probe, rate_hz=32)["rate_hz"].successful
        assert emu.wait_for_line("RATE 32", 10), emu.output  # the port was reopened and the rate command sent
        n = len(probe.received["imu/data_raw"])
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= n + 64, 10)
        stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
                           for _, m in probe.received["imu/data_raw"][-32:]])
        assert np.median(np.diff(stamps)) == pytest.approx(1 / 32, rel=1e-3)
        assert _set(probe, port=str(tmp_path / "other"))["port"].successful
        assert other.wait_for_line("RATE 32", 10), other.output  # the new port, opened with the new rate
        n = len(probe.received["imu/data_raw"])
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= n + 32, 10)
    finally:
        probe.destroy_node()
        assert drv.stop() == 0, drv.output
        emu.stop()
        other.stop()


def test_noise_sigmas_come_from_the_sensor_model_at_the_selected_rate(tmp_path, rclpy_context):
    path = Path(__file__).parents[1] / "config/sensor_models/bp3010.yaml"
    emu, drv = _start(tmp_path, rclpy_context, ["--source", "still", "--seconds", "30"],
                      {"sensor_model_path": str(path), "rate_hz": 16})
    probe = Probe({"imu/data_raw": Imu})
    try:
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= 2, 20), drv.output
    finally:
        probe.destroy_node()
        assert drv.stop() == 0, drv.output
        emu.stop()
    model = sensor_model.load(path)
    msg = probe.received["imu/data_raw"][-1][1]
    assert msg.angular_velocity_covariance[0] == pytest.approx(np.max(model.gyro.white_noise) ** 2 * 16)
    assert msg.linear_acceleration_covariance[0] == pytest.approx(np.max(model.accel.white_noise) ** 2 * 16)


def test_driver_with_a_missing_sensor_model_exits_2_naming_the_parameter(ros_env, tmp_path):
    drv = NodeProcess("bp3010_driver", env=ros_env, ros_args={"sensor_model_path": str(tmp_path / "none.yaml")})
    assert drv.proc.wait(timeout=30) == 2
    drv.stop()
    assert "sensor_model_path" in drv.output and "Traceback" not in drv.output
