"""bag_record subscribes with the QoS its publishers offer and writes that QoS into the bag's metadata."""
import time

import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from nav_core.processes import NodeProcess

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.mark.ros
@pytest.mark.parametrize("storage", ["mcap"])
def test_bag_record_takes_the_offered_qos_and_records_it(tmp_path, rclpy_context, storage):
    """(DDS discovery does not carry history and depth: they are recorded as rmw reports them, unknown.)"""
    import rclpy
    from rosbags.interfaces import QosDurability, QosReliability
    from rosbags.rosbag2 import Reader
    from std_msgs.msg import String

    node = rclpy.create_node("qos_publisher")
    latched = node.create_publisher(String, "/latched", LATCHED)
    reliable = node.create_publisher(String, "/reliable", 10)
    sensor = node.create_publisher(String, "/sensor", qos_profile_sensor_data)
    latched.publish(String(data="sent before the recorder started"))
    recorder = NodeProcess("bag_record", env=rclpy_context, ros_args={
        "output": str(tmp_path / "bag"), "storage": storage, "topics": "[/latched, /reliable, /sensor]",
        "discovery_period_s": 0.1})
    try:
        assert recorder.wait_for_line("ready", 20), recorder.output
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(
                not node.get_subscriptions_info_by_topic(t) for t in ("/latched", "/reliable", "/sensor")):
            rclpy.spin_once(node, timeout_sec=0.1)
        subs = {t: node.get_subscriptions_info_by_topic(t)[0].qos_profile for t in ("/latched", "/reliable", "/sensor")}
        assert subs["/reliable"].reliability == ReliabilityPolicy.RELIABLE
        assert subs["/sensor"].reliability == ReliabilityPolicy.BEST_EFFORT
        assert subs["/latched"].durability == DurabilityPolicy.TRANSIENT_LOCAL
        time.sleep(0.5)
        for i in range(200):
            reliable.publish(String(data=str(i)))
        time.sleep(1.5)
    finally:
        assert recorder.stop() == 0, recorder.output
        node.destroy_node()
    with Reader(tmp_path / "bag") as reader:
        conns = {c.topic: c for c in reader.connections}
        counts = {t: c.msgcount for t, c in conns.items()}
        offered = {t: c.ext.offered_qos_profiles for t, c in conns.items()}
    assert counts["/latched"] == 1  # the transient-local subscription got the message published before it
    assert counts["/reliable"] == 200  # reliable: nothing lost however fast it was sent
    assert [q.reliability for q in offered["/reliable"]] == [QosReliability.RELIABLE]
    assert [q.durability for q in offered["/latched"]] == [QosDurability.TRANSIENT_LOCAL]
    assert "/sensor" not in conns or [q.reliability for q in offered["/sensor"]] == [QosReliability.BEST_EFFORT]
