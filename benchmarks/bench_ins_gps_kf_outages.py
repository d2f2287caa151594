"""Benchmark of the filter through GNSS outages, scored as KF-GINS's paper does (issue 25).

60-s outages every 3 minutes, repeated with the start shifted by 60 s and 120 s; the score is the RMS over
all outages of the largest horizontal error inside each. Drive: the simulated paper drive (12 min, 5 km,
BP3010-grade errors, 1 Hz GNSS), seeds 0 and 1. Compared in the same run: the plain forward filter (the
named peer), the forward filter with non-holonomic constraints (``nhc_enabled``), and the forward-backward
smoother (:mod:`ins_gps_kf.smoother`) of both, and NHC with a wheel odometer simulated from the truth (0.5 %
scale error, 0.05 m/s noise, 10 Hz; the filter estimates the scale). Prints the figures and the ratios to the
plain forward filter (issue 25's targets: NHC at most 0.4, NHC + odometer at most 0.1, smoothed + NHC at most 0.1). Then, with GNSS throughout, the smoothed
horizontal RMS against the forward one (target at most 0.85), the backward pass's CPU time against the forward
pass's (target at most 1), and the smoother's memory for a 2-hour drive at 64 Hz (target under 300 MB),
extrapolated from this drive's measured bytes per filter epoch. The simulated IMU is mounted square in the car (a mounting tilt the filter is not told is not simulated here).

    .venv/bin/python benchmarks/bench_ins_gps_kf_outages.py [--seeds 0 1] [--quick]
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_core.workspace import PAPER_DRIVE, workspace_file
from nav_eval.metrics import drop_fixes, outage_windows, truth_at
from ins_gps_kf import config
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from ins_gps_kf.smoother import ForwardStore, smooth

OUTAGE_S, PERIOD_S, FIRST_S, SHIFTS_S = 60.0, 180.0, 120.0, (0.0, 60.0, 120.0)
CASES = {"forward": {}, "forward + NHC": {"nhc_enabled": True},
         "forward + NHC + odometer": {"nhc_enabled": True, "odometer_enabled": True}}
ODOMETER_SCALE, ODOMETER_STD_MPS, ODOMETER_RATE_HZ = 0.005, 0.05, 10.0


def simulated_odometer(truth, seed: int) -> tuple:
    """(t s, wheel speed m/s): the truth's forward speed at ``ODOMETER_RATE_HZ`` with the scale error and noise."""
    t = np.arange(truth.t[0], truth.t[-1], 1.0 / ODOMETER_RATE_HZ)
    yaw, pitch = (np.interp(t, truth.t, np.unwrap(a)) for a in (truth.yaw, truth.pitch))
    vel = np.column_stack([np.interp(t, truth.t, truth.velocity_n[:, i]) for i in range(3)])
    axis = np.column_stack([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), np.sin(pitch)])
    noise = np.random.default_rng(seed + 1000).normal(0.0, ODOMETER_STD_MPS, len(t))
    return t, (1.0 + ODOMETER_SCALE) * np.sum(vel * axis, axis=1) + noise
LONG_DRIVE_S = 7200.0  # the memory target: a 2-hour drive


def forward_and_smoothed(imu, gnss, model, params: dict, trace=False, odometry=None):
    """(forward estimates, smoothed estimates, filter, forward CPU s, backward CPU s, backward peak heap bytes:
    measured with ``trace`` only, which slows the pass)."""
    filt = InsGpsFilter(config.from_params(params), model)
    filt.recorder = ForwardStore(filt.n_states)
    t0 = time.process_time()
    forward = run(filt, imu, gnss, odometry=odometry if filt.cfg.odometer_enabled else None)
    t1 = time.process_time()
    trace and tracemalloc.start()
    smoothed = smooth(filt.recorder, forward)
    peak = tracemalloc.get_traced_memory()[1] if trace else 0
    trace and tracemalloc.stop()
    t2 = time.process_time()
    filt.recorder = None
    return forward, smoothed, filt, t1 - t0, t2 - t1, peak


def horizontal_rms(est, truth, frame) -> float:
    """Horizontal RMS error (m) of ``est`` against ``truth`` over all epochs."""
    t = np.array([e.t for e in est])
    err = np.array([e.position_n for e in est]) - truth_at(truth, frame, t).enu
    return float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))))


def largest_errors(est, truth, frame, windows) -> list[float]:
    """Largest horizontal error (m) of the epochs inside each outage window."""
    t = np.array([e.t for e in est])
    pos = np.array([e.position_n for e in est])
    out = []
    for t0, t1 in windows:
        inside = (t >= t0) & (t <= t1)
        if inside.any():
            ref = truth_at(truth, frame, t[inside]).enu
            out.append(float(np.max(np.hypot(*(pos[inside] - ref)[:, :2].T))))
    return out


