"""bag_record subscribes with the QoS its publishers offer and writes that QoS into the bag's metadata;
bag_play offers it again (a latched topic stays latched)."""
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
    node.destroy_publisher(latched)  # from now on only bag_play can deliver it
    player = NodeProcess("bag_play", env=rclpy_context, ros_args={
        "bag": str(tmp_path / "bag"), "start_delay_s": 0.0, "exit_when_done": False, "publish_clock": False})
    try:
        assert player.wait_for_line("ready", 20), player.output
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and len(node.get_publishers_info_by_topic("/reliable")) < 2:
            rclpy.spin_once(node, timeout_sec=0.1)
        infos = node.get_publishers_info_by_topic("/reliable")
        played = [i.qos_profile for i in infos if i.node_name != "qos_publisher"]
        assert played and played[0].reliability == ReliabilityPolicy.RELIABLE, [(i.node_name, i.qos_profile) for i in infos]
        time.sleep(2.0)  # played out: a subscriber that comes now still gets the latched message
        late = []
        node.create_subscription(String, "/latched", late.append, LATCHED)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not [m for m in late if "before the recorder" in m.data]:
            rclpy.spin_once(node, timeout_sec=0.1)
        assert any(m.data == "sent before the recorder started" for m in late)
    finally:
        player.stop()
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


def test_a_bag_written_offline_records_the_qos_our_publishers_offer_and_plays_with_it(tmp_path):
    import numpy as np
    from rosbags.interfaces import QosDurability, QosReliability

    from imu_driver.bag_play_node import playback_qos
    from nav_core import bagio, recording
    from nav_core.recording import ImuRecording

    rec = ImuRecording(1.7e9 + np.arange(64) / 64, np.zeros((64, 3)), np.tile([0.0, 0.0, 9.8], (64, 1)))
    bag = recording.write_bag(tmp_path / "bag", rec, storage="mcap")
    with bagio.BagWriter(tmp_path / "tf", "mcap") as writer:
        writer.write_cdr("/tf_static", "tf2_msgs/msg/TFMessage", 1, b"\x00\x01\x00\x00\x00\x00\x00\x00")
    qos = {**bagio.offered_qos(bag), **bagio.offered_qos(tmp_path / "tf")}
    # was: empty offered_qos_profiles in every bag but bag_record's
    assert qos["imu/data_raw"][0].reliability == QosReliability.BEST_EFFORT
    assert qos["tf_static"][0].durability == QosDurability.TRANSIENT_LOCAL
    played = playback_qos(qos["imu/data_raw"])
    assert played is not None and played.reliability == ReliabilityPolicy.BEST_EFFORT
    assert playback_qos(qos["tf_static"]).durability == DurabilityPolicy.TRANSIENT_LOCAL
