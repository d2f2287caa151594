"""Benchmark of the filter through GNSS outages, scored as KF-GINS's paper does (issue 25).

60-s outages every 3 minutes, repeated with the start shifted by 60 s and 120 s; the score is the RMS over
all outages of the largest horizontal error inside each. Drive: the simulated paper drive (12 min, 5 km,
BP3010-grade errors, 1 Hz GNSS), seeds 0 and 1, with the IMU mounted in the car at roll 1, pitch 2, yaw 3 deg,
which the filter is not told. Compared in the same run: the plain forward filter (the named peer), the forward
filter with non-holonomic constraints (``nhc_enabled``) and with NHC and a wheel odometer simulated from the truth
(0.5 % scale error, 0.05 m/s noise, 10 Hz; the filter estimates the scale), each with the mounting estimated (the
default: two filter states), given true and given as zero; and the forward-backward smoother
(:mod:`ins_gps_kf.smoother`) of every run. Prints the figures and the ratios to the plain forward filter (issue
25's targets: NHC at most 0.4, NHC + odometer at most 0.1, smoothed + NHC at most 0.1).

Then, with GNSS throughout: the smoothed horizontal RMS against the forward one (target at most 0.85); the position
NEES (3 dof) of the forward and smoothed estimates (mean, and the share of epochs beyond the chi-square 99 % point);
the share of epochs whose smoothed horizontal error is no larger than the forward one (issue target 95 %) beside
what an optimal smoother gives with these covariances (:func:`ins_gps_kf.smoother.no_worse_probability`); epochs
where a smoothed variance exceeds the forward one; the backward pass's CPU time against the forward pass's
(target at most 1). Last, ``ins-gps-kf replay --smooth`` on a 2-hour drive at 64 Hz (a synthetic circle drive
written as CSV; 10 minutes with --quick) in a child process, whose peak RSS is measured (target under 300 MB).

    nice -n 10 .venv/bin/python benchmarks/bench_ins_gps_kf_outages.py [--seeds 0 1] [--quick]
        [--bias-gm-states 1 3] [--mounting-estimated-only] [--no-memory] [--no-katwijk]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_core import frames, recording
from nav_core.workspace import PAPER_DRIVE, workspace_file
from nav_eval.metrics import drop_fixes, outage_windows, truth_at
from nav_eval.outages import HorizontalErrors, largest_per_outage
from ins_gps_kf import config
from ins_gps_kf import synthetic as syn
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from ins_gps_kf.smoother import ForwardStore, no_worse_probability, smooth

OUTAGE_S, PERIOD_S, FIRST_S, SHIFTS_S = 60.0, 180.0, 120.0, (0.0, 60.0, 120.0)
TILT_DEG = (1.0, 2.0, 3.0)  # the IMU's roll, pitch, yaw in the car, not told to the filter
MOUNTINGS = {"estimated": {}, "given true": {"nhc_mounting": "given", **{
    f"mounting_{a}_deg": v for a, v in zip(("roll", "pitch", "yaw"), TILT_DEG)}},
    "given zero": {"nhc_mounting": "given"}}
CASES = {"forward": {}, "NHC": {"nhc_enabled": True}, "NHC + odometer": {"nhc_enabled": True, "odometer_enabled": True}}
OPTIONS = {"scale factors estimated": {"estimate_scale_factors": True},
           "ZUPT in outages": {"zupt_max_ins_speed_outage_mps": 2.0},
           "scale factors + ZUPT in outages": {"estimate_scale_factors": True, "zupt_max_ins_speed_outage_mps": 2.0}}
"""Options measured besides (not --quick): the 21-state model (the simulated IMU has scale factors and misalignment
the 15 states omit) and zero-velocity updates at stops inside outages (with the odometer a stop is seen anyway)."""
ODOMETER_SCALE, ODOMETER_STD_MPS, ODOMETER_RATE_HZ = 0.005, 0.05, 10.0
LONG_DRIVE_S, QUICK_DRIVE_S = 7200.0, 600.0  # the memory target: a 2-hour drive at 64 Hz
NEES_POINT = chi2.ppf(0.99, 3)
REPLAY_REPORTING_PEAK = ("import sys\nfrom ins_gps_kf.replay import main\n"
                         "def hwm():\n    return [ln for ln in open('/proc/self/status') if ln.startswith('VmHWM')][0]"
                         ".split()[1]\n"
                         "print('imports_kB', hwm(), file=sys.stderr)\ncode = main(sys.argv[1:])\n"
                         "print('VmHWM_kB', hwm(), file=sys.stderr)\nsys.exit(code)")
"""``ins-gps-kf`` in a child that reports its own peak RSS (VmHWM: the child's address space only; a fork's copy of
this process, which the children's getrusage would count, is not)."""


def simulated_odometer(truth, seed: int) -> tuple:
    """(t s, wheel speed m/s): the truth's forward speed at ``ODOMETER_RATE_HZ`` with the scale error and noise."""
    t = np.arange(truth.t[0], truth.t[-1], 1.0 / ODOMETER_RATE_HZ)
    yaw, pitch = (np.interp(t, truth.t, np.unwrap(a)) for a in (truth.yaw, truth.pitch))
    vel = np.column_stack([np.interp(t, truth.t, truth.velocity_n[:, i]) for i in range(3)])
    axis = np.column_stack([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), np.sin(pitch)])
    noise = np.random.default_rng(seed + 1000).normal(0.0, ODOMETER_STD_MPS, len(t))
    return t, (1.0 + ODOMETER_SCALE) * np.sum(vel * axis, axis=1) + noise


