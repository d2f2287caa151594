"""wmra_node: calibrate and WMRA-denoise ``imu/data_raw`` into ``imu/data_corrected`` (sensor-data QoS).

Each output carries the stamp and frame of the input sample it denoises and leaves
``delay_samples`` (= right support + hop - 1) samples after it. Gaps and time jumps are
:class:`wmra_filter.stream_policy.StreamPolicy`'s: a gap of up to ``fill_gap_samples``
whole samples is filled by interpolation, any other break restarts the window (pending
samples flushed first), counted in the diagnostics and logged. This module is wiring.

Input is taken in batches every ``intake_period_s`` and output published as raw CDR
(:mod:`nav_core.imu_cdr`): the per-message executor callback and Imu object building
cost ten times the denoising at 1 kHz.
"""
from __future__ import annotations

import threading
import time

import numpy as np
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu

from nav_core import sensor_model
from nav_core.params import ConfigError, Param
from nav_core.ros_node import (LINK_QOS, SENSOR_QOS, Diagnostics, ImuBatchSubscription, IntakeLoop,
                               declare_parameters, link_publisher, publish_imu_batch, run_node)
from rclpy.node import Node
from wmra_filter import levels, thresholds as thr
from wmra_filter.stream_policy import StreamPolicy
from wmra_filter.status import WmraStatus
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import Calibrator, WmraConfig, WmraConfigError, model_sample_sigma

PARAMS = (
    Param("sensor_model_path", "", "sensor-model YAML (nav_core.sensor_model): calibration and white noise N"),
    Param("sample_rate_hz", 0.0, "input sample rate, Hz; 0 = the sensor model's sample_rate_hz", 0.0, 1e5),
    Param("wavelet", "db8", "PyWavelets discrete wavelet (the paper: db8)"),
    Param("vehicle", "road_vehicle", "vehicle class whose motion bandwidth is kept when bandwidth_hz is 0",
          choices=tuple(levels.VEHICLE_BANDWIDTH_HZ)),
    Param("bandwidth_hz", 0.0, "motion bandwidth kept untouched, Hz; 0 = the vehicle's default", 0.0, 1e5),
    Param("level", 0, "SWT decomposition level; 0 = from sample rate and bandwidth", 0, 12),
    Param("window", 0, "SWT window, samples (multiple of 2^level); 0 = the smallest valid one", 0, 1 << 20),
    Param("hop", 8, "outputs computed per SWT step, samples (delay and CPU trade-off)", 1, 1 << 16),
    Param("threshold_mode", "hard_soft", "shrinkage: hard, soft or hard_soft (hard, then soft at soft_ratio)",
          choices=thr.MODES),
    Param("soft_ratio", 0.5, "hard_soft: soft threshold as a fraction of the hard one", 0.0, 1.0),
    Param("threshold_rule", "universal", "threshold rule: universal or sure", choices=thr.RULES),
    Param("noise_source", "model", "detail noise sigma from the sensor model's white noise or from the data (mad)",
          choices=thr.NOISE_SOURCES),
    Param("gap_factor", 1.5, "a sample interval above gap_factor / sample_rate_hz restarts the window", 1.01, 1e3),
    Param("fill_gap_samples", 4, "a gap of up to this many missing samples (a dropped message) is filled by linear "
          "interpolation instead of restarting; fill samples are not published", 0, 1000),
    Param("intake_period_s", 0.01, "imu/data_raw is taken in batches at this period, s (adds up to this much "
          "latency; one executor callback per message would cost more CPU than the denoising at 1 kHz)",
          0.0005, 1.0),
    Param("diagnostics_period_s", 1.0, "period of the /diagnostics status, s", 0.05, 60.0),
    Param("input_queue_depth", 20000, "imu/data_raw messages held until taken: a node held up (a busy CPU) "
          "catches up instead of losing samples; 20,000 = 39 s of 64-Hz IMU at 8x", 100, 1000000),
)


def config_from_params(values: dict, model: sensor_model.SensorModel) -> WmraConfig:
    """The WMRA config the node's parameters describe (raises WmraConfigError)."""
    fs = values["sample_rate_hz"] or model.sample_rate_hz
    common = dict(wavelet=values["wavelet"], mode=values["threshold_mode"], soft_ratio=values["soft_ratio"],
                  rule=values["threshold_rule"], noise=values["noise_source"], hop=values["hop"],
                  window=values["window"])
    if values["level"]:
        return WmraConfig(fs, values["level"], **common)
    return WmraConfig.for_bandwidth(fs, values["bandwidth_hz"] or None, values["vehicle"], **common)


def load_model(path: str) -> sensor_model.SensorModel:
    """The sensor model at ``path`` (ConfigError naming the parameter and the file)."""
    if not path:
        raise ConfigError("parameter 'sensor_model_path' is empty: give the sensor-model YAML to apply")
    try:
        return sensor_model.load(path)
    except sensor_model.SensorModelError as err:
        raise ConfigError(f"parameter 'sensor_model_path': {err}") from None


