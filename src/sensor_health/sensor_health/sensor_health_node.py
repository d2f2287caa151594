"""sensor_health_node: the health monitor on ``imu/data_raw``; events on a transient-local topic, /diagnostics.

Samples are taken in batches every ``intake_period_s`` (as wmra_node takes them) and pushed into
:class:`sensor_health.monitor.HealthMonitor` with their header stamps, so a recorded bag gives the events the
``sensor-health`` CLI gives. Each event is published once on ``events_topic`` (``std_msgs/String``, one JSON
object, reliable and transient local: a late subscriber, such as the demo report, still gets every event); a fault
that went away (a held vibration line, a start-up noise increase) follows as an ``OK`` event with
``statistic.cleared`` (``health.json`` lists these under ``cleared``).
``/diagnostics`` carries one status per channel (``gx`` .. ``az``) and a ``summary`` (:mod:`sensor_health.status`).
``gps/fix`` feeds the yaw scale-factor and track tests and is counted in the summary. ``odometry/filtered``
(ins_gps_kf's epoch rates, bias-corrected) against imu/data_raw calibrated by the sensor model (as wmra_node
calibrates the filter's input) gives the filter's gyro bias (:class:`sensor_health.odometry_bias.OdometryBias`),
reported on gx gy gz in ``/diagnostics`` beside the monitor's own tests; it feeds no test, so the events are the
CLI's with or without it.
This module is wiring.
"""
from __future__ import annotations

import copy
import json
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import String

from nav_core import sensor_model
from nav_core.params import ConfigError, Param
from nav_core.ros_node import (DIAG_LEVELS, LINK_QOS, SENSOR_QOS_IN, ImuBatchSubscription, IntakeLoop,
                               declare_parameters, run_node)
from nav_core.units import deg2rad, g2mps2
from sensor_health import status
from sensor_health.events import CHANNELS, cleared_event
from sensor_health.monitor import HealthConfig, HealthMonitor
from sensor_health.odometry_bias import OdometryBias