def tilted(imu):
    """``imu`` as sensed by an IMU mounted at ``TILT_DEG`` in the car (body' = mount^T body)."""
    mount = frames.mat_nb_from_euler(*np.radians(TILT_DEG))
    out = imu.select(slice(None))
    out.gyro, out.accel = imu.gyro @ mount, imu.accel @ mount
    return out


def forward_and_smoothed(imu, gnss, model, params: dict, odometry=None):
    """(forward estimates, smoothed estimates, filter, forward CPU s, backward CPU s)."""
    filt = InsGpsFilter(config.from_params(params), model)
    filt.recorder = ForwardStore(filt.n_states)
    t0 = time.process_time()
    forward = run(filt, imu, gnss, odometry=odometry if filt.cfg.odometer_enabled else None)
    t1 = time.process_time()
    smoothed = smooth(filt.recorder, forward)
    filt.recorder = None
    return forward, smoothed, filt, t1 - t0, time.process_time() - t1


def errors(est, truth, frame):
    """(t (n,), horizontal error (n,) m, position error (n, 3) m) of ``est`` against ``truth``."""
    t = np.array([e.t for e in est])
    err = np.array([e.position_n for e in est]) - truth_at(truth, frame, t).enu
    return t, np.hypot(err[:, 0], err[:, 1]), err


def largest_errors(t, horiz, windows) -> list[float]:
    """Largest horizontal error (m) of the epochs inside each outage window that has epochs
    (:func:`nav_eval.outages.largest_per_outage`, KF-GINS's score)."""
    with_epochs = [(a, b) for a, b in windows if np.any((t >= a) & (t <= b))]
    return largest_per_outage(HorizontalErrors(t, horiz, np.full(len(t), np.nan)), with_epochs)


def nees(est, err) -> np.ndarray:
    """Position NEES (3 dof) per epoch."""
    return np.array([d @ np.linalg.solve(e.cov[:3, :3], d) for d, e in zip(err, est)])


def run_names(quick: bool, gm_states=(None,)) -> list:
    """(label, params) of every run: the plain filter, then each NHC case with each mounting; then (not --quick) the
    options that bear on the consistency inside the outages: scale-factor states, ZUPT in outages. Each
    ``bias_gm_states_per_axis`` of ``gm_states`` (None: the default) runs them all, labelled unless it is None."""
    mountings = {"estimated": {}} if quick else MOUNTINGS
    out = [("forward", {})]
    for case, extra in list(CASES.items())[1:]:
        out += [(f"{case}, mounting {m}", {**extra, **p}) for m, p in mountings.items()]
    if not quick:
        out += [(f"{case}, {name}", {**extra, **p}) for name, p in OPTIONS.items() for case, extra in CASES.items()
                if case != "NHC + odometer" or "ZUPT" not in name]
    return [(label if n is None else f"{label} [{n} GM]", p if n is None else {**p, "bias_gm_states_per_axis": n})
            for n in gm_states for label, p in out]


