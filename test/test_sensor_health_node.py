"""sensor_health_node wiring: a real node process fed by rclpy publishers (imu/data_raw and the filter's
odometry/filtered); events (transient local, a cleared fault's OK event with them) and /diagnostics (each
channel's effect, onset, estimate, interval; the filter's gyro bias) observed from probes, and the same events as
the core (the CLI's) on the same samples."""
import json
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from nav_core import sensor_model
from nav_core.processes import NodeProcess
from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays, stamp_from_s
from nav_core.sensor_model import SensorModel, TriadModel
from nav_core.status import level_name
from sensor_health import noise_sim
from sensor_health.events import Event, cleared_event
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
    """12 s of model noise: ax's sd x3 until 3.5 s (a start-up noise increase that goes away), gz frozen from 6 s
    on (the GNSS path and a bag: test_sensor_health_node_gnss)."""
    n = int(12 * FS)
    t = T0 + np.arange(n) / FS
    x = noise_sim.model_noise(_model(), n, 1 / FS, np.random.default_rng(7))
    early = t < T0 + 3.5
    x[early, 3] += np.sqrt(8) * noise_sim.model_noise(_model(), n, 1 / FS, np.random.default_rng(8))[early, 3]
    x[:, 5] += 9.81
    x[t >= T0 + 6, 2] = x[t >= T0 + 6][0, 2]
    return t, x


FILTER_BIAS = np.array([1.5e-3, -0.5e-3, 2.5e-3])
"""rad/s: the gyro bias the simulated filter has estimated (its odometry's rate is the raw mean less this)."""


def _odometry(t, x, t_epoch, epoch_s=0.5):
    """ins_gps_kf's odometry/filtered at ``t_epoch``: twist.angular the epoch's mean raw rate less FILTER_BIAS."""
    msg = Odometry()
    msg.header.stamp = stamp_from_s(t_epoch)
    w = x[(t > t_epoch - epoch_s) & (t <= t_epoch), :3].mean(axis=0) - FILTER_BIAS
    msg.twist.twist.angular.x, msg.twist.twist.angular.y, msg.twist.twist.angular.z = (float(v) for v in w)
    return msg


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


def test_node_names_faults_like_the_core_with_their_cleared_ok_event_on_a_transient_local_topic_and_in_diagnostics(
        tmp_path, ros_env, rclpy_context):
    path = sensor_model.save(_model(), tmp_path / "model.yaml")
    t, x = _samples()
    epochs = T0 + np.arange(0.5, 12.0, 0.5)  # the filter's 2-Hz epochs
    node = NodeProcess("sensor_health_node", env=ros_env, ros_args={"sensor_model_path": str(path),
                                                                    "diagnostics_period_s": 0.2})
    try:
        # the core runs while the node starts (each its own Monte Carlo, in its own process)
        core = HealthMonitor(_model(), keep_trace=False)
        expected = core.push(t, x[:, :3], x[:, 3:])
        assert [(e.effect, e.channels) for e in expected] == [("white_noise_increase", ["ax"]),
                                                              ("stuck_output", ["gz"])]
        (note,) = core.cleared  # ax's noise went at 5 s: its OK event follows on the topic, before gz's
        published = sorted([e.to_dict() for e in expected] + [cleared_event(note).to_dict()], key=lambda d: d["t_s"])
        assert [d["level"] for d in published] == ["WARN", "OK", "ERROR"]
        assert node.wait_for_line("ready", 60), node.output
        probe = Probe({"/diagnostics": DiagnosticArray})
        feeder = rclpy.create_node("feeder")
        pub = feeder.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
        odom = feeder.create_publisher(Odometry, "odometry/filtered", 100)
        assert probe.spin_until(lambda p: pub.get_subscription_count() > 0 and odom.get_subscription_count() > 0, 20)
        probe.spin_until(lambda p: False, 1.0)  # the node's side of discovery lags ours: best effort would lose
        def summary(count, odometry=0):
            """The latest diagnostics whose summary says ``count`` samples and ``odometry`` epochs were received."""
            def find(p):
                for _, arr in reversed(p.received["/diagnostics"]):
                    for st in arr.status:
                        values = {kv.key: kv.value for kv in st.values}
                        if st.name.endswith(": summary") and int(values.get("received", -1)) >= count \
                                and int(values.get("odometry", -1)) >= odometry:
                            return arr
                return None
            return find
        # paced by what the node reports taken: best effort loses nothing when the reader is never behind
        for a in range(0, len(t), 64):
            for ti, row in zip(t[a:a + 64], x[a:a + 64]):
                pub.publish(imu_from_arrays(ti, row[:3], row[3:]))
                time.sleep(0.0005)
            for te in epochs[(epochs > t[a] - 1 / FS) & (epochs <= t[min(a + 64, len(t)) - 1])]:
                odom.publish(_odometry(t, x, te))
            assert probe.spin_until(summary(min(a + 64, len(t))), 20), \
                f"the node did not take samples {a}..{a + 64}:\n{node.output}"
        assert probe.spin_until(summary(len(t), len(epochs)), 20), node.output
        arr = summary(len(t), len(epochs))(probe)
        statuses = channel_statuses(arr)
        for e in expected:  # each channel's latest event: effect, stamps, estimate and interval as the core's
            for ch in e.channels:
                st, d = statuses[ch], e.to_dict()
                assert (st.effect, st.onset_s, st.t_s) == (e.effect, e.onset_s, e.t_s), (ch, st)
                assert (json.loads(st.estimate), json.loads(st.interval_95)) == (d["estimate"], d["interval_95"])
        assert statuses["gz"].level == "ERROR" and statuses["gx"].effect == "" and statuses["gx"].level == "OK"
        assert statuses["ax"].cleared_s == note["t_s"] and statuses["ax"].level == "OK"  # gone, OK at once
        assert statuses["summary"].events == 2 and statuses["summary"].level == "ERROR"
        values = {st.name.split(": ")[-1]: {kv.key: kv.value for kv in st.values} for st in arr.status}
        assert values["summary"]["filter_bias_epochs"] == "20"  # the last 10 s of 0.5-s epochs
        for c, ch in enumerate(("gx", "gy", "gz")):  # the filter's bias: the raw rate less its corrected one
            assert float(values[ch]["filter_bias_rad_s"]) == pytest.approx(FILTER_BIAS[c], abs=1e-12)
            lo, hi = json.loads(values[ch]["filter_bias_interval_95"])
            assert lo <= hi and lo == pytest.approx(FILTER_BIAS[c], abs=1e-12)

        got = late_events()  # joins after the events (and the OK event) were published
        assert got, "a late subscriber did not get the events (transient local)"
        assert [Event.from_dict(d).to_dict() for d in got] == published
        assert Event.from_dict(got[1]).cleared and got[1]["statistic"] == {"cleared": True, "named_s": note["since_s"]}
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
