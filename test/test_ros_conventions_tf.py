"""The fusion node's REP-105 frames on /tf and /tf_static, and complete odometry (the body rate in the twist)."""


import time  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

rclpy = pytest.importorskip("rclpy")
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

from ins_gps_kf import synthetic as syn  # noqa: E402
from nav_core.processes import NodeProcess  # noqa: E402
from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays, stamp_from_s, stamp_to_s  # noqa: E402
from nav_core.tf_tree import Pose  # noqa: E402
from nav_core.units import DEG  # noqa: E402

RATE, TURN_START_S, YAW_RATE, MAX_SPEED_MPS = 32.0, 35.0, 0.05, 5.0
PARAMS = {"alignment_time_s": 15.0, "imu_rate_hz": RATE, "lever_arm_x_m": 0.4, "lever_arm_z_m": 1.2}


def _fix(t, lat, lon, h, std):
    msg = NavSatFix()
    msg.header.stamp, msg.header.frame_id = stamp_from_s(t), "gps_link"
    msg.status.status = NavSatStatus.STATUS_FIX  # Jazzy's default is STATUS_UNKNOWN
    msg.latitude, msg.longitude, msg.altitude = float(lat / DEG), float(lon / DEG), float(h)
    msg.position_covariance = np.diag(np.asarray(std, float) ** 2).ravel().tolist()
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    return msg


def _pose(tr) -> Pose:
    t, q = tr.transform.translation, tr.transform.rotation
    return Pose.from_xyzw([t.x, t.y, t.z], [q.x, q.y, q.z, q.w])


@pytest.mark.ros
@pytest.mark.slow
def test_tf_tree_and_twist_of_the_fusion_node(ros_env, rclpy_context):
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=10.0, yaw_rate=YAW_RATE)
    rng = np.random.default_rng(9)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    node = NodeProcess("ins_gps_kf_node", env=ros_env, ros_args=PARAMS)
    probe = Probe({"odometry/filtered": Odometry, "/tf": TFMessage}, name="tf_probe", qos=QoSProfile(depth=5000))
    static = Probe({"/tf_static": TFMessage}, name="tf_static_probe", qos=QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    imu_pub = probe.create_publisher(Imu, "imu/data_corrected", SENSOR_QOS)
    gps_pub = probe.create_publisher(NavSatFix, "gps/fix", SENSOR_QOS)
    try:
        assert node.wait_for_line("ready", 60.0), node.output
        assert probe.spin_until(lambda p: imu_pub.get_subscription_count() and gps_pub.get_subscription_count()
                                and p.count_publishers("/tf"), 20.0), node.output
        probe.spin_until(lambda p: False, 1.0)
        events = sorted([(t, 0, i) for i, t in enumerate(gnss.t) if t >= 2.0] + [(t, 1, i) for i, t in enumerate(imu.t)])
        next_t = time.monotonic()
        for _, kind, i in events:
            if kind == 0:
                gps_pub.publish(_fix(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i]))
            else:
                imu_pub.publish(imu_from_arrays(imu.t[i], imu.gyro[i], imu.accel[i]))
            next_t += 1.0 / 150.0
            while time.monotonic() < next_t:
                rclpy.spin_once(probe, timeout_sec=max(0.0, next_t - time.monotonic()))
        probe.spin_until(lambda p: any(stamp_to_s(m.header.stamp) > imu.t[-1] - 1.0
                                       for _, m in p.received["odometry/filtered"]), 20.0)
        assert static.spin_until(lambda p: p.received["/tf_static"], 10.0)  # latched: a late subscriber gets it
    finally:
        node.stop()
        statics = [tr for _, m in static.received["/tf_static"] for tr in m.transforms]
        odom = [m for _, m in probe.received["odometry/filtered"]]
        tf = [tr for _, m in probe.received["/tf"] for tr in m.transforms]
        probe.destroy_node()
        static.destroy_node()

    mounts = {(tr.header.frame_id, tr.child_frame_id): _pose(tr) for tr in statics}
    assert set(mounts) == {("base_link", "imu_link"), ("base_link", "gps_link")}
    assert np.allclose(mounts["base_link", "gps_link"].position, [0.4, 0.0, 1.2])  # the lever arm parameters
    assert np.allclose(mounts["base_link", "imu_link"].position, 0.0)

    by_stamp = {}
    for tr in tf:
        by_stamp.setdefault(round(stamp_to_s(tr.header.stamp), 6), {})[tr.header.frame_id, tr.child_frame_id] = _pose(tr)
    assert len(odom) > 40, node.output
    odom_base_prev, jumps = None, []
    for m in odom:
        t = stamp_to_s(m.header.stamp)
        frames = by_stamp[round(t, 6)]
        map_base = frames["map", "odom"].compose(frames["odom", "base_link"])
        p, q = m.pose.pose.position, m.pose.pose.orientation
        pose = Pose.from_xyzw([p.x, p.y, p.z], [q.x, q.y, q.z, q.w])
        assert np.allclose(map_base.position, pose.position, atol=1e-6)  # map -> odom -> base_link = the pose
        assert (map_base.rotation.inv() * pose.rotation).magnitude() < 1e-6
        if odom_base_prev is not None:  # odom moves no farther than the vehicle (5 m/s at most) in an epoch
            step = np.linalg.norm(odom_base_prev.between(frames["odom", "base_link"]).position)
            assert step <= 0.5 * MAX_SPEED_MPS * 1.3, (t, step)
        odom_base_prev = frames["odom", "base_link"]
        jumps.append(np.linalg.norm(frames["map", "odom"].position))
        w = m.twist.twist.angular
        cov = np.reshape(m.twist.covariance, (6, 6))
        assert np.all(np.diag(cov)[3:] > 0)
        expected = YAW_RATE if t > TURN_START_S + 0.25 else 0.0  # an epoch is the 0.5 s up to its stamp
        assert w.z == pytest.approx(expected, abs=0.004 + 3 * np.sqrt(cov[5, 5])), t
    assert max(jumps) > 1.0  # the GPS corrections (here: the heading taken from the course) are in map -> odom