class WmraNode(Node):
    """The denoising node around :class:`StreamingWmra`."""

    def __init__(self):
        super().__init__("wmra_node")
        values = declare_parameters(self, PARAMS)
        self.model = load_model(values["sensor_model_path"])
        try:
            self.cfg = config_from_params(values, self.model)
        except WmraConfigError as err:
            raise ConfigError(str(err)) from None
        sigma = model_sample_sigma(self.model, self.cfg.sample_rate_hz)
        if self.cfg.noise == "model" and not np.all(sigma > 0):
            raise ConfigError(f"{values['sensor_model_path']}: white_noise must be > 0 on every axis for "
                              "noise_source 'model' (or set noise_source: mad)")
        self.stream = StreamingWmra(self.cfg, 6, sample_sigma=sigma)
        # published covariance: the model's per-sample white-noise variance, an upper bound (denoising removes
        # part of it); 0 ("unknown") only where the model has no white noise
        self.sample_var = sigma ** 2
        self.policy = StreamPolicy(self.stream, self.cfg.sample_rate_hz, values["gap_factor"],
                                   values["fill_gap_samples"])
        self.calibrate = Calibrator(self.model)
        self.stats = {"published": 0, "busy_s": 0.0, "busy_max_s": 0.0}
        # overridable: on two hosts nav-demo makes it reliable, so the recorder keeps the cut's backlog burst
        self.pub = link_publisher(self, Imu, "imu/data_corrected", SENSOR_QOS)
        qos = QoSProfile(depth=values["input_queue_depth"], reliability=ReliabilityPolicy.BEST_EFFORT)
        self.intake = ImuBatchSubscription(self, "imu/data_raw", self.on_batch, None, qos=qos,
                                           qos_overriding_options=LINK_QOS)
        self.diagnostics = Diagnostics(self, "wmra", hardware_id=values["sensor_model_path"])
        self.lock = threading.Lock()
        self.create_timer(values["diagnostics_period_s"], self._publish_diagnostics_locked)
        self.intake_period_s = values["intake_period_s"]
        self.intake_loop = IntakeLoop(self, self.intake_period_s, self.intake.drain, self.lock)
        self.get_logger().info(f"ready: level {self.cfg.level}, window {self.cfg.window_samples}, "
                               f"hop {self.cfg.hop}, delay {self.cfg.delay_samples} samples "
                               f"({self.cfg.delay_s:.3f} s at {self.cfg.sample_rate_hz:g} Hz)")

    def on_batch(self, batch) -> None:
        """Calibrate a batch of samples, hand it to the gap policy, publish what the window releases."""
        start = time.perf_counter()
        samples = self.calibrate(batch.gyro, batch.accel)
        tags = list(zip(batch.sec.tolist(), batch.nanosec.tolist(), batch.frame_ids))
        released, restarts = self.policy.push(batch.t_s, samples, tags)
        for text in restarts:
            self.get_logger().warning(f"imu/data_raw: {text}")
        self._publish(released)
        busy = time.perf_counter() - start
        self.stats["busy_s"] += busy
        self.stats["busy_max_s"] = max(self.stats["busy_max_s"], busy)

    def _publish(self, outputs) -> None:
        """Publish released ``((sec, nanosec, frame_id), value)`` pairs; fill samples (tag None) are not."""
        kept = [(tag, value) for tag, value in outputs if tag is not None]
        if not kept:
            return
        sec, nanosec, frames = zip(*(tag for tag, _ in kept))
        values = np.array([value for _, value in kept])
        frames = np.array(frames)
        for frame_id in dict.fromkeys(frames):  # one run per frame_id, normally a single one
            rows = np.flatnonzero(frames == frame_id)
            self.stats["published"] += publish_imu_batch(self.pub, np.array(sec)[rows], np.array(nanosec)[rows],
                                                         values[rows, :3], values[rows, 3:], str(frame_id),
                                                         gyro_var=self.sample_var[:3], accel_var=self.sample_var[3:])

    def _publish_diagnostics_locked(self) -> None:
        with self.lock:  # the intake thread changes what the diagnostics read
            self.publish_diagnostics()

    def publish_diagnostics(self) -> None:
        """Delay, window, thresholds in use and processing time per message on /diagnostics."""
        s, p, cfg = self.stats, self.policy.stats, self.cfg
        lam = self.stream.thresholds
        st = WmraStatus(
            "WARN" if p.restarts or p.nonfinite else "OK", "denoising" if p.received else "waiting for imu/data_raw",
            cfg.delay_samples, cfg.delay_s, cfg.window_samples, cfg.hop, cfg.level, cfg.wavelet, cfg.mode, cfg.rule,
            cfg.noise, "pending" if lam is None else _levels_text(lam[:, :3]),
            "pending" if lam is None else _levels_text(lam[:, 3:]), p.received, s["published"], p.restarts,
            p.filled_samples, p.nonfinite, p.last_restart, 1e6 * s["busy_s"] / max(p.received, 1),
            self.intake_period_s, self.intake.bad_messages, 1e6 * s["busy_max_s"])
        self.diagnostics.publish(st.level, st.message, st.to_values())

    def close(self) -> None:
        """Publish the samples still in the window before shutting down."""
        if not self.intake_loop.stop():  # its thread is still on a batch: a second thread on the intake would race
            self.get_logger().warn("shutdown: the intake is still busy; the samples in the window are not published")
            return
        try:
            self.intake.drain()
            self._publish(self.policy.flush())
        except Exception:  # the context may already be shut down on SIGINT; losing the tail is acceptable
            pass


def _levels_text(lam: np.ndarray) -> str:
    return "; ".join(f"L{j + 1}: " + " ".join(f"{v:.3g}" for v in row) for j, row in enumerate(lam))


def main(args=None) -> int:
    """Console script ``wmra_node``."""
    return run_node(WmraNode, args, usage=(
        "wmra_node",
        "Calibrate and wavelet-denoise (WMRA) imu/data_raw into imu/data_corrected.",
        PARAMS,
        "wmra_node --ros-args --params-file config/navigation.yaml "
        "-p sensor_model_path:=config/sensor_models/bp3010.yaml"))


if __name__ == "__main__":
    raise SystemExit(main())
