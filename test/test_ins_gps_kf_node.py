"""ins_gps_kf_node as a process: same output as the offline replay, diagnostics, bad config, time jumps."""


import time  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

rclpy = pytest.importorskip("rclpy")
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402

from rclpy.qos import QoSProfile  # noqa: E402

from nav_core import frames, recording  # noqa: E402
from nav_core.processes import NodeProcess  # noqa: E402
from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays, stamp_from_s  # noqa: E402
from nav_core.units import DEG  # noqa: E402
from ins_gps_kf import synthetic as syn  # noqa: E402
from ins_gps_kf.replay import replay_files  # noqa: E402

pytestmark = pytest.mark.ros
RATE = 32.0
PARAMS = {"alignment_time_s": 15.0, "imu_rate_hz": RATE}


def _fix_msg(t, lat, lon, h, std, status=0):
    msg = NavSatFix()
    msg.header.stamp = stamp_from_s(t)
    msg.header.frame_id = "gps_link"
    msg.status.status = int(status)
    msg.latitude, msg.longitude, msg.altitude = float(lat / DEG), float(lon / DEG), float(h)
    msg.position_covariance = np.diag(np.asarray(std, float) ** 2).ravel().tolist()
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    return msg


def _drive():
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=10.0)
    rng = np.random.default_rng(9)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    # no fix in the first 2 s: the IMU messages before the first fix (ignored by node and replay alike)
    # are a lead-in, so a best-effort message lost while DDS settles changes nothing
    late = gnss.t >= 2.0
    return imu, type(gnss)(gnss.t[late], gnss.lat[late], gnss.lon[late], gnss.h[late], gnss.std_enu[late])


def _events(imu, gnss, imu_delay_s=0.0, gnss_received=None):
    """Publication order: by stamp (fixes: by ``gnss_received`` if given), the IMU ``imu_delay_s`` behind
    (a denoiser's window delays it)."""
    received = gnss.t if gnss_received is None else gnss_received
    events = [(t, 0, i) for i, t in enumerate(received)] + [(t + imu_delay_s, 1, i) for i, t in enumerate(imu.t)]
    return sorted(events)


class Feeder:
    """Probe plus publishers on the node's input topics."""

    def __init__(self):
        self.probe = Probe({"imu/data": Imu, "/diagnostics": DiagnosticArray})
        # odometry is reliable: a deep reliable queue keeps every epoch of a faster-than-real-time feed
        self.odom = Probe({"odometry/filtered": Odometry}, name="odom_probe", qos=QoSProfile(depth=1000))
        self.imu_pub = self.probe.create_publisher(Imu, "imu/data_corrected", SENSOR_QOS)
        self.gps_pub = self.probe.create_publisher(NavSatFix, "gps/fix", SENSOR_QOS)

    def wait_connected(self, timeout_s=20.0):
        return self.probe.spin_until(lambda p: self.imu_pub.get_subscription_count() > 0
                                     and self.gps_pub.get_subscription_count() > 0
                                     and p.count_publishers("odometry/filtered") > 0
                                     and self.odom.count_publishers("odometry/filtered") > 0, timeout_s)

    def play(self, imu, gnss, msgs_per_s=150.0, imu_delay_s=0.0, gnss_received=None):
        period = 1.0 / msgs_per_s
        next_t = time.monotonic()
        for _, kind, i in _events(imu, gnss, imu_delay_s, gnss_received):
            if kind == 0:
                self.gps_pub.publish(_fix_msg(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i],
                                              gnss.status[i]))
            else:
                self.imu_pub.publish(imu_from_arrays(imu.t[i], imu.gyro[i], imu.accel[i]))
            next_t += period
            while time.monotonic() < next_t:
                rclpy.spin_once(self.probe, timeout_sec=0.0)
                rclpy.spin_once(self.odom, timeout_sec=max(0.0, next_t - time.monotonic()))


@pytest.fixture
def feeder(rclpy_context):
    f = Feeder()
    yield f
    f.probe.destroy_node()
    f.odom.destroy_node()


@pytest.mark.slow
# in stamp order the equality is test_ins_gps_kf_node_wheel's (a bag played, with the odometer and NHC on)
@pytest.mark.parametrize("imu_delay_s", [1.5], ids=["imu_arriving_behind_the_fixes"])
def test_node_output_equals_offline_replay_of_the_same_messages(ros_env, feeder, tmp_path, imu_delay_s):
    imu, gnss = _drive()
    bag = recording.write_bag(tmp_path / "bag", imu, gnss, imu_topic="imu/data_corrected")
    traj, _ = replay_files(bag, None, "default", tmp_path / "replay.csv", PARAMS, plot=False, progress=False)
    node = NodeProcess("ins_gps_kf_node", env=ros_env, ros_args=PARAMS)
    try:
        assert node.wait_for_line("ready", 30.0), node.output
        assert feeder.wait_connected(), node.output
        feeder.probe.spin_until(lambda p: False, 1.0)  # let both ends of every match settle
        feeder.play(imu, gnss, imu_delay_s=imu_delay_s)
        last = traj.t[traj.t < imu.t[-1] - 0.2][-1]
        assert feeder.odom.spin_until(lambda p: any(
            abs(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec - last) < 1e-6
            for _, m in p.received["odometry/filtered"]), 20.0), node.output
    finally:
        node.stop()
    feeder.probe.spin_until(lambda p: False, 1.5)  # collect the last diagnostics
    odom = [m for _, m in feeder.odom.received["odometry/filtered"]]
    assert len(odom) >= len(traj) - 2, node.output
    by_t = {round(t, 6): i for i, t in enumerate(traj.t)}
    for m in odom:
        i = by_t[round(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, 6)]
        p = m.pose.pose.position
        np.testing.assert_allclose([p.x, p.y, p.z], [traj.extra[k][i] for k in ("e_m", "n_m", "u_m")], atol=1e-6)
        q = m.pose.pose.orientation
        roll, pitch, yaw = frames.euler_from_quat_xyzw([q.x, q.y, q.z, q.w])
        assert frames.wrap_angle(yaw - traj.yaw[i]) == pytest.approx(0.0, abs=1e-8)
        assert m.pose.covariance[0] == pytest.approx(traj.extra["std_e"][i] ** 2, rel=1e-8)
        assert m.header.frame_id == "map" and m.child_frame_id == "base_link"
    oriented = [m for _, m in feeder.probe.received["imu/data"]]
    assert oriented and oriented[-1].orientation_covariance[0] > 0.0
    diags = [s for _, a in feeder.probe.received["/diagnostics"] for s in a.status if "ins_gps_kf" in s.name]
    values = {kv.key: kv.value for kv in diags[-1].values}
    for key in ("state", "last_nis", "rejected_fixes", "gps_age_s", "alignment"):
        assert key in values
    assert values["alignment"] == "aligned"
    assert values["late_dropped"] == "0"  # a fix waits for the IMU to pass it, however far behind the IMU is