def score_outages(sims, shifts, runs, model) -> dict:
    """RMS of the largest horizontal error per outage for every run, forward and smoothed; prints each run."""
    scores, inside_nees = {}, {}
    for seed, sim, imu, odometry in sims:
        for shift in shifts:
            windows = outage_windows(FIRST_S + shift, sim.truth.t[-1], PERIOD_S, OUTAGE_S, FIRST_S + shift)
            gnss = drop_fixes(sim.gnss, windows)
            for label, extra in runs:
                fwd, smo, filt, *_ = forward_and_smoothed(imu, gnss, model, {"imu_rate_hz": sim.rate_hz, **extra},
                                                          odometry)
                for kind, est in (("forward", fwd), ("smoothed", smo)):
                    t, horiz, err = errors(est, sim.truth, filt.frame)
                    errs = largest_errors(t, horiz, windows)
                    scores.setdefault((label, kind), []).extend(errs)
                    inside = np.any([(t >= a) & (t <= b) for a, b in windows], axis=0)
                    inside_nees.setdefault((label, kind), []).append(nees(est, err)[inside])
                    print(f"seed {seed} shift {shift:3.0f} s {kind:<8} {label:<44} largest error per outage (m): "
                          + " ".join(f"{e:6.1f}" for e in errs), flush=True)
                if label != "forward" and filt.nhc.mounting_deg()[0] is not None:
                    print(f"    mounting estimated: pitch {filt.nhc.mounting_deg()[0]:.2f}, yaw "
                          f"{filt.nhc.mounting_deg()[1]:.2f} deg (true {TILT_DEG[1]:g}, {TILT_DEG[2]:g}); "
                          f"NHC rejected {filt.counters.nhc_rejected} of "
                          f"{filt.counters.nhc_rejected + filt.counters.nhc_updates}")
    for (label, kind), values in inside_nees.items():
        n = np.concatenate(values)
        print(f"{kind:<8} {label:<44} position NEES inside the outages: mean {n.mean():.2f} (3), beyond the "
              f"chi-square 99 % point in {100 * np.mean(n > NEES_POINT):.1f} % of {len(n)} epochs (1 %)")
    return {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in scores.items()}, scores


def print_scores(rms: dict, scores: dict, gm_states=(None,)) -> None:
    """The scores and the issue's ratios (to the plain forward filter of the first of ``gm_states``)."""
    tag = [f" [{n} GM]" if n is not None else "" for n in gm_states]
    base = rms[("forward" + tag[0], "forward")]
    for (label, kind), value in rms.items():
        print(f"{kind:<8} {label:<44} RMS of the largest horizontal error per outage: {value:7.2f} m "
              f"({len(scores[(label, kind)])} outages, worst {max(scores[(label, kind)]):6.1f} m; "
              f"{value / base:.3f}x plain forward)")
    for t in tag:
        est = ", mounting estimated" + t
        print(f"forward + NHC{t} / forward: {rms[('NHC' + est, 'forward')] / base:.3f} (target <= 0.4)")
        print(f"forward + NHC + odometer{t} / forward: {rms[('NHC + odometer' + est, 'forward')] / base:.3f} "
              "(target <= 0.1)")
        print(f"smoothed + NHC{t} / forward: {rms[('NHC' + est, 'smoothed')] / base:.3f} (target <= 0.1)")


