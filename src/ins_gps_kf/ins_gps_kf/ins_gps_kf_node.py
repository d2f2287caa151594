"""ROS 2 node around :class:`ins_gps_kf.filter.InsGpsFilter`: IMU + NavSatFix in, Odometry + oriented Imu out.

Subscribes ``imu_topic`` (default ``imu/data_corrected``) and ``gps_topic`` (``gps/fix``)
with the sensor-data QoS (best effort); publishes ``odometry/filtered`` (pose in
``odom`` = local ENU at the datum, twist in ``base_link``) at every filter epoch,
``imu/data`` (with orientation) once aligned, and ``/diagnostics``. IMU samples are taken
in batches every ``intake_period_s`` and run through the filter as chunks (bit-identical
to one by one); ``imu/data`` carries the newest sample of each chunk: every sample at
64 Hz, about one per intake period at 1 kHz (a per-sample orientation would cost more
than the filter).
Messages wait ``reorder_window_s`` in a buffer ordered by stamp, so late and
out-of-order messages are processed in order; older ones are dropped and counted;
a stamp jump beyond ``time_jump_s`` resets the filter (reported).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # 15x15 matrices: BLAS threads only cost time

import dataclasses  # noqa: E402
import heapq  # noqa: E402
import itertools  # noqa: E402
import math  # noqa: E402
import threading  # noqa: E402

import numpy as np  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rclpy.node import Node  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402

from nav_core import sensor_model as sm  # noqa: E402
from nav_core.params import ConfigError, Param  # noqa: E402
from nav_core.imu_cdr import stamps_from_s  # noqa: E402
from nav_core.ros_node import (SENSOR_QOS, Diagnostics, ImuBatchSubscription, IntakeLoop,  # noqa: E402
                               PolledSubscription, declare_parameters, publish_imu_batch, run_node, stamp_from_s,
                               stamp_to_s)
from nav_core.units import DEG  # noqa: E402
from ins_gps_kf import config as kfconfig  # noqa: E402
from ins_gps_kf import error_model as em  # noqa: E402
from ins_gps_kf import strapdown  # noqa: E402
from ins_gps_kf.filter import ALIGNING, NAVIGATING, Estimate, InsGpsFilter  # noqa: E402
from ins_gps_kf.replay import load_model  # noqa: E402

GPS, IMU = 0, 1  # a fix sorts before an IMU sample of the same stamp (as in the replay)

INTAKE = Param("intake_period_s", 0.01, "IMU and GPS messages are taken in batches at this period, s (adds up "
               "to this much latency; an executor callback per message costs more than the filter at 1 kHz)",
               0.0005, 1.0)


def _param(spec: Param) -> Param:
    """ROS declaration of a core parameter; NaN defaults ('not set') get no ROS range (the core checks it)."""
    unset = isinstance(spec.default, float) and math.isnan(spec.default)
    return dataclasses.replace(spec, low=None, high=None) if unset else spec


class InsGpsKfNode(Node):
    """The fusion node; all numerics live in the core filter."""

    def __init__(self, **kwargs):
        super().__init__(kfconfig.NODE_NAME, **kwargs)
        try:
            self.params = declare_parameters(self, [_param(s) for s in kfconfig.PARAMETERS] + [INTAKE])
            cfg = kfconfig.from_params({k: v for k, v in self.params.items() if k != INTAKE.name})
            model = load_model(self.params["sensor_model_path"] or "default")
        except (kfconfig.FilterConfigError, sm.SensorModelError, InvalidParameterValueException,
                InvalidParameterTypeException) as err:
            raise ConfigError(str(err)) from err
        self.filter = InsGpsFilter(cfg, model)
        self.window = float(self.params["reorder_window_s"])
        self.time_jump = float(self.params["time_jump_s"])
        self.heap, self.seq = [], itertools.count()
        self.newest_t = -math.inf
        self.last_t = None
        self.late_dropped = 0
        self.node_resets = 0
        self.last_reset = ""
        self.last_estimate: Estimate | None = None
        self.closing = False
        self.odom_pub = self.create_publisher(Odometry, "odometry/filtered", 10)
        self.imu_pub = self.create_publisher(Imu, "imu/data", SENSOR_QOS)
        self.imu_out = []
        self.imu_received = 0
        # IMU and fixes are taken together and merged by receive time: the order per-message callbacks
        # would have seen, so a fix is never overtaken by a batch of IMU samples that arrived after it
        self.imu_intake = ImuBatchSubscription(self, self.params["imu_topic"], None, None)
        self.gps_intake = PolledSubscription(self, NavSatFix, self.params["gps_topic"], None, None)
        self.lock = threading.Lock()
        self.diag = Diagnostics(self, "ins_gps_kf")
        self.create_timer(1.0, self._locked(self.publish_diagnostics))
        strapdown.warm_up()  # compile or load the numba kernels now, not on the first aligned sample
        self.intake_loop = IntakeLoop(self, self.params["intake_period_s"], self.take_input, self.lock)
        self.get_logger().info(f"ready: imu '{self.params['imu_topic']}', gps '{self.params['gps_topic']}', "
                               f"model '{self.params['sensor_model_path'] or 'hand-tuned default'}'")

    def _locked(self, fn):
        """``fn`` run holding the intake lock (it reads what the intake thread changes)."""
        def call():
            with self.lock:
                fn()
        return call

    # ------------------------------------------------------------------ input

    def take_input(self):
        """Queue what arrived since the last call, IMU samples and fixes in arrival order; publish imu/data."""
        imu, fixes = self.imu_intake.take_all(), self.gps_intake.take_all()
        if not imu and not fixes:
            return
        batch = self.imu_intake.decode([blob for blob, _ in imu])
        self.imu_received += len(batch)
        if len(batch) != len(imu):  # a bad message was skipped: arrival order is lost for this batch only
            imu = [(None, imu[-1][1])] * len(batch)
        arrivals = sorted([(received, IMU, i) for i, (_, received) in enumerate(imu)]
                          + [(received, GPS, i) for i, (_, received) in enumerate(fixes)])
        t_s = batch.t_s.tolist()
        for _, kind, i in arrivals:  # drained once at the end, so the filter gets whole chunks
            if kind == IMU:
                self._push(t_s[i], IMU, (batch.gyro[i], batch.accel[i]), drain=False)
            else:
                self.on_gps(deserialize_message(fixes[i][0], NavSatFix), drain=False)
        self._drain(self.newest_t - self.window)
        self._publish_imu_out()

    def on_gps(self, msg: NavSatFix, drain=True):
        """Queue one fix (NaN and NO_FIX fixes are counted and ignored by the filter)."""
        cov = np.asarray(msg.position_covariance, dtype=float).reshape(3, 3)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if msg.position_covariance_type > 0 else np.zeros(3)
        self._push(stamp_to_s(msg.header.stamp), GPS,
                   (msg.latitude * DEG, msg.longitude * DEG, msg.altitude, std, msg.status.status), drain)

    def _push(self, t, kind, payload, drain=True):
        # IMU stamps are the clock: only they can signal a restart; a very late fix is just late
        if kind == IMU and self.last_t is not None and t < self.last_t - self.time_jump:
            self._drain(self.newest_t - self.window)  # what the stamps before the jump released
            self._reset(f"stamp jumped back {self.last_t - t:.3f} s (bag restart?)")
        heapq.heappush(self.heap, (t, kind, next(self.seq), payload))
        if kind == IMU:  # a fix waits for the IMU to pass it: the denoised IMU arrives later than the fixes
            self.newest_t = max(self.newest_t, t)
        if drain:
            self._drain(self.newest_t - self.window)

    def _reset(self, reason):
        self.get_logger().warn(f"time jump: {reason}; filter reset")
        self.filter.reset(reason)
        self.heap.clear()
        self.newest_t, self.last_t = -math.inf, None
        self.node_resets += 1
        self.last_reset = reason

    def _drain(self, until_t):
        run = []  # consecutive IMU samples go to the filter as one chunk (the same bits as one by one)
        while self.heap and self.heap[0][0] <= until_t:
            t, kind, _, payload = heapq.heappop(self.heap)
            if self.last_t is not None and (t < self.last_t or (kind == GPS and t == self.last_t)):
                self.late_dropped += 1  # arrived after its place in the stamp order was processed
                continue
            if kind == GPS:
                self._process_imu_run(run)
                run = []
                self.filter.process_gps(t, *payload)
                continue
            self.last_t = t
            run.append((t, payload))
        self._process_imu_run(run)

    def _process_imu_run(self, run):
        """Run IMU samples through the filter; queue the newest one, oriented, for imu/data."""
        if not run:
            return
        t = np.array([t for t, _ in run])
        gyro, accel = np.array([p[0] for _, p in run]), np.array([p[1] for _, p in run])
        for est in self.filter.process_imu(t, gyro, accel):
            self.publish_odometry(est)
        self.publish_imu(t[-1], gyro[-1], accel[-1])

    def close(self):
        """Run what is still buffered through the filter without publishing (called by run_node on shutdown)."""
        self.intake_loop.stop()
        self.closing = True
        try:
            self.take_input()
        except Exception:  # the context may already be shut down on SIGINT; what was queued still runs
            pass
        self._drain(math.inf)

    # ------------------------------------------------------------------ output

    def publish_imu(self, t, gyro, accel):
        """Queue the input sample, bias-corrected, with the estimated orientation and its covariance."""
        f = self.filter
        if not f.navigating or self.closing:
            return
        self.imu_out.append((t, f.nav[strapdown.Q].copy(), f.cov[em.PHI, em.PHI].ravel(),
                             gyro - f.gyro_bias, accel - f.accel_bias))

    def _publish_imu_out(self):
        """Publish the queued oriented samples on imu/data in one raw-CDR batch."""
        if not self.imu_out:
            return
        t, quat, quat_cov, gyro, accel = (np.array(col) for col in zip(*self.imu_out))
        self.imu_out.clear()
        f = self.filter
        sec, nanosec = stamps_from_s(t)
        publish_imu_batch(self.imu_pub, sec, nanosec, gyro, accel, self.params["child_frame_id"],
                          gyro_var=f.noise.gyro_white ** 2 * f.cfg.imu_rate_hz,
                          accel_var=f.noise.accel_white ** 2 * f.cfg.imu_rate_hz,
                          orientation_xyzw=quat, orientation_cov=quat_cov)

    def publish_odometry(self, est: Estimate):
        """Pose (ENU, odom) and twist (body) with covariances from the filter's P."""
        self.last_estimate = est
        if self.closing:
            return
        msg = Odometry()
        msg.header.stamp = stamp_from_s(est.t)
        msg.header.frame_id = self.params["frame_id"]
        msg.child_frame_id = self.params["child_frame_id"]
        p = msg.pose.pose
        p.position.x, p.position.y, p.position.z = (float(v) for v in est.position_n)
        p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = (float(v) for v in est.quat_xyzw)
        idx = np.r_[0:3, 6:9]
        msg.pose.covariance = est.cov[np.ix_(idx, idx)].flatten().tolist()
        mat_bn = self.filter.mat_nb().T
        v_b = mat_bn @ est.velocity_n
        msg.twist.twist.linear.x, msg.twist.twist.linear.y, msg.twist.twist.linear.z = (float(v) for v in v_b)
        twist_cov = np.zeros((6, 6))
        twist_cov[:3, :3] = mat_bn @ est.cov[em.DV, em.DV] @ mat_bn.T
        twist_cov[3:, 3:] = np.diag(self.filter.noise.gyro_white ** 2 * self.filter.cfg.filter_rate_hz)
        msg.twist.covariance = twist_cov.flatten().tolist()
        self.odom_pub.publish(msg)

    def publish_diagnostics(self):
        """State, NIS, rejected fixes, GPS age, alignment status, resets."""
        f = self.filter
        c = f.counters
        age = (self.last_t - f.last_fix_t) if self.last_t is not None else math.inf
        stale_gps = age > 3.0 / f.cfg.gps_rate_hz
        if f.status == NAVIGATING and not stale_gps:
            level, message = "OK", "navigating"
        elif f.status == NAVIGATING:
            level, message = "WARN", f"navigating on INS only (GPS age {age:.1f} s)"
        else:
            level, message = "WARN", f.status
        values = {"state": f.status, "last_nis": f.last_nis, "fixes": c.fixes, "rejected_fixes": c.fixes_rejected,
                  "invalid_fixes": c.fixes_invalid, "reused_fixes": c.fixes_reused, "gps_resets": c.gps_resets,
                  "gps_age_s": age, "zupts": c.zupts, "epochs": c.epochs,
                  "alignment": ("aligned" if f.alignment is not None else
                                f"{f.aligner.elapsed_s:.1f}/{f.cfg.alignment_time_s:.0f} s stationary"
                                if f.status == ALIGNING else "waiting for a GPS fix (datum)"),
                  "filter_resets": c.resets, "imu_gaps_bridged": c.gaps_bridged,
                  "last_reset": (c.reset_reasons[-1] if c.reset_reasons else ""),
                  "late_dropped": self.late_dropped, "imu_received": self.imu_received,
                  "bad_imu_messages": self.imu_intake.bad_messages}
        if f.alignment is not None:
            values.update({"align_roll_deg": f.alignment.roll / DEG, "align_pitch_deg": f.alignment.pitch / DEG})
        self.diag.publish(level, message, values)


def main(args=None) -> int:
    """Console script ``ins_gps_kf_node``."""
    return run_node(InsGpsKfNode, args=args)


if __name__ == "__main__":
    raise SystemExit(main())
