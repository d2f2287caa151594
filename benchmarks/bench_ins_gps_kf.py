"""Benchmark of ins_gps_kf: offline replay throughput (IMU epochs/s) and memory.

Figures: a 1-hour 64 Hz and a 1-hour 200 Hz synthetic drive (circle, 1 Hz GPS,
filter at 2 Hz) through the same core the node and ``ins-gps-kf replay`` use.
Target: at least 45,000 IMU epochs/s. Named peer, measured in the same run: the
same strapdown kernel run as plain Python (numba's ``py_func``), on a slice.
``--quick`` runs 2 minutes of data instead of an hour.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the CLI and node do

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from ins_gps_kf import config, strapdown  # noqa: E402
from ins_gps_kf import synthetic as syn  # noqa: E402
from ins_gps_kf.filter import InsGpsFilter  # noqa: E402
from ins_gps_kf.replay import run  # noqa: E402

TARGET_EPOCHS_PER_S = 45_000


def make_drive(duration_s: float, rate_hz: float, seed: int = 0):
    """IMU and GPS recordings of a circle drive (45 s rest first), white noise and biases."""
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=duration_s - 75.0, yaw_rate=0.02)
    rng = np.random.default_rng(seed)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, rate_hz, oversample=1), rng, 1e-4, 0.01, 3e-4, 2e-3)
    return imu, syn.gnss(motion, rate_hz, 2.0, rng)


def bench_replay(duration_s: float, rate_hz: float) -> dict:
    """Replay wall time, IMU epochs per second and the process peak RSS after the run."""
    imu, gnss = make_drive(duration_s, rate_hz)
    filt = InsGpsFilter(config.from_params({"imu_rate_hz": rate_hz}))
    t0 = time.perf_counter()
    est = run(filt, imu, gnss)
    wall = time.perf_counter() - t0
    return {"rate_hz": rate_hz, "duration_s": duration_s, "samples": len(imu), "filter_epochs": len(est),
            "wall_s": wall, "epochs_per_s": len(imu) / wall,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            "input_mb": (imu.gyro.nbytes + imu.accel.nbytes + imu.t.nbytes) / 2**20}


def bench_filter_memory(duration_s: float, rate_hz: float) -> float:
    """Peak Python-heap growth (MB) of a replay (tracemalloc; the input arrays excluded): the filter and its output."""
    import tracemalloc

    imu, gnss = make_drive(duration_s, rate_hz)
    filt = InsGpsFilter(config.from_params({"imu_rate_hz": rate_hz}))
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    run(filt, imu, gnss)
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    return peak / 2**20


def bench_peer(rate_hz: float, n: int) -> dict:
    """The strapdown kernel as plain Python (numba's py_func) versus compiled, over ``n`` samples."""
    imu, _ = make_drive(max(120.0, n / rate_hz + 80.0), rate_hz)
    z = np.zeros(3)
    out = {}
    for name, fn in (("numba", strapdown.integrate), ("python", strapdown.integrate.py_func)):
        nav, mem = strapdown.new_state([0, 0, 0, 1.0], z, z), strapdown.new_memory(0.0)
        t0 = time.perf_counter()
        fn(nav, mem, imu.t[:n], imu.gyro[:n], imu.accel[:n], z, z, z, z, z)
        out[name] = n / (time.perf_counter() - t0)
    return out


def main(argv=None) -> int:
    """Print the figures; exit 0 (the target is reported, not enforced)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 minutes of data instead of 1 hour")
    args = parser.parse_args(argv)
    duration = 120.0 if args.quick else 3600.0
    strapdown.warm_up()
    print(f"ins_gps_kf replay throughput ({'quick: 2 min' if args.quick else '1 hour'} drives; target "
          f">= {TARGET_EPOCHS_PER_S:,} IMU epochs/s)")
    for rate in (64.0, 200.0):
        r = bench_replay(duration, rate)
        verdict = "meets" if r["epochs_per_s"] >= TARGET_EPOCHS_PER_S else "BELOW"
        print(f"  {rate:5.0f} Hz: {r['samples']:>9,} samples, {r['filter_epochs']:,} filter epochs in "
              f"{r['wall_s']:.2f} s = {r['epochs_per_s']:,.0f} epochs/s ({verdict} target); "
              f"process peak RSS {r['peak_rss_mb']:.0f} MB (mostly the synthetic truth generation; "
              f"input arrays {r['input_mb']:.0f} MB)")
    mem_s = 120.0 if args.quick else 900.0
    mem = bench_filter_memory(mem_s, 64.0)
    print(f"  filter heap peak over a {mem_s / 60:.0f} min 64 Hz replay: {mem:.1f} MB "
          f"(~{mem * 3600 / mem_s:.0f} MB per hour: the kept per-epoch estimates with their 15x15 covariance)")
    peer = bench_peer(64.0, 2000 if args.quick else 20000)
    print(f"  peer: strapdown kernel alone, numba {peer['numba']:,.0f} samples/s vs plain Python "
          f"{peer['python']:,.0f} samples/s ({peer['numba'] / peer['python']:.0f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