def throughout(sims, model, gm_states=(None,)) -> None:
    """With GNSS throughout: RMS, NEES, the no-larger share against the optimal smoother's, variances, CPU."""
    cost = {"forward": 0.0, "backward": 0.0}
    for label, extra in run_names(True, gm_states):
        acc = {k: [] for k in ("h_f", "h_s", "nees_f", "nees_s", "no_worse", "expected", "var_up")}
        for seed, sim, imu, odometry in sims:
            fwd, smo, filt, t_f, t_b = forward_and_smoothed(imu, sim.gnss, model,
                                                            {"imu_rate_hz": sim.rate_hz, **extra}, odometry)
            cost["forward"] += t_f
            cost["backward"] += t_b
            _, h_f, err_f = errors(fwd, sim.truth, filt.frame)
            _, h_s, err_s = errors(smo, sim.truth, filt.frame)
            acc["h_f"].append(h_f), acc["h_s"].append(h_s)
            acc["nees_f"].append(nees(fwd, err_f)), acc["nees_s"].append(nees(smo, err_s))
            acc["no_worse"].append(h_s <= h_f)
            acc["expected"].append(no_worse_probability(np.array([e.cov[:2, :2] for e in fwd]),
                                                        np.array([e.cov[:2, :2] for e in smo])))
            var_f, var_s = (np.array([np.diag(e.cov) for e in est]) for est in (fwd, smo))
            acc["var_up"].append(np.any(var_s > var_f * (1 + 1e-9) + 1e-15, axis=1))
        a = {k: np.concatenate(v) for k, v in acc.items()}
        rms_f, rms_s = (float(np.sqrt(np.mean(a[k] ** 2))) for k in ("h_f", "h_s"))
        print(f"GNSS throughout, {label}: horizontal RMS forward {rms_f:.3f} m, smoothed {rms_s:.3f} m: "
              f"{rms_s / rms_f:.3f}x (target <= 0.85)")
        for kind in ("f", "s"):
            n = a[f"nees_{kind}"]
            print(f"    position NEES {'forward ' if kind == 'f' else 'smoothed'}: mean {n.mean():.2f} (3 for a "
                  f"consistent filter), beyond the chi-square 99 % point in {100 * np.mean(n > NEES_POINT):.1f} % "
                  "of epochs (1 %)")
        print(f"    smoothed horizontal error no larger than forward in {100 * a['no_worse'].mean():.1f} % of epochs "
              f"(target 95 %); an optimal smoother with these covariances: {100 * a['expected'].mean():.1f} %; "
              f"epochs with a smoothed variance above the forward one: {int(a['var_up'].sum())} of {len(a['var_up'])}")
    print(f"backward pass CPU {cost['backward']:.2f} s against forward {cost['forward']:.2f} s: "
          f"{cost['backward'] / cost['forward']:.3f}x (target <= 1)")


def long_drive_memory(duration_s: float, gm_states=None) -> None:
    """``ins-gps-kf replay --smooth`` over a ``duration_s`` synthetic drive at 64 Hz in a child: its peak RSS. A
    200-s drive is replayed first, so the numba kernels are compiled and cached (its peak, printed, is what a first
    run after an install or an edit costs) and the figure is the drive's own."""
    with tempfile.TemporaryDirectory(prefix="bench_smooth_") as tmp:
        warm = _replay_smooth_child(Path(tmp) / "warm", 200.0, gm_states)
        peak_mb, import_mb, wall, rows = _replay_smooth_child(Path(tmp) / "long", duration_s, gm_states)
    gm = "" if gm_states is None else f", {gm_states} GM states per bias axis"
    print(f"replay --smooth{gm} over a {duration_s / 3600.0:.2f}-h drive at 64 Hz ({int(duration_s * 64)} IMU samples, "
          f"{rows} smoothed epochs): peak RSS {peak_mb:.0f} MB, {wall:.0f} s wall (target < 300 MB for 2 h; the "
          f"imports alone take {import_mb:.0f} MB: numba, and FilterPy pulling in scipy.stats; the first run over "
          f"{warm[3]} epochs, kernels compiled unless cached: {warm[0]:.0f} MB)")


def _replay_smooth_child(folder: Path, duration_s: float, gm_states=None) -> tuple:
    """(peak RSS MB, RSS after the imports MB, wall s, smoothed epochs) of ``replay --smooth`` in a child process
    over a synthetic circle drive of ``duration_s`` at 64 Hz written as CSV into ``folder``."""
    rate = 64.0
    motion = syn.circle(still_s=60.0, accel_s=10.0, straight_s=10.0, turn_s=duration_s - 80.0, yaw_rate=0.02)
    rng = np.random.default_rng(0)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, rate, oversample=1), rng, 1e-4, 0.01, 1e-3, 2e-3)
    gnss = syn.gnss(motion, rate, 1.0, rng)
    imu_csv = recording.write_imu_csv(folder / "imu.csv", imu)
    gnss_csv = recording.write_gnss_csv(folder / "gnss.csv", gnss)
    del imu, gnss
    t0 = time.time()
    proc = subprocess.run([sys.executable, "-c", REPLAY_REPORTING_PEAK, "replay", "--recording", str(imu_csv),
                           "--gnss", str(gnss_csv), "--model", "default", "--out", str(folder / "traj.csv"),
                           "--quiet", "--no-plot", "--smooth"]
                          + ([] if gm_states is None else ["--param", f"bias_gm_states_per_axis={gm_states}"]),
                          capture_output=True, text=True)
    wall = time.time() - t0
    if proc.returncode != 0:
        raise SystemExit(f"replay --smooth failed: {proc.stderr[-2000:]}")
    peak_mb, import_mb = (int(proc.stderr.split(key)[-1].split()[0]) / 1024.0 for key in ("VmHWM_kB", "imports_kB"))
    rows = sum(1 for _ in open(folder / "traj.csv")) - 1
    return peak_mb, import_mb, wall, rows