def test_node_reports_a_time_jump_and_realigns(ros_env, feeder):
    imu, gnss = _drive()
    node = NodeProcess("ins_gps_kf_node", env=ros_env, ros_args={**PARAMS, "alignment_time_s": 5.0})
    try:
        assert node.wait_for_line("ready", 30.0), node.output
        assert feeder.wait_connected(), node.output
        def first(n_s):
            keep = gnss.t < n_s
            return imu.select(imu.t < n_s), type(gnss)(gnss.t[keep], gnss.lat[keep], gnss.lon[keep], gnss.h[keep],
                                                        gnss.std_enu[keep])
        feeder.play(*first(10.0), msgs_per_s=400.0)
        feeder.play(*first(4.0), msgs_per_s=400.0)  # the bag restarts: stamps jump back by ~6 s
        assert node.wait_for_line("time jump", 10.0), node.output

        def reset_reported(p):
            for _, arr in p.received["/diagnostics"]:
                for s in arr.status:
                    vals = {kv.key: kv.value for kv in s.values}
                    if "stamp jumped back" in vals.get("last_reset", ""):
                        return True
            return False
        assert feeder.probe.spin_until(reset_reported, 5.0)
    finally:
        node.stop()


def test_node_with_a_bad_config_exits_2_with_a_message(ros_env):
    node = NodeProcess("ins_gps_kf_node", env=ros_env, ros_args={"gate_probability": 0.1})
    try:
        node.proc.wait(timeout=30.0)
    finally:
        code = node.stop()
    assert code == 2
    assert "gate_probability" in node.output


@pytest.mark.slow
def test_a_nan_imu_sample_and_a_gnss_clock_step_are_counted_never_published_and_sigint_exits_0(ros_env, feeder):
    imu, gnss = _drive()
    bad = int(np.searchsorted(imu.t, 38.0))  # while navigating
    imu.gyro[bad] = np.nan
    imu.accel[bad + 5] = np.inf
    received = gnss.t.copy()
    stepped = gnss.t >= 33.0
    gnss.t[stepped] -= 100.0  # the GNSS clock steps back 100 s; the fixes come as before
    node = NodeProcess("ins_gps_kf_node", env=ros_env, ros_args=PARAMS)
    try:
        assert node.wait_for_line("ready", 30.0), node.output
        assert feeder.wait_connected(), node.output
        feeder.probe.spin_until(lambda p: False, 1.0)
        feeder.play(imu, gnss, msgs_per_s=400.0, gnss_received=received)
        feeder.odom.spin_until(lambda p: False, 2.0)
        feeder.probe.spin_until(lambda p: False, 1.5)  # a diagnostics period after the last message
    finally:
        code = node.stop()
    assert code == 0, node.output
    assert "Traceback" not in node.output
    odom = [m for _, m in feeder.odom.received["odometry/filtered"]]
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in odom]
    assert stamps and max(stamps) > imu.t[bad] + 5.0  # it kept publishing after the bad samples
    for m in odom:
        p, q = m.pose.pose.position, m.pose.pose.orientation
        assert np.all(np.isfinite([p.x, p.y, p.z, q.x, q.y, q.z, q.w, *m.pose.covariance, *m.twist.covariance]))
    assert all(np.all(np.isfinite([m.orientation.x, m.orientation.w])) for _, m in feeder.probe.received["imu/data"])
    diags = [s for _, a in feeder.probe.received["/diagnostics"] for s in a.status if "ins_gps_kf" in s.name]
    values = {kv.key: kv.value for kv in diags[-1].values}
    # the core rejects and counts the two samples (its counters reach the diagnostics), the node published nothing bad
    assert values["imu_nonfinite"] == "2", values
    assert values["nonfinite_estimates"] == "0" and values["processing_errors"] == "0", values
    assert values["state"] == "navigating"
    assert node.output.count("ERROR") <= 1
    # the stepped fixes reach the filter where they arrived: the step is found and the fixes used again
    assert values["fixes_stamped_back"] == str(int(stepped.sum())) and values["late_fixes"] == "0", values
    assert values["gnss_clock_steps"] == "1" and float(values["gps_age_s"]) < 2.0, values
    assert "GNSS clock step" in node.output
