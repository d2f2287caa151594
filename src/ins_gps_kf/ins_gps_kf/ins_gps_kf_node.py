"""ROS 2 node around :class:`ins_gps_kf.filter.InsGpsFilter`: IMU + NavSatFix in, Odometry + oriented Imu out.

Subscribes ``imu_topic`` (default ``imu/data_corrected``) and ``gps_topic`` (``gps/fix``)
with the sensor-data QoS (best effort); publishes ``odometry/filtered`` (pose in
``map`` = local ENU at the datum, twist in ``base_link``: velocity and the epoch's bias-corrected
rate) and ``map -> odom -> base_link`` on ``/tf`` (REP-105, :mod:`nav_core.tf_tree`) at every filter epoch,
the sensor mounts on ``/tf_static``,
``imu/data`` (with orientation) once aligned, and ``/diagnostics``. IMU samples are taken
in batches every ``intake_period_s`` and run through the filter as chunks (bit-identical
to one by one); ``imu/data`` carries the newest sample of each chunk: every sample at
64 Hz, about one per intake period at 1 kHz (a per-sample orientation would cost more
than the filter).
Ordering, late drops and time-jump resets are :class:`ins_gps_kf.intake.StampOrderIntake`'s
(messages wait ``reorder_window_s`` past the newest IMU stamp, so a node that falls behind
catches up in the same order; a fix stamped back goes where it arrived, so the filter's GNSS
clock check sees the step as in the replay; after a stale spell the IMU waits for the fixes'
backlog, :meth:`ins_gps_kf.intake.StampOrderIntake.hold_for_fixes`); this module is wiring. The subscriptions queue
``input_queue_depth`` messages, so a node held up for seconds loses nothing, and every
numba kernel is compiled before the node says ready (a first-epoch compile once held a
fresh install's node up for 30 s on a busy machine while DDS dropped its input).
Only finite estimates are published: a non-finite one is counted and the filter reset.
With ``odometer_enabled`` the wheel odometer's forward speed comes from ``odometer_topic`` (``odom/wheel``,
sensor-data QoS): ``nav_msgs/Odometry`` (``twist.twist.linear.x``) or ``geometry_msgs/TwistStamped``
(``twist.linear.x``), as ``odometer_msg_type`` says or, with ``auto``, as the graph's first publisher offers it;
its stamps go through the same intake as the fixes (:meth:`ins_gps_kf.intake.StampOrderIntake.add_odometry`).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # 15x15 matrices: BLAS threads only cost time

import dataclasses  # noqa: E402
import math  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from geometry_msgs.msg import TwistStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.clock import Clock, ClockType  # noqa: E402
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402

from nav_core import sensor_model as sm  # noqa: E402
from nav_core.params import ConfigError, Param  # noqa: E402
from nav_core.imu_cdr import stamps_from_s  # noqa: E402
from nav_core.ros_node import (LINK_QOS, SENSOR_QOS, Diagnostics, ImuBatchSubscription, IntakeLoop,  # noqa: E402
                               PolledSubscription, declare_parameters, publish_imu_batch, run_node, stamp_from_s,
                               stamp_to_s)
from nav_core.tf_ros import TfBroadcaster  # noqa: E402
from nav_core.tf_tree import OdomChain, Pose, static_mounts  # noqa: E402
from nav_core.units import DEG  # noqa: E402
from ins_gps_kf import config as kfconfig  # noqa: E402
from ins_gps_kf import strapdown  # noqa: E402
from ins_gps_kf.filter import Estimate, InsGpsFilter  # noqa: E402
from ins_gps_kf.intake import RESUME_WAIT_S, StampOrderIntake, warm_up  # noqa: E402
from ins_gps_kf.offline import load_model  # noqa: E402
from ins_gps_kf.status import INPUT_STALE_S, StatusOnResume, filter_status, mark_stale  # noqa: E402

GPS, WHEEL, IMU = 0, 1, 2  # arrival-merge order of a fix, a wheel speed and an IMU message received at one instant
WHEEL_TYPES = {"nav_msgs/msg/Odometry": Odometry, "geometry_msgs/msg/TwistStamped": TwistStamped}

INTAKE = Param("intake_period_s", 0.01, "IMU and GPS messages are taken in batches at this period, s (adds up "
               "to this much latency; an executor callback per message costs more than the filter at 1 kHz)",
               0.0005, 1.0)
QUEUE = Param("input_queue_depth", 20000, "messages each input subscription holds until taken: a node held up "
              "(a busy CPU) catches up instead of losing input; 20,000 = 39 s of 64-Hz IMU at 8x", 100, 1000000)
TF_PARAMS = (  # REP-105 frames; the pose frame (map) and base_link are the core's frame_id / child_frame_id
    Param("publish_tf", True, "publish map -> odom -> base_link on /tf at each filter epoch and the sensor mounts "
          "(base_link -> imu_frame_id, base_link -> gps_frame_id at the lever arm) on /tf_static"),
    Param("odom_frame_id", "odom", "continuous frame (REP-105): odom -> base_link follows the INS prediction and "
          "never jumps; frame_id (map) -> odom carries the GPS corrections"),
    Param("imu_frame_id", "imu_link", "IMU frame: identity transform from base_link (the IMU axes are the body axes)"),
    Param("gps_frame_id", "gps_link", "GPS antenna frame: transform from base_link at the lever arm"),
)
WHEEL_TYPE = Param("odometer_msg_type", "auto", "message type on odometer_topic: auto = the type its first publisher "
                   "in the graph offers (the subscription is made once one is seen)",
                   choices=("auto", *WHEEL_TYPES))
NODE_PARAMS = (INTAKE, QUEUE, WHEEL_TYPE, *TF_PARAMS)
ERROR_LOG_PERIOD_S = 10.0  # a repeating processing error is logged at most this often
STALE_TICK_S = 0.2
"""s of the steady clock between staleness checks: a stale spell is said within this of passing INPUT_STALE_S, then
once a second (ticks of a second said a link cut of 1.7 s of wall time, 10 s at 6x, only if one fell in the last
0.7-0.9 s of its staleness: some phases said nothing)."""


def _param(spec: Param) -> Param:
    """ROS declaration of a core parameter; NaN defaults ('not set') get no ROS range (the core checks it)."""
    unset = isinstance(spec.default, float) and math.isnan(spec.default)
    return dataclasses.replace(spec, low=None, high=None) if unset else spec


class InsGpsKfNode(Node):
    """The fusion node; all numerics live in the core filter."""

    def __init__(self, **kwargs):
        super().__init__(kfconfig.NODE_NAME, **kwargs)
        try:
            self.params = declare_parameters(self, [_param(s) for s in kfconfig.PARAMETERS] + list(NODE_PARAMS))
            cfg = kfconfig.from_params({k: v for k, v in self.params.items()
                                        if k not in {p.name for p in NODE_PARAMS}})
            model = load_model(self.params["sensor_model_path"] or "default")
        except (kfconfig.FilterConfigError, sm.SensorModelError, InvalidParameterValueException,
                InvalidParameterTypeException) as err:
            raise ConfigError(str(err)) from err
        self.filter = InsGpsFilter(cfg, model)
        self.intake = StampOrderIntake(self.filter, self.params["reorder_window_s"], self.params["time_jump_s"],
                                       cfg.imu_rate_hz, on_run=self._on_run, gps_rate_hz=cfg.gps_rate_hz)
        self.last_estimate: Estimate | None = None
        self.nonfinite_estimates = 0  # estimates not published because not finite (the filter was reset)
        self.processing_errors = 0
        self.last_processing_error = ""
        self._error_logged_at = -math.inf
        self.closing = False
        # deep: catching up after a hold-up publishes many epochs at once, and none may be overwritten
        self.odom_pub = self.create_publisher(Odometry, "odometry/filtered", 1000)
        self.imu_pub = self.create_publisher(Imu, "imu/data", SENSOR_QOS)
        self.tf = TfBroadcaster(self) if self.params["publish_tf"] else None
        self.odom_chain = OdomChain()
        self._last_epoch_t = -math.inf
        if self.tf:
            self.tf.send_static(static_mounts(cfg.lever_arm_b, self.params["child_frame_id"],
                                              self.params["imu_frame_id"], self.params["gps_frame_id"]))
        self.imu_out = []
        # the first stamps received: the report replays the run's bag from them (a subscription matched
        # after playing began misses what the recorder has), s; None until one comes
        self.first_imu_t: float | None = None
        self.first_fix_t: float | None = None
        # IMU and fixes are taken together and merged by receive time: the order per-message callbacks
        # would have seen, so a fix is never overtaken by a batch of IMU samples that arrived after it
        qos = QoSProfile(depth=self.params["input_queue_depth"], reliability=ReliabilityPolicy.BEST_EFFORT)
        self.imu_intake = ImuBatchSubscription(self, self.params["imu_topic"], None, None, qos=qos,
                                               qos_overriding_options=LINK_QOS)
        self.wheel_intake: PolledSubscription | None = None  # made once the type is known (odometer_enabled)
        self.bad_wheel_messages = 0
        self._wheel_qos = qos
        self.gps_intake = PolledSubscription(self, NavSatFix, self.params["gps_topic"], None, None, qos=qos,
                                             qos_overriding_options=LINK_QOS)
        self.lock = threading.Lock()
        self.diag = Diagnostics(self, "ins_gps_kf")
        self.create_timer(1.0, self._locked(self.publish_diagnostics))
        # the simulated clock stops when /clock stops (a link down from the sensor host): staleness is said on
        # the node's own steady clock
        self._last_input_wall: float | None = None
        self._stale_said_wall = -math.inf  # steady s of the last status said because the input was stale
        self.on_resume = StatusOnResume()  # the status said at the first fix after a stale spell, not a period later
        self.create_timer(STALE_TICK_S, self._locked(self._diagnostics_if_stale),
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        start = time.monotonic()
        strapdown.warm_up()
        warm_up(cfg, model)  # every numba kernel compiled (or loaded from cache) now, not at the first epoch
        self.get_logger().info(f"kernels ready in {time.monotonic() - start:.1f} s")
        self._wheel_wait = None
        if cfg.odometer_enabled:
            self._subscribe_wheel()
            if self.wheel_intake is None:  # auto: look for a publisher's type each half second until one comes
                self._wheel_wait = self.create_timer(0.5, self._subscribe_wheel,
                                                     clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.intake_loop = IntakeLoop(self, self.params["intake_period_s"], self.take_input, self.lock)
        wheel = f"wheel '{self.params['odometer_topic']}', " if cfg.odometer_enabled else ""
        self.get_logger().info(f"ready: imu '{self.params['imu_topic']}', gps '{self.params['gps_topic']}', {wheel}"
                               f"model '{self.params['sensor_model_path'] or 'hand-tuned default'}'")

    def _subscribe_wheel(self):
        """Subscribe ``odometer_topic`` with the type ``odometer_msg_type`` names, or (auto) the type a publisher
        in the graph offers; until one is seen, nothing (called again by the waiting timer)."""
        topic, msg_type = self.params["odometer_topic"], self.params["odometer_msg_type"]
        if msg_type == "auto":
            name = self.resolve_topic_name(topic)
            offered = [t for n, types in self.get_topic_names_and_types() if n == name for t in types]
            msg_type = next((t for t in offered if t in WHEEL_TYPES), None)
            if msg_type is None:
                if offered:
                    self.get_logger().warn(f"{name} offers {offered}: not a wheel speed type ({list(WHEEL_TYPES)}); "
                                           "set odometer_msg_type", once=True)
                return
        with self.lock:
            self.wheel_intake = PolledSubscription(self, WHEEL_TYPES[msg_type], topic, None, None, qos=self._wheel_qos)
        if self._wheel_wait is not None:
            self._wheel_wait.cancel()
        self.get_logger().info(f"wheel odometer: {topic} as {msg_type}")

    def _locked(self, fn):
        """``fn`` run holding the intake lock (it reads what the intake thread changes); skipped when the intake
        holds it for over half a second (catching up a backlog): the executor's thread never waits on the intake,
        so a shutdown is seen at once."""
        def call():
            if not self.lock.acquire(timeout=0.5):
                return
            try:
                fn()
            finally:
                self.lock.release()
        return call

    # ------------------------------------------------------------------ input

    def take_input(self):
        """Queue what arrived since the last call, IMU samples and fixes in arrival order; run what is due."""
        imu, fixes = self.imu_intake.take_all(), self.gps_intake.take_all()
        wheel = self.wheel_intake.take_all() if self.wheel_intake is not None else []
        if not imu and not fixes and not wheel:
            if self.intake.hold_until is not None:
                self._release()  # the hold may have ended
            return
        now = time.monotonic()
        if self._last_input_wall is not None and now - self._last_input_wall > INPUT_STALE_S:
            self.intake.hold_for_fixes(now + RESUME_WAIT_S)
            self.on_resume.input_resumed(self.filter.counters.fixes)
        self._last_input_wall = now
        batch = self.imu_intake.decode([blob for blob, _ in imu])
        if len(batch) != len(imu):  # a bad message was skipped: arrival order is lost for this batch only
            imu = [(None, imu[-1][1])] * len(batch)
        # merged by receive time: the order per-message callbacks would have seen, so a fix is never
        # overtaken by a batch of IMU samples that arrived after it
        arrivals = sorted([(received, IMU, i) for i, (_, received) in enumerate(imu)]
                          + [(received, GPS, i) for i, (_, received) in enumerate(fixes)]
                          + [(received, WHEEL, i) for i, (_, received) in enumerate(wheel)])
        t_s = batch.t_s.tolist()
        if self.first_imu_t is None and t_s:
            self.first_imu_t = t_s[0]
        restarts, steps = self.intake.counters.restarts, self.filter.input.gnss_clock_steps
        for _, kind, i in arrivals:
            if kind == IMU:
                self.intake.add_imu(t_s[i], batch.gyro[i], batch.accel[i])
            elif kind == WHEEL:
                self.on_wheel_speed(wheel[i][0])
            else:
                self.on_gps(deserialize_message(fixes[i][0], NavSatFix))
        self._release()
        if self.intake.counters.restarts != restarts:
            self.get_logger().warn(f"time jump: {self.intake.counters.last_restart}; filter reset")
        if self.filter.input.gnss_clock_steps != steps:
            self.get_logger().warn(f"GNSS clock step ({self.filter.input.gnss_clock_steps} so far): "
                                   f"{self.filter.input.last_rejection}")
        self._publish_imu_out()

    def _release(self):
        """Run what is due (after a stale spell, for :data:`RESUME_WAIT_S`, no further than the fixes allow)."""
        self._guarded(lambda: self.intake.release(time.monotonic()))

    def on_gps(self, msg: NavSatFix):
        """Queue one fix (the filter judges NaN, NO_FIX and implausible fixes)."""
        cov = np.asarray(msg.position_covariance, dtype=float).reshape(3, 3)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if msg.position_covariance_type > 0 else np.zeros(3)
        if self.first_fix_t is None:
            self.first_fix_t = stamp_to_s(msg.header.stamp)
        self.intake.add_fix(stamp_to_s(msg.header.stamp), msg.latitude * DEG, msg.longitude * DEG, msg.altitude,
                            std, msg.status.status)

    def on_wheel_speed(self, blob: bytes):
        """Queue one wheel speed (the filter judges NaN, repeated and back-going stamps and a stuck wheel); a message
        that does not decode is counted (``bad_odometer_messages``)."""
        try:
            msg = deserialize_message(blob, self.wheel_intake.msg_type)
        except Exception:  # noqa: BLE001 - rclpy raises several kinds on bad CDR
            self.bad_wheel_messages += 1
            return
        twist = msg.twist.twist if isinstance(msg, Odometry) else msg.twist
        self.intake.add_odometry(stamp_to_s(msg.header.stamp), float(twist.linear.x))

    def _guarded(self, fn):
        """``fn()``; an error of the filter is counted, logged now and then, and resets it (input goes on)."""
        try:
            fn()
        except Exception as err:  # noqa: BLE001 - the node outlives a bad state: reset, re-align, report
            self.processing_errors += 1
            self.last_processing_error = f"{type(err).__name__}: {err}"
            if time.monotonic() - self._error_logged_at > ERROR_LOG_PERIOD_S:
                self._error_logged_at = time.monotonic()
                self.get_logger().error(f"filter error ({self.processing_errors} so far): "
                                        f"{self.last_processing_error}; filter reset")
            self.filter.reset(f"error: {self.last_processing_error}")

    def _on_run(self, estimates, t, gyro, accel):
        """After a chunk of IMU samples: publish its epochs' odometry; queue its newest sample for imu/data.

        A non-finite estimate is never published: it is counted and the filter reset (it re-aligns). The first
        fix taken after a stale spell has the status said now (:class:`ins_gps_kf.status.StatusOnResume`).
        """
        for est in estimates:
            if not _finite(est):
                self.nonfinite_estimates += 1
                self.filter.reset(f"non-finite estimate at t={est.t:.3f} s")
                return
            self.publish_odometry(est)
        self.publish_imu(t, gyro, accel)
        if self.on_resume.due(self.filter.counters.fixes) and not self.closing:
            self.publish_diagnostics()

    def close(self):
        """Run what is still buffered through the filter without publishing (called by run_node on shutdown)."""
        # (a shutdown that hangs leaves its stacks in the log: nav_core.ros_node.run_node arms the dump)
        self.closing = True
        if not self.intake_loop.stop():  # its thread is still on a batch: a second thread on the intake would race
            self.get_logger().warn("shutdown: the intake is still busy; what is queued is not run")
            return
        try:
            self.take_input()
        except Exception:  # noqa: BLE001 - the context may already be shut down on SIGINT; what was queued runs
            pass
        self._guarded(self.intake.flush)

    # ------------------------------------------------------------------ output

    def publish_imu(self, t, gyro, accel):
        """Queue the input sample, bias-corrected, with the estimated orientation and its covariance."""
        f = self.filter
        if not f.navigating or self.closing:
            return
        quat, att_cov, gyro_c, accel_c = f.oriented_imu(gyro, accel)
        row = (t, quat, att_cov.ravel(), gyro_c, accel_c)
        if all(np.all(np.isfinite(v)) for v in row):  # a non-finite state is caught (and counted) at the epoch
            self.imu_out.append(row)

    def _publish_imu_out(self):
        """Publish the queued oriented samples on imu/data in one raw-CDR batch."""
        if not self.imu_out:
            return
        t, quat, quat_cov, gyro, accel = (np.array(col) for col in zip(*self.imu_out))
        self.imu_out.clear()
        gyro_var, accel_var = self.filter.imu_variances()
        sec, nanosec = stamps_from_s(t)
        publish_imu_batch(self.imu_pub, sec, nanosec, gyro, accel, self.params["child_frame_id"],
                          gyro_var=gyro_var, accel_var=accel_var, orientation_xyzw=quat, orientation_cov=quat_cov)

    def publish_odometry(self, est: Estimate):
        """Pose (ENU, map) and twist (body) with covariances: :func:`ins_gps_kf.odometry.odometry`, converted."""
        self.last_estimate = est
        if self.closing:
            return
        odom = self.filter.odometry(est, self._last_epoch_t)
        self._last_epoch_t = est.t
        msg = Odometry()
        msg.header.stamp = stamp_from_s(odom.t)
        msg.header.frame_id = self.params["frame_id"]
        msg.child_frame_id = self.params["child_frame_id"]
        p, tw = msg.pose.pose, msg.twist.twist
        p.position.x, p.position.y, p.position.z = (float(v) for v in odom.position_n)
        p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = (float(v) for v in odom.quat_xyzw)
        tw.linear.x, tw.linear.y, tw.linear.z = (float(v) for v in odom.velocity_b)
        tw.angular.x, tw.angular.y, tw.angular.z = (float(v) for v in odom.angular_rate_b)
        msg.pose.covariance = odom.pose_cov.flatten().tolist()
        msg.twist.covariance = odom.twist_cov.flatten().tolist()
        self.odom_pub.publish(msg)
        self.publish_tf(est)

    def publish_tf(self, est: Estimate):
        """map -> odom -> base_link at the epoch's stamp (the split is :class:`nav_core.tf_tree.OdomChain`'s)."""
        if self.tf is None:
            return
        predicted = (None if est.predicted_position_n is None
                     else Pose.from_xyzw(est.predicted_position_n, est.predicted_quat_xyzw))
        tf = self.odom_chain.update(est.t, Pose.from_xyzw(est.position_n, est.quat_xyzw), predicted,
                                    segment=self.filter.counters.resets)
        p = self.params
        self.tf.send(est.t, [(p["frame_id"], p["odom_frame_id"], tf.map_odom),
                             (p["odom_frame_id"], p["child_frame_id"], tf.odom_base)])

    def publish_diagnostics(self):
        """The typed status (:class:`ins_gps_kf.status.FilterStatus`) on /diagnostics."""
        st = filter_status(self.filter, self.intake, self.first_imu_t, self.first_fix_t, self.imu_intake.bad_messages,
                           self.nonfinite_estimates, self.processing_errors, self.last_processing_error,
                           self.bad_wheel_messages)
        mark_stale(st, 0.0 if self._last_input_wall is None else time.monotonic() - self._last_input_wall)
        self.diag.publish(st.level, st.message, st.to_values())

    def _diagnostics_if_stale(self):
        """The status once the input is stale, then each second of the steady clock (the sim-time timer may be
        stopped)."""
        now = time.monotonic()
        if self._last_input_wall is None or now - self._last_input_wall <= INPUT_STALE_S:
            return
        if now - self._stale_said_wall >= 1.0 - STALE_TICK_S / 2:  # a new spell: the last said before its input
            self._stale_said_wall = now
            self.publish_diagnostics()


def _finite(est: Estimate) -> bool:
    """Whether every published field of ``est`` is finite."""
    return all(np.all(np.isfinite(v)) for v in (est.position_n, est.velocity_n, est.quat_xyzw, est.cov))


def main(args=None) -> int:
    """Console script ``ins_gps_kf_node``."""
    return run_node(InsGpsKfNode, args=args, usage=(
        "ins_gps_kf_node",
        "Fuse IMU and GPS in the INS/GPS Kalman filter into odometry/filtered, imu/data and /tf.",
        [_param(s) for s in kfconfig.PARAMETERS] + list(NODE_PARAMS),
        "ins_gps_kf_node --ros-args --params-file config/navigation.yaml "
        "-p sensor_model_path:=config/sensor_models/bp3010.yaml"))


if __name__ == "__main__":
    raise SystemExit(main())
