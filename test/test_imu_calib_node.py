"""allan_node wiring: live subscribe-for-duration then characterise, offline recording, bad config."""
import os
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import Imu

from imu_calib import synthetic
from nav_core import sensor_model
from nav_core.processes import NodeProcess
from nav_core.recording import write_imu_csv
from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays

pytestmark = pytest.mark.ros
MODEL = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)),
                                 accel=sensor_model.TriadModel(white_noise=np.full(3, 2e-3)), sample_rate_hz=50.0)


def _result(probe):
    for _, arr in probe.received["/diagnostics"]:
        for st in arr.status:
            if "allan_node" in st.name and st.message not in ("collecting", "characterising"):
                return st
    return None


@pytest.mark.slow
def test_node_collects_duration_of_live_data_then_writes_the_model(tmp_path, ros_env, rclpy_context):
    out = tmp_path / "live"
    node = NodeProcess("allan_node", env=ros_env, ros_args={"duration_s": 4.0, "out_dir": str(out),
                                                            "diagnostics_period_s": 0.2})
    try:
        probe = Probe({"/diagnostics": DiagnosticArray})
        feeder = rclpy.create_node("feeder")
        pub = feeder.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
        assert probe.spin_until(lambda p: pub.get_subscription_count() > 0, 20), node.output
        rec = synthetic.static_recording(MODEL, 6.0, np.random.default_rng(0), t0=1000.0)
        for t, g, a in zip(rec.t, rec.gyro, rec.accel):
            pub.publish(imu_from_arrays(t, g, a))
            rclpy.spin_once(probe, timeout_sec=0.0)
            time.sleep(0.004)
        # The characterisation runs at nice +10: on a machine loaded 10x over it took more than 30 s; a deadline
        # for a result, not a speed claim.
        assert probe.spin_until(lambda p: _result(p) is not None, 120), node.output
        status = _result(probe)
        values = {kv.key: kv.value for kv in status.values}
        assert status.level == DiagnosticStatus.OK, status.message
        assert 150 <= int(values["samples"]) <= 202  # 4 s of stamps at 50 Hz, best effort may drop a few
        model = sensor_model.load(out / "sensor_model.yaml")
        np.testing.assert_allclose(model.gyro.white_noise, 1e-3, rtol=0.35)
        assert (out / "imu.yaml").exists() and (out / "allan.png").exists()
        feeder.destroy_node()
        probe.destroy_node()
    finally:
        node.stop()


@pytest.mark.slow
def test_node_characterises_a_recording_and_can_exit_when_done(tmp_path, ros_env):
    csv = write_imu_csv(tmp_path / "rec.csv", synthetic.static_recording(MODEL, 60.0, np.random.default_rng(1)))
    out = tmp_path / "offline"
    node = NodeProcess("allan_node", env=ros_env, ros_args={"recording": str(csv), "out_dir": str(out),
                                                            "exit_when_done": True, "diagnostics_period_s": 0.1})
    try:
        assert node.proc.wait(timeout=60) == 0, node.output
    finally:
        node.stop()
    assert "wrote" in node.output
    assert sensor_model.load(out / "sensor_model.yaml").sample_rate_hz == pytest.approx(50.0)


def test_node_stops_with_a_message_when_out_dir_is_missing(ros_env):
    node = NodeProcess("allan_node", env=ros_env, ros_args={"out_dir": ""})
    try:
        assert node.proc.wait(timeout=30) == 2
    finally:
        node.stop()
    assert "out_dir" in node.output


@pytest.mark.slow
def test_the_fit_runs_in_a_niced_worker_while_the_node_keeps_publishing_diagnostics(tmp_path, ros_env, rclpy_context):
    # 2 h at 10 Hz: about a second of fitting on a quiet machine (several under load), done by a child process at
    # nice +10 (issue 15); statuses every 0.05 s, so even the quiet machine's fit is seen answering many times (at
    # 0.2 s a fresh-clone run saw only 2 before the model was written)
    rec = synthetic.static_recording(sensor_model.SensorModel(
        gyro=sensor_model.TriadModel(white_noise=np.full(3, 3.5e-4), rate_random_walk=np.full(3, 2.2e-6)),
        accel=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=10.0), 7200.0,
        np.random.default_rng(3))
    csv = write_imu_csv(tmp_path / "rec.csv", rec)
    node = NodeProcess("allan_node", env=ros_env, ros_args={"recording": str(csv), "out_dir": str(tmp_path / "o"),
                                                            "diagnostics_period_s": 0.05, "worker_nice": 10})
    arrivals, niceness = [], []

    def on_diag(arr):
        for st in arr.status:
            if "allan_node" in st.name:
                arrivals.append((time.monotonic(), st.message))
                values = {kv.key: kv.value for kv in st.values}
                if st.message == "characterising" and not niceness:
                    pid = int(values["worker_pid"])
                    try:
                        niceness.append(os.getpriority(os.PRIO_PROCESS, pid) - os.getpriority(os.PRIO_PROCESS, 0))
                    except ProcessLookupError:
                        pass
    try:
        probe = Probe({"/diagnostics": DiagnosticArray})
        probe.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 50)
        assert probe.spin_until(lambda p: any(m not in ("characterising", "collecting") for _, m in arrivals),
                                300), node.output
        probe.destroy_node()
    finally:
        node.stop()
    working = [t for t, m in arrivals if m == "characterising"]
    assert len(working) >= 5, arrivals[:3]
    # the node answered all along: no silence of more than 2 s (40 periods, slack for a loaded CI) while its worker
    # was busy
    assert np.max(np.diff(working)) < 2.0, np.max(np.diff(working))
    # the kernel caps niceness at 19, so under a niced test run (CI at nice 10) the worker is less than +10 apart
    assert niceness and niceness[0] >= min(10, 19 - os.getpriority(os.PRIO_PROCESS, 0)), niceness
    assert arrivals[-1][1].startswith("wrote"), arrivals[-1]