EVENTS_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""Events: reliable and transient local (a subscriber that joins late gets the events so far)."""

PARAMS = (
    Param("sensor_model_path", "", "sensor-model YAML (nav_core.sensor_model): the noise that is never a fault"),
    Param("sample_rate_hz", 0.0, "input sample rate, Hz; 0 = the sensor model's sample_rate_hz", 0.0, 1e5),
    Param("window_s", 1.0, "window of the noise, line and bias statistics, s", 0.1, 60.0),
    Param("false_alarms_per_10h", HealthConfig.false_alarms_per_10h, "budget of statistical false events on the "
          "model's noise per 10 h shared by the tests without a share of their own (thresholds by Monte Carlo)",
          1e-6, 1e3),
    Param("gyro_range_dps", 300.0, "gyro range, deg/s (saturation)", 1e-3, 1e6),
    Param("accel_range_g", 10.0, "accelerometer range, g (saturation)", 1e-3, 1e6),
    Param("events_topic", "sensor_health/events", "topic of the events (std_msgs/String JSON, transient local)"),
    Param("intake_period_s", 0.1, "imu/data_raw is taken in batches at this period, s", 0.001, 5.0),
    Param("diagnostics_period_s", 1.0, "period of the /diagnostics statuses, s", 0.05, 60.0),
    Param("input_queue_depth", 20000, "imu/data_raw messages held until taken", 100, 1000000),
    Param("filter_bias_average_s", 10.0, "the filter's gyro bias (odometry/filtered) is averaged over this, s",
          0.5, 3600.0),
    Param("filter_epoch_max_s", 1.0, "odometry/filtered stamps further apart than this are not one filter epoch "
          "(ins_gps_kf's 1 / filter_rate_hz; after alignment or a reset the span is unknown), s", 0.01, 60.0),
)


class SensorHealthNode(Node):
    """The monitor node: intake, events, diagnostics."""

    def __init__(self):
        super().__init__("sensor_health_node")
        values = declare_parameters(self, PARAMS)
        path = values["sensor_model_path"]
        if not path:
            raise ConfigError("parameter 'sensor_model_path': empty; give the sensor-model YAML of the IMU")
        try:
            model = sensor_model.load(path)
        except sensor_model.SensorModelError as err:
            raise ConfigError(f"parameter 'sensor_model_path': {err}") from None
        cfg = HealthConfig(window_s=values["window_s"], false_alarms_per_10h=values["false_alarms_per_10h"],
                           gyro_range_rad_s=float(deg2rad(values["gyro_range_dps"])),
                           accel_range_m_s2=float(g2mps2(values["accel_range_g"])))
        try:
            self.monitor = HealthMonitor(model, cfg, values["sample_rate_hz"], keep_trace=False)
        except ValueError as err:
            raise ConfigError(f"sensor_health: {err}") from None
        self.counts, self.stats = {}, {"received": 0, "busy_s": 0.0, "gps_fix": 0, "odometry": 0, "cleared": 0}
        self.events_pub = self.create_publisher(String, values["events_topic"], EVENTS_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(NavSatFix, "gps/fix", self.on_fix, copy.copy(SENSOR_QOS_IN),
                                 qos_overriding_options=LINK_QOS)  # copied: rclpy writes overrides into it
        self.filter_bias = OdometryBias(values["filter_bias_average_s"], values["filter_epoch_max_s"])
        self.correct_gyro = sensor_model.corrector(model.gyro)  # the filter's input is calibrated (wmra_node)
        self.create_subscription(Odometry, "odometry/filtered", self.on_odometry, 100)
        qos = QoSProfile(depth=values["input_queue_depth"], reliability=ReliabilityPolicy.BEST_EFFORT)
        self.intake = ImuBatchSubscription(self, "imu/data_raw", self.on_batch, None, qos=qos,
                                           qos_overriding_options=LINK_QOS)
        self.lock = threading.Lock()
        self.create_timer(values["diagnostics_period_s"], self._publish_diagnostics_locked)
        self.intake_loop = IntakeLoop(self, values["intake_period_s"], self.intake.drain, self.lock)
        th = self.monitor.thr
        self.get_logger().info(f"ready: window {th.window_s:g} s, stuck run {th.stuck_run.tolist()} samples, "
                               f"line gate {th.line_h:.1f}, noise h {th.noise_h:.2f}")

    def _count(self, key):
        self.stats[key] += 1

    def on_fix(self, msg) -> None:
        """A GNSS fix into the monitor (the yaw scale factor against the course); publish what it completes."""
        self._count("gps_fix")
        if msg.status.status < 0:  # no fix
            return
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        with self.lock:
            events = self.monitor.push_gnss([t], [float(deg2rad(msg.latitude))], [float(deg2rad(msg.longitude))],
                                            [float(msg.altitude)])
            self._publish_events(events)

    def on_odometry(self, msg) -> None:
        """One filter epoch: its bias-corrected body rate against imu/data_raw (the filter's gyro bias)."""
        self._count("odometry")
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        w = msg.twist.twist.angular
        with self.lock:
            self.filter_bias.push_odometry(t, (w.x, w.y, w.z))

    def on_batch(self, batch) -> None:
        """Push a batch into the monitor; publish each event it names."""
        start = time.perf_counter()
        events = self.monitor.push(batch.t_s, batch.gyro, batch.accel)
        self.filter_bias.push_imu(batch.t_s, self.correct_gyro(batch.gyro))
        self.stats["received"] += len(batch.t_s)
        self._publish_events(events)
        self._log_cleared()
        self.stats["busy_s"] += time.perf_counter() - start

    def _publish_events(self, events) -> None:
        status.count_events(self.counts, events)
        for e in events:
            self.events_pub.publish(String(data=e.to_json()))
            log = self.get_logger().error if e.level == "ERROR" else self.get_logger().warning
            log(f"{e.effect} {','.join(e.channels)} at t {e.t_s:.3f} s (onset {e.onset_s:.3f} s): {e.message}")

    def _log_cleared(self) -> None:
        """Publish each fault that went away as an OK event on the event topic, and log it (its channel's status
        says so too)."""
        for c in self.monitor.cleared[self.stats["cleared"]:]:
            self.events_pub.publish(String(data=cleared_event(c).to_json()))
            self.get_logger().info(f"cleared: {c['effect']} {','.join(c['channels'])} at t {c['t_s']:.3f} s "
                                   f"(named at {c['since_s']:.3f} s)")
        self.stats["cleared"] = len(self.monitor.cleared)

    def _publish_diagnostics_locked(self) -> None:
        with self.lock:
            self.publish_diagnostics()

    def publish_diagnostics(self) -> None:
        """One status per channel and the summary on /diagnostics."""
        now = self.monitor.checked_s[1] if self.monitor.checked_s[1] is not None else 0.0
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        bias = self.filter_bias.estimate()
        for name, s in status.statuses(self.monitor, now, self.counts).items():
            values = s.to_values()
            if bias is not None and name in CHANNELS[:3]:
                c = CHANNELS.index(name)
                values["filter_bias_rad_s"] = repr(float(bias[0][c]))
                values["filter_bias_interval_95"] = json.dumps(bias[1][c].tolist())
            if name == status.SUMMARY:
                values.update({k: str(v) for k, v in self.stats.items()})
                values["filter_bias_epochs"] = str(bias[2] if bias is not None else 0)
                values["processing_mean_us"] = f"{1e6 * self.stats['busy_s'] / max(self.stats['received'], 1):.1f}"
                if not self.stats["received"]:
                    s.message = "waiting for imu/data_raw"
            arr.status.append(DiagnosticStatus(level=DIAG_LEVELS[s.level], name=f"{self.get_name()}: {name}",
                                               message=s.message, hardware_id="imu",
                                               values=[KeyValue(key=k, value=v) for k, v in values.items()]))
        self.diag_pub.publish(arr)

    def close(self) -> None:
        """Take what is queued before shutting down."""
        if not self.intake_loop.stop():  # its thread is still on a batch: a second thread on the intake would race
            self.get_logger().warn("shutdown: the intake is still busy; what is queued is not checked")
            return
        try:
            self.intake.drain()
        except Exception:  # the context may already be shut down on SIGINT
            pass


def main(args=None) -> int:
    """Console script ``sensor_health_node``."""
    return run_node(SensorHealthNode, args, usage=(
        "sensor_health_node",
        "Watch imu/data_raw live and name sensor faults (effect, channel, onset) on sensor_health/events.",
        PARAMS,
        "sensor_health_node --ros-args -p sensor_model_path:=out/my_imu/sensor_model.yaml"))


if __name__ == "__main__":
    raise SystemExit(main())
