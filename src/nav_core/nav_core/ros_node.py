"""rclpy helpers shared by every node: main loop, declared parameters, diagnostics, Imu conversion, probe.

The only module of ``nav_core`` that imports rclpy.
"""
from __future__ import annotations

import copy
import faulthandler
import gc
import sys
import threading
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.callback_groups import CallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.qos_overriding_options import QoSOverridingOptions
from geometry_msgs.msg import Vector3
from sensor_msgs.msg import Imu

from nav_core.cli import help_wanted, node_help
from nav_core import units
from nav_core.imu_cdr import ImuBatch, ImuCdrError, decode_imu, encode_imu
from nav_core.params import ConfigError
from nav_core.params_ros import declare_parameters, init_error_line  # noqa: F401  (re-exported)

SENSOR_QOS = qos_profile_sensor_data
"""Best-effort QoS of sensor topics: a reliable subscriber will not connect to them."""

SENSOR_QOS_IN = QoSProfile(depth=500, reliability=ReliabilityPolicy.BEST_EFFORT)
"""Subscriptions to sensor topics: best effort like the publishers, but a deep queue, so a node that
falls behind for a moment (a GC pause, a busy core) catches up instead of dropping samples."""

LINK_QOS = QoSOverridingOptions.with_default_policies()
"""Endpoints of a topic that may cross a link between hosts (imu/data_raw, gps/fix): their reliability, history
and depth can be set per run with ``-p qos_overrides./TOPIC.publisher.reliability:=reliable`` (and ``depth``;
``subscription`` on the reader's side), the ROS 2 way; nav-demo --hosts 2 sets them (nav_bringup.hosts)."""


def link_publisher(node: Node, msg_type, topic: str, qos: QoSProfile = SENSOR_QOS):
    """A publisher of a topic that may cross a link between hosts: ``qos`` overridable per run (:data:`LINK_QOS`)."""
    # copied: rclpy writes the overrides into the profile it is given, and SENSOR_QOS is rclpy's shared one
    return node.create_publisher(msg_type, topic, copy.copy(qos), qos_overriding_options=LINK_QOS)


RCLError = _rclpy.RCLError
SHUTDOWN_DUMP_S = 8.0
"""A node still shutting down this long after its spin ended prints every thread's stack (the runners kill at 10 s)."""

DIAG_LEVELS = {"OK": DiagnosticStatus.OK, "WARN": DiagnosticStatus.WARN,
               "ERROR": DiagnosticStatus.ERROR, "STALE": DiagnosticStatus.STALE}


def run_node(node_factory, args=None, usage=None) -> int:
    """The ros2/demos main: init, build, spin, shut down cleanly; a ConfigError exits with status 2.

    ``usage`` (``(prog, purpose, params, example)`` for :func:`nav_core.cli.node_help`) is printed for
    ``-h``/``--help`` (before any ``--ros-args``), and the node is not started. A process's main only: once the
    node has run, the heap is left frozen for the exit (:func:`release_heap_before_exit`).
    """
    if usage is not None and help_wanted(sys.argv[1:] if args is None else args):
        print(node_help(*usage))
        return 0
    try:
        rclpy.init(args=args)
    except Exception as err:  # rcl refuses a params file it cannot read or parse, or bad --ros-args
        print(f"[ERROR] configuration: {init_error_line(err)}", flush=True)
        return 2
    node = None
    status = 0
    try:
        node = node_factory()
        rclpy.spin(node)
    except ConfigError as err:
        print(f"[ERROR] configuration: {err}", flush=True)
        status = 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RCLError:
        if rclpy.ok():
            raise
        # SIGINT's shutdown landed between the executor's check of the context and its making a wait set (or
        # guard condition): rclpy raises RCLError there, not ExternalShutdownException; the same clean stop
    finally:
        # armed for every node as soon as the spin ends, and never cancelled: a hang anywhere in the shutdown (a
        # node's close, destroy_node, rclpy's shutdown) leaves the stacks in the log before the runners' SIGKILL
        faulthandler.dump_traceback_later(SHUTDOWN_DUMP_S, exit=False)
        if node is not None:
            close = getattr(node, "close", None)
            if close:
                close()
            node.destroy_node()
            node = None  # nothing left to hold it: its cycles go in the collection below
        rclpy.try_shutdown()
        release_heap_before_exit()
    return status


def release_heap_before_exit() -> None:
    """Collect what is garbage now, then freeze every object left, so the interpreter's exit does not traverse them.

    At exit Python clears every module and collects the cycles that leaves (numba's dispatchers, LLVM modules,
    rclpy's entities): in ins_gps_kf_node most of its shutdown, 0.48 s of CPU (0.14 s with this), and 1.5-4.6 s
    of wall time from SIGINT to exit with a bag playing on a busy machine (0.5-1.3 s with this; 65 cycles). A
    still busier machine stretches it towards the runners' 10-s SIGKILL, with a stack dump that shows only
    '<no Python frame>' (the suspected cause of issue 29's rare filter-node hang, not reproduced). Collected
    here, the cycles' destructors (DDS entities, shared-memory segments) still run while the interpreter is
    whole; what is frozen is freed by the process's end.
    """
    gc.collect()
    gc.freeze()


