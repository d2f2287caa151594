"""Benchmark of wmra_filter: batch throughput, streaming cost per message, CPU share at 1 kHz, latency at 64 Hz.

Usage: python benchmarks/bench_wmra_filter.py [--quick] [--node]

Peers measured in the same run: PyWavelets' own ``pywt.iswt`` in place of our
vectorised inverse (batch), and a per-sample ``scipy.signal.sosfilt`` Butterworth
low-pass (streaming). ``--node`` also runs the real ``wmra_node`` process fed at
1 kHz and reads its CPU time from /proc (Linux).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pywt
from scipy import signal

from nav_core.sensor_model import SensorModel, TriadModel, save
from wmra_filter import wmra
from wmra_filter.evaluation import N_ACCEL, N_GYRO
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import Calibrator, WmraConfig, denoise, estimate_thresholds, model_sample_sigma


def _model(fs: float) -> SensorModel:
    return SensorModel(gyro=TriadModel(white_noise=np.full(3, N_GYRO), bias=np.full(3, 0.005)),
                       accel=TriadModel(white_noise=np.full(3, N_ACCEL), bias=np.full(3, 0.1)), sample_rate_hz=fs)


def _cpu(fn) -> float:
    start = time.process_time()
    fn()
    return time.process_time() - start


def batch_throughput(cfg: WmraConfig, n: int, rng) -> tuple[float, float]:
    """(ours, peer with pywt.iswt) batch samples/s on (n, 6)."""
    x = rng.normal(size=(n, 6))
    lam = estimate_thresholds(cfg, np.full(6, 0.01))
    ours = _cpu(lambda: denoise(x, cfg, lam))
    fast_iswt = wmra.iswt
    wmra.iswt = lambda coeffs, w: np.stack([pywt.iswt([c[:, i] for c in coeffs], w)
                                            for i in range(coeffs[0].shape[1])], axis=1)
    try:
        peer = _cpu(lambda: denoise(x, cfg, lam))
    finally:
        wmra.iswt = fast_iswt
    return n / ours, n / peer


def streaming_cost(cfg: WmraConfig, n: int, rng) -> tuple[float, float, float]:
    """(mean, max) CPU s per input message (calibrate + push), and the sosfilt peer's mean, s."""
    model = _model(cfg.sample_rate_hz)
    gyro, accel = rng.normal(size=(n, 3)) * 0.01, rng.normal(size=(n, 3)) * 0.01 + [0, 0, 9.8]
    stream = StreamingWmra(cfg, 6, sample_sigma=model_sample_sigma(model, cfg.sample_rate_hz))
    calibrate = Calibrator(model)
    per = np.empty(n)
    for i in range(n):
        t0 = time.process_time()
        stream.push(calibrate(gyro[i], accel[i]), tag=i)
        per[i] = time.process_time() - t0
    total = _cpu(lambda: [stream.push(calibrate(gyro[i], accel[i]), tag=i) for i in range(n)])
    sos = signal.butter(4, 5.0, fs=cfg.sample_rate_hz, output="sos")
    zi = np.zeros((sos.shape[0], 2, 6))
    x = np.hstack([gyro, accel])

    def peer():
        nonlocal zi
        for i in range(n):
            _, zi = signal.sosfilt(sos, x[i:i + 1], axis=0, zi=zi)
    return total / n, float(per.max()), _cpu(peer) / n