def katwijk() -> None:
    """The Katwijk beach rover (real; NaveGo's recording in ../shared/data): forward, NHC (mounting estimated, and
    given as zero) and smoothed, with GNSS throughout and with 30-s outages every 90 s, against the reference."""
    try:
        from nav_eval.datasets import KATWIJK_PARAMS
        from nav_eval.rovers import load_katwijk
    except ImportError as err:
        print(f"Katwijk: skipped ({err})")
        return
    for axes in ("-x_fwd", "x_fwd"):
        try:
            imu, gnss, ref, _ = load_katwijk(axes)
        except (OSError, ValueError) as err:
            print(f"Katwijk: skipped ({err})")
            return
        t_from = float(gnss.t[0]) + 40.0
        windows = outage_windows(t_from, min(gnss.t[-1], ref.t[-1]), 90.0, 30.0, t_from + 20.0)
        for label, extra in (("plain", {}), ("NHC, mounting estimated", {"nhc_enabled": True}),
                             ("NHC, mounting given zero", {"nhc_enabled": True, "nhc_mounting": "given"})):
            row = []
            for gnss_in, inside in ((gnss, False), (drop_fixes(gnss, windows), True)):
                fwd, smo, filt, *_ = forward_and_smoothed(imu, gnss_in, None, {**KATWIJK_PARAMS, **extra})
                for est in (fwd, smo):
                    t, horiz, _ = errors(est, ref, filt.frame)
                    keep = t >= t_from
                    row.append(float(np.max(largest_errors(t, horiz, windows))) if inside else
                               float(np.sqrt(np.mean(horiz[keep] ** 2))))
            mount = filt.nhc.mounting_deg()
            note = f"; mounting pitch {mount[0]:.1f}, yaw {mount[1]:.1f} deg" if mount[0] is not None else ""
            print(f"Katwijk {axes:<6} {label:<25} horizontal RMS with GNSS forward {row[0]:.3f} m, smoothed "
                  f"{row[1]:.3f} m; 30-s outages: worst error forward {row[2]:.2f} m, smoothed {row[3]:.2f} m "
                  f"(NHC applied {filt.counters.nhc_updates}, rejected {filt.counters.nhc_rejected}{note})",
                  flush=True)


def main(argv=None) -> int:
    """Run every seed, shift and case; print the scores."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    p.add_argument("--quick", action="store_true", help="seed 0, no shifted starts, mounting estimated only, a "
                   "10-minute drive for the memory check")
    p.add_argument("--bias-gm-states", type=int, nargs="+", default=None, metavar="N",
                   help="run every case with each bias_gm_states_per_axis N (compared in one run; default: the "
                   "filter's default only); the memory check uses the first")
    p.add_argument("--mounting-estimated-only", action="store_true",
                   help="the NHC cases with the mounting estimated only, no options (the outage NEES comparison)")
    p.add_argument("--no-memory", action="store_true", help="skip the 2-hour replay --smooth memory check")
    p.add_argument("--no-katwijk", action="store_true", help="skip the Katwijk rover")
    args = p.parse_args(argv)
    gm = tuple(args.bias_gm_states) if args.bias_gm_states else (None,)
    # the 2-hour child first: RUSAGE_CHILDREN reports the largest child, and no other child runs before
    if not args.no_memory:
        long_drive_memory(QUICK_DRIVE_S if args.quick else LONG_DRIVE_S, gm[0])
    if args.quick:
        args.seeds = [0]
    model = bp3010_grade_model()
    sims = []
    for seed in args.seeds:
        sim = simulate(str(workspace_file(PAPER_DRIVE)), model=model, seed=seed, with_bytes=False)
        sims.append((seed, sim, tilted(sim.imu), simulated_odometer(sim.truth, seed)))
    print(f"IMU mounted at roll {TILT_DEG[0]:g}, pitch {TILT_DEG[1]:g}, yaw {TILT_DEG[2]:g} deg in the car, not told "
          "to the filter")
    runs = run_names(args.quick or args.mounting_estimated_only, gm)
    rms, scores = score_outages(sims, SHIFTS_S[:1] if args.quick else SHIFTS_S, runs, model)
    print_scores(rms, scores, gm)
    throughout(sims, model, gm)
    if not args.no_katwijk:
        katwijk()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