class Diagnostics:
    """Publishes one ``DiagnosticStatus`` of a node on ``/diagnostics`` (diagnostic_updater stand-in)."""

    def __init__(self, node: Node, name: str, hardware_id: str = ""):
        self._node = node
        self._pub = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.name = f"{node.get_name()}: {name}"
        self.hardware_id = hardware_id

    def publish(self, level: str, message: str, values: dict) -> DiagnosticStatus:
        """Publish ``values`` (stringified) at ``level`` (OK/WARN/ERROR/STALE) with ``message``."""
        status = DiagnosticStatus(level=DIAG_LEVELS[level], name=self.name, message=message,
                                  hardware_id=self.hardware_id,
                                  values=[KeyValue(key=str(k), value=_fmt(v)) for k, v in values.items()])
        arr = DiagnosticArray()
        arr.header.stamp = self._node.get_clock().now().to_msg()
        arr.status = [status]
        self._pub.publish(arr)
        return status


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


class _PolledGroup(CallbackGroup):
    """A callback group the executor never waits on: a timer polls its entities instead."""

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


class PolledSubscription:
    """Messages taken raw every ``period_s`` (steady clock): ``on_messages([(cdr bytes, received system ns)])``.

    At 1 kHz an executor callback per message costs more CPU than the work it carries (the
    executor rebuilds its wait set each time), so the subscription stays out of the wait set
    and a timer drains its queue (``qos`` depth must hold ``period_s`` worth of messages).
    The price is up to ``period_s`` of added latency.
    """

    def __init__(self, node: Node, msg_type, topic: str, on_messages, period_s: float | None, qos=SENSOR_QOS_IN,
                 max_batch: int = 20000, qos_overriding_options: QoSOverridingOptions | None = None):
        """``period_s`` None: no timer, the owner calls :meth:`drain` or :meth:`take_all`; ``qos_overriding_options``
        :data:`LINK_QOS` for a topic that may cross a link."""
        self._on_messages, self._max_batch, self._node, self.msg_type = on_messages, max_batch, node, msg_type
        qos = copy.copy(qos) if qos_overriding_options else qos  # rclpy writes the overrides into it
        self.subscription = node.create_subscription(msg_type, topic, _never_called, qos, raw=True,
                                                     callback_group=_PolledGroup(),
                                                     qos_overriding_options=qos_overriding_options)
        # steady clock: under use_sim_time a paused or slow /clock must not stall the intake
        self.timer = None if period_s is None else node.create_timer(
            period_s, self.drain, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def take_all(self) -> list:
        """Every queued message as ``(cdr bytes, received system ns)``, oldest first."""
        taken_all = []
        handle = self.subscription.handle
        with handle:
            while len(taken_all) < self._max_batch:
                taken = handle.take_message(self.msg_type, True)
                if taken is None:
                    break
                taken_all.append((taken[0], taken[1]["received_timestamp"]))
        return taken_all

    def drain(self) -> int:
        """Take every queued message, hand the batch on; returns how many were taken."""
        taken_all = self.take_all()
        if taken_all:
            self._on_messages(taken_all)
        return len(taken_all)


class ImuBatchSubscription(PolledSubscription):
    """``sensor_msgs/Imu`` taken in raw batches (see :class:`PolledSubscription`): ``on_batch(ImuBatch)``.

    Messages that are not CDR Imu are counted in ``bad_messages`` and skipped.
    """

    def __init__(self, node: Node, topic: str, on_batch, period_s: float | None, qos=SENSOR_QOS_IN,
                 max_batch: int = 20000, qos_overriding_options: QoSOverridingOptions | None = None):
        super().__init__(node, Imu, topic, self._on_messages_taken, period_s, qos, max_batch, qos_overriding_options)
        self._on_batch = on_batch
        self.bad_messages = 0

    def _on_messages_taken(self, taken) -> None:
        self._on_batch(self.decode([blob for blob, _ in taken]))

    def decode(self, blobs) -> ImuBatch:
        """The samples of raw Imu messages; bad ones are counted, logged and skipped."""
        try:
            return decode_imu(blobs)
        except ImuCdrError:
            good = []
            for blob in blobs:
                try:
                    decode_imu([blob])
                    good.append(blob)
                except ImuCdrError as err:
                    self.bad_messages += 1
                    self._node.get_logger().warning(f"skipped a message on {self.subscription.topic_name}: {err}")
            return decode_imu(good)


class IntakeLoop:
    """Calls ``fn()`` every ``period_s`` on its own thread, holding ``lock``, until :meth:`stop`.

    The intake of polled subscriptions: waking the rclpy executor with a timer costs a few
    hundred microseconds per wake (it rebuilds its wait set), a plain thread a few. Node
    callbacks that read what ``fn`` changes (diagnostics) take the same ``lock``. An
    exception in ``fn`` is logged and the loop goes on: the intake must outlive a bad batch.
    """

    def __init__(self, node: Node, period_s: float, fn, lock: threading.Lock):
        self._node, self._period_s, self._fn, self.lock = node, period_s, fn, lock
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"{node.get_name()}_intake", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            next_t = max(next_t + self._period_s, time.monotonic())
            self._stop.wait(max(0.0, next_t - time.monotonic()))
            if self._stop.is_set() or not self._node.context.ok():
                return
            try:
                with self.lock:
                    self._fn()
            except Exception as err:  # noqa: BLE001 - report and keep taking input
                self._node.get_logger().error(f"intake: {type(err).__name__}: {err}")

    def stop(self, timeout_s: float = 5.0) -> bool:
        """Stop the loop and wait up to ``timeout_s`` for a call in progress; whether the loop has ended (if not,
        ``fn`` is still running on its thread: what it works on is not the caller's to touch)."""
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=timeout_s)
        return not self._thread.is_alive()