def node_cpu_share(rate_hz: float, hop: int, seconds: float, intake_s: float = 0.01):
    """CPU share of one core used by a real wmra_node process fed at ``rate_hz``; (share, outputs, diagnostics)."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Imu

    from nav_core.processes import NodeProcess
    from nav_core.imu_cdr import encode_imu
    from nav_core.ros_node import SENSOR_QOS, Probe

    env = dict(os.environ, ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", str(200 + os.getpid() % 30)),
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    with tempfile.TemporaryDirectory() as tmp:
        path = save(_model(rate_hz), Path(tmp) / "model.yaml")
        # gap_factor 1000: a dropped best-effort message must not restart the window (steady-state cost);
        # with the default 1.5 each drop restarts, and restarts cascade when the node falls behind
        node = NodeProcess("wmra_node", env=env, ros_args={"sensor_model_path": str(path), "hop": hop,
                                                           "gap_factor": 1000.0, "intake_period_s": intake_s})
        try:
            if not node.wait_for_line("ready", 30):
                raise RuntimeError(node.output)
            rclpy.init()
            probe = Probe({"imu/data_corrected": Imu, "/diagnostics": DiagnosticArray}, qos=QoSProfile(depth=100,
                                                                       reliability=ReliabilityPolicy.BEST_EFFORT))
            pub = probe.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
            probe.spin_until(lambda p: pub.get_subscription_count() > 0, 20)
            rng = np.random.default_rng(0)
            n_total = int(seconds * rate_hz) + 1
            ns = np.arange(n_total) * int(1e9 / rate_hz)
            messages = encode_imu(ns // 10**9, ns % 10**9, rng.normal(size=(n_total, 3)) * 0.01,
                                  np.tile([0.0, 0.0, 9.8], (n_total, 1)))
            cpu0 = _proc_cpu_s(node.proc.pid)
            start = time.monotonic()
            i = 0
            while time.monotonic() - start < seconds and i < n_total:
                due = int((time.monotonic() - start) * rate_hz)
                while i < due:
                    pub.publish(messages[i])
                    i += 1
                rclpy.spin_once(probe, timeout_sec=0.0005)
            share = (_proc_cpu_s(node.proc.pid) - cpu0) / (time.monotonic() - start)
            outputs = len(probe.received["imu/data_corrected"])
            probe.spin_until(lambda p: len(p.received["/diagnostics"]) > 0, 3)
            diag = {}
            for _, arr in probe.received["/diagnostics"]:
                diag = {kv.key: kv.value for st in arr.status for kv in st.values}
            probe.destroy_node()
            rclpy.try_shutdown()
            return share, outputs, diag, i
        finally:
            node.stop()


def _proc_cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced sizes, a few seconds")
    parser.add_argument("--node", action="store_true", help="also measure the real node process at 1 kHz")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    n_batch, n_stream = (1 << 14, 2000) if args.quick else (1 << 18, 20000)
    cfg64 = WmraConfig.for_bandwidth(64.0, hop=8)
    print(f"wmra_filter benchmark ({'quick' if args.quick else 'full'}), db8, hard_soft, 6 axes")
    for label, cfg in (("64 Hz, 5 Hz band", cfg64),
                       ("1 kHz, 5 Hz band", WmraConfig.for_bandwidth(1000.0, hop=256))):
        ours, peer = batch_throughput(cfg, n_batch, rng)
        print(f"batch {label} (level {cfg.level}): {ours:,.0f} samples/s "
              f"(peer pywt.iswt inverse: {peer:,.0f} samples/s, x{ours / peer:.1f})")
    for hop in (64, 128, 256, 512):
        cfg = WmraConfig.for_bandwidth(1000.0, hop=hop)
        mean, worst, peer = streaming_cost(cfg, n_stream if not args.quick else 2 * hop + 1200, rng)
        print(f"streaming 1 kHz level {cfg.level} hop {hop} window {cfg.window_samples}: "
              f"{mean * 1e6:.1f} us CPU/message (max {worst * 1e3:.2f} ms), CPU share at 1 kHz "
              f"{100 * mean * 1000:.1f} % of one core, delay {cfg.delay_s:.3f} s "
              f"(peer sosfilt low-pass {peer * 1e6:.1f} us/message)")
    mean, worst, peer = streaming_cost(cfg64, n_stream // 4 if not args.quick else 600, rng)
    print(f"streaming 64 Hz level {cfg64.level} hop {cfg64.hop} window {cfg64.window_samples}: "
          f"{mean * 1e6:.1f} us CPU/message (max {worst * 1e3:.2f} ms); added latency = window delay "
          f"{cfg64.delay_samples} samples = {cfg64.delay_s * 1e3:.1f} ms + processing {mean * 1e3:.3f} ms mean "
          f"/ {worst * 1e3:.2f} ms worst = {(cfg64.delay_s + mean) * 1e3:.1f} ms, plus up to the node's "
          f"intake_period_s (10 ms default) of batching")
    if args.node:
        for hop, intake_s in ((512, 0.02), (256, 0.01)):
            share, outputs, diag, sent = node_cpu_share(1000.0, hop, 5.0 if args.quick else 15.0, intake_s)
            print(f"real wmra_node process fed at 1 kHz (hop {hop}, intake every {intake_s * 1e3:g} ms): "
                  f"{100 * share:.1f} % of one core (target < 10 %; includes DDS and rclpy); sent {sent}, "
                  f"node received {diag.get('received')}, restarts {diag.get('restarts')}, filled "
                  f"{diag.get('filled_samples')}, processing {diag.get('processing_mean_us')} us/message; "
                  f"{outputs} outputs received by the probe")
    return 0


if __name__ == "__main__":
    sys.exit(main())
