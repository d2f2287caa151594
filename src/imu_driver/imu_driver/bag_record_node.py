"""``bag_record``: record topics into a new rosbag2 bag (sqlite3 or MCAP) that ``ros2 bag`` reads.

Topics are discovered by name (like ``ros2 bag record``): each is subscribed
as serialized CDR as soon as a publisher of it appears, with the QoS its publishers
offer (as rosbag2 adapts it): reliable when every publisher is reliable (odometry,
diagnostics, /tf), best effort otherwise (sensor data); transient local when every
publisher is (/tf_static, so the latched transforms are recorded). The offered QoS
go into the bag's metadata (``offered_qos_profiles``), so ``ros2 bag play`` offers
them again. Queues are drained in batches every
``intake_period_s`` (:class:`nav_core.ros_node.PolledSubscription`): one executor
callback per message lost messages of a 640 Hz topic on a busy machine. Log time is
the receive time: the middleware's receive stamp moved onto the node clock.
"""
from __future__ import annotations

import time

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from imu_driver.bag_play_node import message_class
from nav_core import units
from nav_core.bagio import BagWriter
from nav_core.params import ConfigError, Param
from nav_core.ros_node import PolledSubscription, declare_parameters, run_node

PARAMS = (
    Param("output", "", "path of the new bag folder (must not exist)"),
    Param("topics", ["imu/data_raw", "gps/fix"], "topics to record"),
    Param("storage", "sqlite3", "storage plugin", choices=("sqlite3", "mcap")),
    Param("discovery_period_s", 0.5, "how often to look for the topics, s", 0.05, 60.0),
    Param("intake_period_s", 0.01, "queues are drained at this period, s", 0.0005, 1.0),
    Param("input_queue_depth", 20000, "messages each topic's subscription holds until written: a recorder held up "
          "(a busy CPU, a slow disk) catches up instead of losing what the filter received; as the filter's", 100,
          1000000),
)


class BagRecorder(Node):
    """Subscribes to the wanted topics as they appear and writes every message."""

    def __init__(self, **kwargs):
        super().__init__("bag_record", **kwargs)
        self.p = declare_parameters(self, PARAMS)
        if not self.p["output"]:
            raise ConfigError("parameter 'output': a path for the new bag is required")
        try:
            self.writer = BagWriter(self.p["output"], self.p["storage"]).__enter__()
        except Exception as err:
            raise ConfigError(f"parameter 'output': cannot create bag {self.p['output']}: {err}") from err
        self.wanted = {"/" + t.lstrip("/") for t in self.p["topics"] if t}
        self.counts = {}
        self._subs = {}
        self._last_log_ns = 0
        # steady clock: under use_sim_time no /clock ticks before the player starts, and the recorder
        # must be subscribed by then (a sim-time timer only fired once playing had begun: the start was lost)
        self.create_timer(self.p["discovery_period_s"], self._discover, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._discover()
        self.get_logger().info(f"ready: recording {sorted(self.wanted)} to {self.p['output']}")

    def _discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self.wanted and topic not in self._subs and types:
                cls = message_class(types[0])
                if cls is None:
                    self.get_logger().warning(f"cannot record {topic}: type {types[0]} not installed")
                    continue
                offered = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
                if not offered:
                    continue  # only subscribers so far: wait for a publisher and its QoS
                self.writer.add_topic(topic, types[0], [bag_qos(q) for q in offered])
                qos = subscription_qos(offered, self.p["input_queue_depth"])
                self._subs[topic] = PolledSubscription(self, cls, topic, self._writer_for(topic, types[0]),
                                                       self.p["intake_period_s"], qos)
                self.counts[topic] = 0
                self.get_logger().info(f"recording {topic} ({types[0]}, {qos.reliability.name.lower()})")

    def _writer_for(self, topic: str, msgtype: str):
        def write(taken):
            now_ns, wall_ns = self.get_clock().now().nanoseconds, time.time_ns()
            for data, received_ns in taken:
                # a stale /clock (sim time) can make the wall-clock back-dating overlap the previous batch:
                # log times never go back, so readers keep the order messages were received in
                self._last_log_ns = max(now_ns - max(0, wall_ns - received_ns), self._last_log_ns + 1)
                self.writer.write_cdr(topic, msgtype, self._last_log_ns, data)
            self.counts[topic] += len(taken)
        return write

    def close(self) -> None:
        """Write what is still queued, finish the bag (writes metadata.yaml)."""
        for sub in self._subs.values():
            try:
                sub.drain()
            except Exception:  # the context may already be shut down on SIGINT; the bag must still be closed
                break
        self.writer.__exit__(None, None, None)
        self.get_logger().info(f"closed {self.p['output']}: {self.counts}")


def subscription_qos(offered, depth: int) -> QoSProfile:
    """The QoS (queue ``depth`` messages) that receives everything the publishers (their ``offered`` QoSProfiles)
    send: reliable only when every one is reliable, transient local only when every one is (a reliable subscriber
    does not match a best-effort publisher, a transient-local one does not match a volatile one)."""
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def bag_qos(q: QoSProfile) -> Qos:
    """rclpy QoSProfile -> rosbags Qos (the rmw enum values and durations rosbag2 writes in its metadata)."""
    def span(duration) -> QosTime:
        ns = duration.nanoseconds
        return QosTime(*units.sec_nanosec(ns))

    return Qos(QosHistory(int(q.history)), int(q.depth), QosReliability(int(q.reliability)),
               QosDurability(int(q.durability)), span(q.deadline), span(q.lifespan),
               QosLiveliness(int(q.liveliness)), span(q.liveliness_lease_duration),
               bool(q.avoid_ros_namespace_conventions))


def main(args=None) -> int:
    """Entry point of ``bag_record``."""
    return run_node(BagRecorder, args, usage=(
        "bag_record",
        "Record topics into a new rosbag2 bag (sqlite3 or MCAP) that ros2 bag reads.",
        PARAMS,
        'bag_record --ros-args -p output:=my_bag -p "topics:=[imu/data_raw, gps/fix]"'))


if __name__ == "__main__":
    raise SystemExit(main())