def _never_called(msg) -> None:
    raise RuntimeError("polled subscription callback called by an executor")


def publish_imu_batch(pub, sec, nanosec, gyro, accel, frame_id: str, **fields) -> int:
    """Publish one Imu per row as raw CDR (``fields`` as :func:`nav_core.imu_cdr.encode_imu`); returns the count."""
    blobs = encode_imu(sec, nanosec, gyro, accel, frame_id, **fields)
    for blob in blobs:
        pub.publish(blob)
    return len(blobs)


def stamp_from_s(t_s: float):
    """``builtin_interfaces/Time`` from float seconds."""
    from builtin_interfaces.msg import Time

    sec, nanosec = units.sec_nanosec(units.ns_from_s(t_s))
    return Time(sec=sec, nanosec=nanosec)


def stamp_to_s(stamp) -> float:
    """Float seconds from ``builtin_interfaces/Time``."""
    return units.s_from_sec_nanosec(stamp.sec, stamp.nanosec)


def imu_to_arrays(msg: Imu):
    """(t s, gyro (3,) rad/s, accel (3,) m/s^2) of an Imu message."""
    w, a = msg.angular_velocity, msg.linear_acceleration
    return stamp_to_s(msg.header.stamp), np.array((w.x, w.y, w.z)), np.array((a.x, a.y, a.z))


_NO_ORIENTATION = np.zeros(9)
_NO_ORIENTATION[0] = -1.0


def imu_from_arrays(t_s: float, gyro, accel, frame_id: str = "imu_link", gyro_var: float = 0.0,
                    accel_var: float = 0.0, stamp=None) -> Imu:
    """An Imu message (no orientation: covariance[0] = -1) from rate (rad/s) and specific force (m/s^2)."""
    msg = Imu()
    msg.header.stamp = stamp if stamp is not None else stamp_from_s(t_s)
    msg.header.frame_id = frame_id
    msg.orientation_covariance = _NO_ORIENTATION
    gx, gy, gz = (float(v) for v in gyro)
    ax, ay, az = (float(v) for v in accel)
    msg.angular_velocity = Vector3(x=gx, y=gy, z=gz)
    msg.linear_acceleration = Vector3(x=ax, y=ay, z=az)
    if gyro_var:
        msg.angular_velocity_covariance = np.diag([gyro_var] * 3).ravel()
    if accel_var:
        msg.linear_acceleration_covariance = np.diag([accel_var] * 3).ravel()
    return msg


class Probe(Node):
    """Test and demo helper: subscribes to topics and keeps (receive time, message) pairs."""

    def __init__(self, topics: dict, name: str = "probe", qos=None):
        super().__init__(name)
        # Best effort (connects to sensor publishers) with a deep queue so a busy probe loses nothing.
        qos = qos or QoSProfile(depth=10000, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.received = {topic: [] for topic in topics}
        for topic, msg_type in topics.items():
            self.create_subscription(msg_type, topic, self._keeper(topic), qos)

    def _keeper(self, topic):
        def keep(msg):
            self.received[topic].append((time.monotonic(), msg))
        return keep

    def spin_until(self, predicate, timeout_s: float) -> bool:
        """Spin until ``predicate(self)`` is true or ``timeout_s`` passes; return whether it became true."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate(self):
                return True
            rclpy.spin_once(self, timeout_sec=0.05)
        return predicate(self)