def main(argv=None) -> int:
    """Run every seed, shift and case; print the scores."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    p.add_argument("--quick", action="store_true", help="seed 0 only")
    args = p.parse_args(argv)
    if args.quick:
        args.seeds = [0]
    model = bp3010_grade_model()
    names = [*CASES, *(n.replace("forward", "smoothed") for n in CASES)]
    scores = {name: [] for name in names}
    cost = {"forward_s": 0.0, "backward_s": 0.0, "epochs": 0, "peak": 0}
    throughout = {name: [] for name in names}
    for seed in args.seeds:
        sim = simulate(str(workspace_file(PAPER_DRIVE)), model=model, seed=seed, with_bytes=False)
        odometry = simulated_odometer(sim.truth, seed)
        for shift in SHIFTS_S:
            windows = outage_windows(FIRST_S + shift, sim.truth.t[-1], PERIOD_S, OUTAGE_S, FIRST_S + shift)
            gnss = drop_fixes(sim.gnss, windows)
            for name, extra in CASES.items():
                fwd, smo, filt, t_f, t_b, peak = forward_and_smoothed(sim.imu, gnss, model,
                                                                      {"imu_rate_hz": sim.rate_hz, **extra},
                                                                      odometry=odometry)
                cost["forward_s"] += t_f
                cost["backward_s"] += t_b
                cost["epochs"] += len(fwd)
                for label, est in ((name, fwd), (name.replace("forward", "smoothed"), smo)):
                    errs = largest_errors(est, sim.truth, filt.frame, windows)
                    scores[label] += errs
                    print(f"seed {seed} shift {shift:5.0f} s {label:<24} largest error per outage (m): "
                          + " ".join(f"{e:6.1f}" for e in errs))
        for name, extra in CASES.items():
            fwd, smo, filt, *_, peak = forward_and_smoothed(sim.imu, sim.gnss, model,
                                                            {"imu_rate_hz": sim.rate_hz, **extra}, trace=True,
                                                            odometry=odometry)
            cost["peak"] = max(cost["peak"], peak / len(fwd))
            throughout[name].append(horizontal_rms(fwd, sim.truth, filt.frame))
            throughout[name.replace("forward", "smoothed")].append(horizontal_rms(smo, sim.truth, filt.frame))
    rms = {name: float(np.sqrt(np.mean(np.square(v)))) for name, v in scores.items()}
    for name, value in rms.items():
        print(f"{name:<24} RMS of the largest horizontal error per outage: {value:7.2f} m "
              f"({len(scores[name])} outages, worst {max(scores[name]):.1f} m; {value / rms['forward']:.3f}x forward)")
    print(f"forward + NHC / forward: {rms['forward + NHC'] / rms['forward']:.3f} (target <= 0.4)")
    print(f"forward + NHC + odometer / forward: {rms['forward + NHC + odometer'] / rms['forward']:.3f} "
          "(target <= 0.1)")
    print(f"smoothed + NHC / forward: {rms['smoothed + NHC'] / rms['forward']:.3f} (target <= 0.1)")
    for name in CASES:
        f, s = (float(np.sqrt(np.mean(np.square(throughout[n])))) for n in (name, name.replace("forward", "smoothed")))
        print(f"GNSS throughout, {name}: horizontal RMS forward {f:.3f} m, smoothed {s:.3f} m: {s / f:.3f}x "
              "(target <= 0.85)")
    print(f"backward pass CPU {cost['backward_s']:.2f} s against forward {cost['forward_s']:.2f} s over "
          f"{cost['epochs']} epochs: {cost['backward_s'] / cost['forward_s']:.3f}x (target <= 1)")
    rate = float(config.defaults()["filter_rate_hz"])
    store = ForwardStore(15)
    epochs = int(LONG_DRIVE_S * rate)
    per_epoch = store.width * 8
    print(f"2-hour drive at 64 Hz (extrapolated, {epochs} epochs at the {rate:g}-Hz filter rate): smoother store "
          f"{epochs * per_epoch / 1e6:.1f} MB ({per_epoch} B/epoch, on disk past {store.ram_rows} epochs: "
          f"{store.ram_rows * per_epoch / 1e6:.1f} MB in memory), backward pass heap "
          f"{cost['peak'] * epochs / 1e6:.1f} MB ({cost['peak']:.0f} B/epoch measured, the smoothed estimates "
          "it returns included); target < 300 MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
