"""``bag_play``: publish a rosbag2 bag's messages with their original timing and ``/clock`` (for use_sim_time).

Plays every topic whose type is importable here (sensor_msgs, nav_msgs, ...)
or the ones named in ``topics``. Each topic is offered with the QoS recorded in the bag
(``offered_qos_profiles``, as ``ros2 bag play`` does: reliable and transient local only when
every recorded publisher was, so ``/tf_static`` stays latched); a bag without them plays sensor
topics with the sensor-data QoS and the rest reliable. A damaged bag plays every intact message
(MCAP is read past the damage, a cut sqlite file up to it) and the error names the file and position.
With ``wait_for_subscribers`` it plays once every topic has that many subscribers; with ``wait_for_readers``
(``topic=node,node``) once each named node subscribes that topic (a count alone is met early when a topic has
more readers than another, or by a stray one); then ``settle_s`` later: a subscriber this node counts may not
count this publisher yet, and would lose the start.
"""
from __future__ import annotations

import importlib
import threading
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from nav_core import bagio, units
from nav_core.params import ConfigError, Param, did_you_mean
from nav_core.ros_node import SENSOR_QOS, declare_parameters, link_publisher, run_node


PARAMS = (
    Param("bag", "", "rosbag2 bag to play: folder, .db3 or .mcap"),
    Param("rate", 1.0, "playback speed multiplier", 0.01, 1000.0),
    Param("start_offset_s", 0.0, "skip this much of the bag's start, s", 0.0, 1e9),
    Param("loop", False, "play again from the start when done"),
    Param("topics", [""], "topics to play (empty: all with a known type)"),
    Param("publish_clock", True, "publish /clock with the bag's time"),
    Param("clock_rate_hz", 100.0, "/clock messages per wall second (as ros2 bag play --clock)", 1.0, 10000.0),
    Param("start_delay_s", 0.5, "wait this long after start so subscribers can connect, s", 0.0, 60.0),
    Param("wait_for_subscribers", 0, "before playing, wait until every topic has this many subscribers", 0, 100),
    Param("wait_for_readers", [""], "before playing, wait until these nodes subscribe: 'topic=node,node' "
          "entries (node names; the topic's other subscribers still count toward wait_for_subscribers)"),
    Param("wait_timeout_s", 30.0, "give up waiting for subscribers after this long, s", 0.0, 3600.0),
    # a subscriber this node counts may not count this publisher yet (DDS discovery is matched on each
    # side apart): what is played before it does is lost to it, never to a recorder that subscribes later
    Param("settle_s", 0.5, "after the subscribers are counted, wait this long before playing, s", 0.0, 60.0),
    Param("exit_when_done", True, "shut down after the last message"),
)


def message_class(msgtype: str):
    """The rclpy message class of ``pkg/msg/Name``, or None if it is not installed."""
    pkg, _, name = msgtype.split("/")
    try:
        return getattr(importlib.import_module(f"{pkg}.msg"), name)
    except (ImportError, AttributeError):
        return None


