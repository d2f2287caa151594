"""sensor_health_node wiring: a real node process fed by an rclpy publisher; events (transient local) and
/diagnostics observed from probes, and the same events as the core (the CLI's) on the same samples."""
import json
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from nav_core import sensor_model
from nav_core.processes import NodeProcess
from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays
from nav_core.sensor_model import SensorModel, TriadModel
from nav_core.status import level_name
from sensor_health import noise_sim
from sensor_health.events import Event
from sensor_health.monitor import HealthMonitor
from sensor_health.sensor_health_node import EVENTS_QOS
from sensor_health.status import ChannelStatus

pytestmark = pytest.mark.ros
FS = 64.0
T0 = 1_700_000_000.0


def _model():
    return SensorModel(TriadModel(white_noise=np.full(3, 1.5e-3), quantization=np.full(3, 7e-7)),
                       TriadModel(white_noise=np.full(3, 2e-3), quantization=np.full(3, 1.4e-5)), FS)


def _samples():
    """12 s of model noise, gz frozen from 6 s on (the GNSS path and a bag: test_sensor_health_node_gnss)."""
    n = int(12 * FS)
    t = T0 + np.arange(n) / FS
    x = noise_sim.model_noise(_model(), n, 1 / FS, np.random.default_rng(7))
    x[:, 5] += 9.81
    x[t >= T0 + 6, 2] = x[t >= T0 + 6][0, 2]
    return t, x


def channel_statuses(arr) -> dict:
    """Channel or ``summary`` -> ChannelStatus, parsed back from one DiagnosticArray of the node."""
    return {st.name.split(": ")[-1]: ChannelStatus.from_values({kv.key: kv.value for kv in st.values},
                                                               level_name(st.level[0]), st.message)
            for st in arr.status}


def late_events(timeout_s=20.0) -> list:
    """The events (dicts) a subscriber that joins now gets on the transient-local event topic."""
    late = rclpy.create_node("late_listener")
    got = []
    late.create_subscription(String, "sensor_health/events", lambda m: got.append(m.data), EVENTS_QOS)
    deadline = time.monotonic() + timeout_s
    while not got and time.monotonic() < deadline:
        rclpy.spin_once(late, timeout_sec=0.1)
    quiet = time.monotonic() + 1.0  # the rest of the history follows the first
    while time.monotonic() < quiet:
        n = len(got)
        rclpy.spin_once(late, timeout_sec=0.1)
        quiet = quiet if len(got) == n else time.monotonic() + 1.0
    late.destroy_node()
    return [json.loads(m) for m in got]


def test_node_names_the_fault_like_the_core_on_a_transient_local_topic_and_in_diagnostics(tmp_path, ros_env,
                                                                                          rclpy_context):
    path = sensor_model.save(_model(), tmp_path / "model.yaml")
    t, x = _samples()
    expected = HealthMonitor(_model(), keep_trace=False).push(t, x[:, :3], x[:, 3:])
    assert [e.effect for e in expected] == ["stuck_output"]
    node = NodeProcess("sensor_health_node", env=ros_env, ros_args={"sensor_model_path": str(path),
                                                                    "diagnostics_period_s": 0.2})
    try:
        assert node.wait_for_line("ready", 60), node.output
        probe = Probe({"/diagnostics": DiagnosticArray})
        feeder = rclpy.create_node("feeder")
        pub = feeder.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
        assert probe.spin_until(lambda p: pub.get_subscription_count() > 0, 20)
        probe.spin_until(lambda p: False, 1.0)  # the node's side of discovery lags ours: best effort would lose
        def summary(count):
            """The latest diagnostics whose summary says ``count`` samples were received."""
            def find(p):
                for _, arr in reversed(p.received["/diagnostics"]):
                    for st in arr.status:
                        values = {kv.key: kv.value for kv in st.values}
                        if st.name.endswith(": summary") and int(values.get("received", -1)) >= count:
                            return arr
                return None
            return find
        # paced by what the node reports taken: best effort loses nothing when the reader is never behind
        for a in range(0, len(t), 64):
            for ti, row in zip(t[a:a + 64], x[a:a + 64]):
                pub.publish(imu_from_arrays(ti, row[:3], row[3:]))
                time.sleep(0.0005)
            assert probe.spin_until(summary(min(a + 64, len(t))), 20), \
                f"the node did not take samples {a}..{a + 64}:\n{node.output}"
        statuses = channel_statuses(summary(len(t))(probe))
        assert statuses["gz"].effect == "stuck_output" and statuses["gz"].level == "ERROR"
        assert abs(statuses["gz"].onset_s - expected[0].onset_s) < 1e-6
        assert statuses["summary"].events == 1 and statuses["gx"].effect == ""

        got = late_events()  # joins after the event was published
        assert got, "a late subscriber did not get the event (transient local)"
        assert [Event.from_dict(d).to_dict() for d in got] == [e.to_dict() for e in expected]
        for n in (feeder, probe):
            n.destroy_node()
    finally:
        node.stop()


def test_node_exits_with_status_2_naming_a_missing_model(ros_env):
    node = NodeProcess("sensor_health_node", env=ros_env, ros_args={"sensor_model_path": "/nonexistent/m.yaml"})
    try:
        assert node.proc.wait(timeout=60) == 2
    finally:
        node.stop()
    assert "/nonexistent/m.yaml" in node.output