class BagPlayer(Node):
    """Replays a bag from a background thread; the executor stays free."""

    def __init__(self, **kwargs):
        super().__init__("bag_play", **kwargs)
        self.p = declare_parameters(self, PARAMS)
        if not self.p["bag"] or not bagio.is_bag(self.p["bag"]):
            raise ConfigError(f"parameter 'bag': {self.p['bag']!r} is not a rosbag2 bag (folder, .db3, .mcap)")
        wanted = [t for t in self.p["topics"] if t]
        self.publishers_by_topic = self._make_publishers(wanted)
        self.readers = parse_readers(self.p["wait_for_readers"], self.publishers_by_topic)
        self.clock_pub = self.create_publisher(Clock, "/clock", QoSProfile(depth=10))
        self.played = 0
        self.error = ""
        self._stop = threading.Event()
        self.done = threading.Event()
        self._thread = threading.Thread(target=self._play, name="bag_play", daemon=True)
        self._thread.start()
        self.create_timer(0.2, self._check_done)
        self.get_logger().info(f"ready: playing {self.p['bag']} topics {sorted(self.publishers_by_topic)} "
                               f"at {self.p['rate']}x")

    def _make_publishers(self, wanted) -> dict:
        pubs = {}
        recorded_qos = bagio.offered_qos(self.p["bag"])
        present = bagio.topics(self.p["bag"])
        absent = sorted({bagio.norm_topic(t) for t in wanted} - set(present))
        if absent:  # a misspelt topic would play the rest and leave the graph without it, silently
            raise ConfigError(f"parameter 'topics': {absent} not in bag {self.p['bag']}"
                              f"{did_you_mean(absent[0], present)}; it has {sorted(present)}")
        for topic, msgtype in present.items():
            if wanted and topic not in {bagio.norm_topic(t) for t in wanted}:
                continue
            cls = message_class(msgtype)
            if cls is None:
                self.get_logger().warning(f"skipping {topic}: type {msgtype} is not installed")
                continue
            qos = playback_qos(recorded_qos.get(topic)) or (SENSOR_QOS if msgtype in bagio.SENSOR_TYPES
                                                            else QoSProfile(depth=100))
            # overridable per run (nav-demo makes the sensor data reliable and kept: nav_bringup.hosts.link_qos)
            pubs[topic] = (cls, link_publisher(self, cls, "/" + topic, qos))
        if not pubs:
            raise ConfigError(f"bag {self.p['bag']}: no playable topics")
        return pubs

    def _wait_for_subscribers(self) -> None:
        want, start = self.p["wait_for_subscribers"], time.monotonic()
        if not want and not self.readers:
            return
        while self._missing(want):
            if self._stop.is_set():
                return
            if time.monotonic() > start + self.p["wait_timeout_s"]:
                self.get_logger().warning(f"playing without {self._missing(want)} after waiting")
                break
            time.sleep(0.05)
        counted = time.monotonic() - start
        self._stop.wait(self.p["settle_s"])  # the subscribers' side of discovery lags ours (seen: 2 s)
        counts = {t: pub.get_subscription_count() for t, (_, pub) in sorted(self.publishers_by_topic.items())}
        named = {t: sorted(self._subscriber_names(t)) for t in sorted(self.readers)}
        self.get_logger().info(f"playing: subscribers {counts}, readers {named}, counted after {counted:.2f} s, "
                               f"then {self.p['settle_s']:.1f} s to settle")

    def _missing(self, want: int) -> list:
        """What playing still waits for: 'topic: N subscribers' and 'topic: node' entries (empty: nothing)."""
        missing = []
        for topic, (_, pub) in sorted(self.publishers_by_topic.items()):
            names = self.readers.get(topic, set())
            # a named reader found in the graph but not yet matched to this publisher is not counted yet
            need = max(want, len(names))
            if pub.get_subscription_count() < need:
                missing.append(f"{topic}: {need} subscribers")
            missing += [f"{topic}: {n}" for n in sorted(names - self._subscriber_names(topic))]
        return missing

    def _subscriber_names(self, topic: str) -> set:
        """The names of the nodes subscribing ``topic`` (the graph's view, not yet matched)."""
        return {info.node_name for info in self.get_subscriptions_info_by_topic("/" + topic)}

    def _play(self) -> None:
        if self._stop.wait(self.p["start_delay_s"]):  # Ctrl-C during the delay ends at once
            self.done.set()
            return
        self._wait_for_subscribers()
        while not self._stop.is_set():
            self._play_once()
            if not self.p["loop"] or self.error:
                break
        self.done.set()

    def _play_once(self) -> None:
        rate, offset_ns = self.p["rate"], int(self.p["start_offset_s"] * 1e9)
        first_ns, wall0, next_clock_ns = None, None, None
        # /clock at a wall rate, not once per message: every use_sim_time node wakes for each one
        clock_step_ns = max(1, int(1e9 * rate / self.p["clock_rate_hz"]))
        last_ns = None
        try:
            for topic, _, log_ns, raw in bagio.iter_raw(self.p["bag"], list(self.publishers_by_topic)):
                if first_ns is None:
                    first_ns = log_ns + offset_ns
                    wall0 = time.monotonic()
                    next_clock_ns = first_ns
                if log_ns < first_ns:
                    continue
                while next_clock_ns <= log_ns and not self._stop.is_set():
                    self._wait_until(wall0 + (next_clock_ns - first_ns) * 1e-9 / rate)
                    self._publish_clock(next_clock_ns)
                    next_clock_ns += clock_step_ns
                if self._stop.is_set():
                    return
                self._wait_until(wall0 + (log_ns - first_ns) * 1e-9 / rate)
                self.publishers_by_topic[topic][1].publish(raw)  # the recorded CDR as it is
                self.played += 1
                last_ns = log_ns
        except bagio.BagDamage as err:  # raised once every intact message was played
            self.error = str(err)
            self.get_logger().error(f"stopped at damage after {self.played} messages: {err}")
        if last_ns is not None:  # the clock reaches the last message, damaged bag or not
            self._publish_clock(last_ns)

    def _publish_clock(self, ns: int) -> None:
        if self.p["publish_clock"]:
            msg = Clock()
            msg.clock.sec, msg.clock.nanosec = units.sec_nanosec(ns)
            self.clock_pub.publish(msg)

    def _wait_until(self, deadline: float) -> None:
        delay = deadline - time.monotonic()
        if delay > 0:
            self._stop.wait(delay)

    def _check_done(self) -> None:
        if self.done.is_set() and self.p["exit_when_done"]:
            self.get_logger().info(f"done: played {self.played} messages")
            self.done.clear()
            rclpy.try_shutdown()

    def close(self) -> None:
        """Stop the playback thread."""
        self._stop.set()
        self._thread.join(timeout=2.0)


def parse_readers(entries, played) -> dict:
    """``wait_for_readers`` entries ``topic=node,node`` -> {topic: {node names}}; each topic must be played."""
    readers = {}
    for entry in (e for e in entries if e):
        topic, sep, names = entry.partition("=")
        nodes = {n.strip() for n in names.split(",") if n.strip()}
        if not sep or not topic.strip() or not nodes:
            raise ConfigError(f"parameter 'wait_for_readers': {entry!r} is not 'topic=node[,node...]'")
        topic = bagio.norm_topic(topic.strip())
        if topic not in played:
            raise ConfigError(f"parameter 'wait_for_readers': {topic!r} is not played"
                              f"{did_you_mean(topic, played)}; playing {sorted(played)}")
        readers.setdefault(topic, set()).update(nodes)
    return readers


def playback_qos(offered) -> QoSProfile | None:
    """The QoS to offer a topic again from its recorded publishers' (rosbags ``Qos`` list); None if unknown."""
    if not offered:
        return None
    reliable = all(q.reliability.name == "RELIABLE" for q in offered)
    latched = all(q.durability.name == "TRANSIENT_LOCAL" for q in offered)
    return QoSProfile(depth=100,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def main(args=None) -> int:
    """Entry point of ``bag_play``."""
    return run_node(BagPlayer, args, usage=(
        "bag_play",
        "Publish a rosbag2 bag's messages with their original timing, and /clock for nodes with use_sim_time.",
        PARAMS,
        "bag_play --ros-args -p bag:=out/katwijk/bag -p rate:=2.0"))


if __name__ == "__main__":
    raise SystemExit(main())
