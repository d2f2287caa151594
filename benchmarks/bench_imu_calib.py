"""Benchmark of imu_calib: Allan deviation speed and memory, fit time, parameter accuracy.

Usage: python benchmarks/bench_imu_calib.py [--quick] [--samples N] [--seeds S] [--only speed|accuracy|reported]
       [--reported-rate HZ] [--repeats R]
       (issue 14's case at HZ: 1 Hz holds the same information on K as 100 Hz, so --only reported
       --reported-rate 1 --seeds 100 checks the bound on 300 axes in about a minute; R alternating timings
       of ours and allantools in the speed part, default 3)

Peers measured in the same run on the same data: ``allantools.oadev`` (same
estimator, same octave grid) and a brute-force non-overlapping Allan variance
that loops over clusters in Python, as the ROS allan_variance tools do in C++;
the brute force runs on a prefix and is scaled linearly (its cost is O(n) per
cluster time), and says so. Accuracy: this project's Allan-variance fit and its
Whittle likelihood refinement against the classic IEEE slope readings and the
Cramer-Rao bound, on synthetic 2 h records with known N, B, K; and issue 14's
case (2 h, white noise and a random walk rising 2.6-3.5x above the white line
at 800 s): how often K is identified, its error, interval coverage. Every
accuracy row shows, per term: the spread over seeds (relative sd, median and
max |error|, median bias), the Cramer-Rao sd from the exact likelihood's Fisher
information (imu_calib.whittle), the efficiency (bound^2 / measured variance),
and the fraction within the target against what an efficient unbiased
estimator would reach; efficiency = bound^2 / mean squared relative error (so
a bias counts against it); the known-model exact ML row is the Monte-Carlo check
of the bound.
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import allantools
import numpy as np
from scipy import stats

from imu_calib import synthetic
from imu_calib.allan import nonoverlapping_adev, octave_taus, overlapping_adev
from imu_calib.noise_fit import fit_noise
from imu_calib.whittle import WhittleProblem, cramer_rao_relative_sd

RATE_HZ = 100.0
CASES = {"separated (tests)": synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.2e-4),
         "K target case (tests)": synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.8e-4)}


def _data(n: int, rng) -> np.ndarray:
    """Six axes of white noise plus rate random walk (cheap to make at 10 M samples)."""
    x = rng.standard_normal((n, 6)) * 1e-2
    x += np.cumsum(rng.standard_normal((n, 6)), axis=0) * 1e-6
    return x


def _brute_nonoverlapping(x: np.ndarray, ms) -> np.ndarray:
    """Cluster-by-cluster non-overlapping Allan variance with a Python loop (the ROS tools' method)."""
    out = []
    for m in ms:
        means = [x[k * m:(k + 1) * m].mean() for k in range(len(x) // m)]
        out.append(0.5 * np.mean(np.diff(means) ** 2))
    return np.array(out)


def bench_speed(n: int, brute_n: int, repeats: int = 3) -> None:
    """Allan deviation of n x 6 samples: ours vs allantools vs brute force; peak memory of ours.

    Ours and allantools alternate ``repeats`` times in the same run, so both see the same load; the ratio
    is given for the best and for the median time of each.
    """
    x = _data(n, np.random.default_rng(0))
    taus = octave_taus(n, RATE_HZ)
    t0 = time.perf_counter()
    overlapping_adev(x[:1000], RATE_HZ)  # JIT compile (cached on disk after the first run)
    compile_s = time.perf_counter() - t0

    ours_s, at_s = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        ours = overlapping_adev(x, RATE_HZ, taus)
        ours_s.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        ref = [allantools.oadev(x[:, i], rate=RATE_HZ, data_type="freq", taus=taus)[1] for i in range(6)]
        at_s.append(time.perf_counter() - t0)
    agree = np.max(np.abs(np.column_stack(ref) / ours.adev - 1))

    t0 = time.perf_counter()
    nonoverlapping_adev(x, RATE_HZ, taus)
    nov_s = time.perf_counter() - t0

    prefix = x[:brute_n]
    ms = np.round(octave_taus(brute_n, RATE_HZ) * RATE_HZ).astype(int)
    t0 = time.perf_counter()
    for i in range(6):
        _brute_nonoverlapping(prefix[:, i], ms)
    brute_s = (time.perf_counter() - t0) * n / brute_n

    tracemalloc.start()
    overlapping_adev(x, RATE_HZ, taus)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    print(f"Allan deviation, {n:,} samples x 6 axes, octave grid ({len(taus)} cluster times), {RATE_HZ:g} Hz")
    best, median = (min(ours_s), min(at_s)), (float(np.median(ours_s)), float(np.median(at_s)))
    print(f"  imu_calib overlapping_adev      {best[0]:8.2f} s   best of {repeats} (median {median[0]:.2f} s; "
          f"JIT compile/load once: {compile_s:.2f} s)")
    print(f"  allantools.oadev (same data)    {best[1]:8.2f} s   best of {repeats} (median {median[1]:.2f} s), "
          f"the two alternating")
    print(f"  -> imu_calib is {best[1] / best[0]:.1f}x faster on the best times, {median[1] / median[0]:.1f}x on "
          f"the medians (target >= 3x); max relative difference {agree:.1e}")
    print(f"  imu_calib non-overlapping 8-9   {nov_s:8.2f} s")
    print(f"  brute-force non-overlapping     {brute_s:8.2f} s   (Python loop per cluster, timed on "
          f"{brute_n:,} samples and scaled by {n / brute_n:.0f})")
    print(f"  peak traced memory of overlapping_adev: {peak / 2**20:.1f} MiB = {peak / x.nbytes:.2f} x the input "
          f"({x.nbytes / 2**20:.1f} MiB; target < 3x)")


def efficiency_line(label: str, ratios, crb_sd: float, covered=None, width: float = 0.25) -> str:
    """One row: estimates / truth of one term over seeds (NaN = not identified) against its Cramer-Rao sd."""
    r = np.asarray(ratios, dtype=float)
    ok = r[np.isfinite(r)]
    e = np.abs(ok - 1)
    sd = ok.std(ddof=1) if len(ok) > 1 else np.nan
    rms = np.sqrt(np.mean((ok - 1) ** 2)) if len(ok) else np.nan
    efficient = 2 * stats.norm.cdf(width / crb_sd) - 1
    cover = f", covers {np.sum(covered)}/{len(r)}" if covered is not None else ""
    return (f"  {label:34s} id {len(ok):3d}/{len(r)}  rel sd {sd:6.1%}  median |err| {np.median(e):6.1%}  "
            f"max {e.max():6.1%}  rms {rms:6.1%}  bias (median) {np.median(ok) - 1:+6.1%}  CRB sd {crb_sd:6.1%}  "
            f"efficiency {crb_sd ** 2 / rms ** 2:4.2f}  within {width:.0%} {np.sum(e < width):3d}/{len(r)} "
            f"({np.sum(e < width) / len(r):4.0%}; efficient unbiased {efficient:4.0%}){cover}")


def _oracle_ratios(x, rate: float, truth, terms) -> np.ndarray:
    """Exact-likelihood ML of the true terms (known model): the Monte-Carlo check of the Cramer-Rao bound."""
    values = np.array([getattr(truth, t) for t in terms])
    fit = WhittleProblem(x, rate, truth.tau_c).fit(terms, values ** 2 * 1.3)
    return np.sqrt(fit.theta) / values if fit.converged else np.full(len(terms), np.nan)


def bench_fit_and_accuracy(seeds: int) -> None:
    """Fit time and accuracy on 2 h synthetic records at 20 Hz: pipeline (Allan + likelihood), the known-model
    ML, Allan WLS alone, IEEE readings; each against the Cramer-Rao bound."""
    rate, n = 20.0, int(2 * 3600 * 20.0)
    for name, truth in CASES.items():
        ratios = {k: {t: [] for t in "NBK"} for k in ("pipeline", "oracle", "avar", "slope")}
        fit_s = {"avar": [], "pipeline": []}
        for seed in range(seeds):
            x = synthetic.noise(n, rate, truth, np.random.default_rng(seed))
            adev = overlapping_adev(x, rate)
            t0 = time.perf_counter()
            avar_fit = fit_noise(adev)
            t1 = time.perf_counter()
            fit = fit_noise(adev, samples=x)
            fit_s["avar"].append(t1 - t0)
            fit_s["pipeline"].append(time.perf_counter() - t1)
            oracle = _oracle_ratios(x, rate, truth, "NBK")
            for i, t in enumerate("NBK"):
                value = getattr(truth, t)
                ratios["pipeline"][t].append(fit.values[t] / value if fit.identifiable(t) else np.nan)
                ratios["avar"][t].append(avar_fit.values[t] / value if avar_fit.identifiable(t) else np.nan)
                ratios["slope"][t].append(fit.slope_readings[t] / value)
                ratios["oracle"][t].append(oracle[i])
        bound = cramer_rao_relative_sd(n, rate, "NBK", [truth.N, truth.B, truth.K])
        print(f"Parameter accuracy, {name}: 2 h at {rate:g} Hz, N={truth.N} B={truth.B} K={truth.K} (SI), "
              f"{seeds} seeds; fit time per axis: Allan WLS {np.mean(fit_s['avar']) * 1e3:.0f} ms, "
              f"pipeline (Allan + likelihood) {np.mean(fit_s['pipeline']) * 1e3:.0f} ms")
        for t, sd in zip("NBK", bound):
            for k, label in (("pipeline", "pipeline"), ("oracle", "known-model exact ML"),
                             ("avar", "Allan WLS alone"), ("slope", "IEEE slope reading")):
                print(efficiency_line(f"{t} {label}", ratios[k][t], sd, width=0.15))


REPORTED_N = (2.9e-4, 3.5e-4, 4.1e-4)
REPORTED_K = (1.5e-6, 2.2e-6, 3.0e-6)
"""Issue 14's record: 2 h of gyro white noise and rate random walk per axis (the old fit returned K = 0)."""


def bench_reported_case(seeds: int, rate: float) -> None:
    """Issue 14's case against the Cramer-Rao bound per axis: the pipeline (Allan + likelihood), the known-model
    exact ML (the bound's Monte-Carlo check), the Allan deviation alone; fit time; speed vs allantools."""
    n = int(2 * 3600 * rate)
    print(f"Issue 14 case: 2 h at {rate:g} Hz, N = {REPORTED_N}, K = {REPORTED_K} (per axis, SI), {seeds} seeds, "
          f"the three axes of a seed independent")
    bound = [cramer_rao_relative_sd(n, rate, "NK", (nn, k)) for nn, k in zip(REPORTED_N, REPORTED_K)]
    rows = ("pipeline", "known-model exact ML", "Allan deviation alone")
    ratios = {r: np.full((seeds, 3, 2), np.nan) for r in rows}
    covered = {r: np.zeros((seeds, 3), bool) for r in rows}
    times = {"adev": [], "pipeline": [], "Allan deviation alone": []}
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        for axis, (nn, k) in enumerate(zip(REPORTED_N, REPORTED_K)):
            x = synthetic.noise(n, rate, synthetic.NoiseTerms(N=nn, K=k), rng)
            t0 = time.perf_counter()
            adev = overlapping_adev(x, rate)
            times["adev"].append(time.perf_counter() - t0)
            for label, samples in (("pipeline", x), ("Allan deviation alone", None)):
                t0 = time.perf_counter()
                fit = fit_noise(adev, samples=samples)
                times[label].append(time.perf_counter() - t0)
                for j, (term, value) in enumerate((("N", nn), ("K", k))):
                    ratios[label][seed, axis, j] = fit.values[term] / value if fit.identifiable(term) else np.nan
                lo, hi = fit.intervals["K"]
                covered[label][seed, axis] = lo <= k <= hi
            fit = WhittleProblem(x, rate).fit("NK", [nn ** 2 * 1.3, k ** 2 * 1.3])
            ratios["known-model exact ML"][seed, axis] = np.sqrt(fit.theta) / (nn, k)
            sd = np.sqrt(np.diag(fit.cov)) / fit.theta
            covered["known-model exact ML"][seed, axis] = abs(np.log(k ** 2 / fit.theta[1])) < 1.96 * sd[1]
    for j, term in enumerate("NK"):
        print(f" {term}: per axis ({', '.join(f'{b[j]:.2%}' for b in bound)} Cramer-Rao sd)")
        for axis in range(3):
            for label in rows:
                print(efficiency_line(f"axis {axis} {label}", ratios[label][:, axis, j], bound[axis][j],
                                      covered[label][:, axis] if term == "K" else None))
        pooled_bound = float(np.sqrt(np.mean([b[j] ** 2 for b in bound])))
        for label in rows:
            print(efficiency_line(f"all axes {label}", ratios[label][:, :, j].ravel(), pooled_bound,
                                  covered[label].ravel() if term == "K" else None))
    print(f"  (all-axes rows use the rms of the three bounds, {pooled_bound:.1%})")
    print(f"  time per axis of {n:,} samples: Allan deviation {np.mean(times['adev']):.2f} s, Allan fit alone "
          f"{np.mean(times['Allan deviation alone']):.2f} s, pipeline fit {np.mean(times['pipeline']):.2f} s")
    x = synthetic.noise(n, rate, synthetic.NoiseTerms(N=REPORTED_N[0], K=REPORTED_K[0]), np.random.default_rng(0))
    taus = octave_taus(n, rate)
    t0 = time.perf_counter()
    ours = overlapping_adev(x, rate, taus)
    ours_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref = allantools.oadev(x, rate=rate, data_type="freq", taus=taus)[1]
    at_s = time.perf_counter() - t0
    print(f"  same record, one axis: imu_calib overlapping_adev {ours_s:.3f} s, allantools.oadev {at_s:.3f} s -> "
          f"{at_s / ours_s:.1f}x faster, max relative difference {np.max(np.abs(ref / ours.adev - 1)):.1e}")


def main(argv=None) -> None:
    """Run the benchmark (``--quick``: a few seconds)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="reduced size, a few seconds")
    parser.add_argument("--samples", type=int, default=10_000_000, help="samples per axis (default 10 M)")
    parser.add_argument("--seeds", type=int, default=40, help="seeds per accuracy case (default 40)")
    parser.add_argument("--reported-rate", type=float, default=100.0,
                        help="sample rate of the issue-14 case, Hz (default 100, as reported)")
    parser.add_argument("--only", choices=("speed", "accuracy", "reported"), help="run one part")
    parser.add_argument("--repeats", type=int, default=3,
                        help="alternating timings of ours and allantools in the speed part (default 3)")
    args = parser.parse_args(argv)
    n = 200_000 if args.quick else args.samples
    if args.only in (None, "speed"):
        bench_speed(n, brute_n=min(n, 5_000 if args.quick else 50_000), repeats=max(1, args.repeats))
    if args.only in (None, "accuracy"):
        bench_fit_and_accuracy(2 if args.quick else args.seeds)
    if args.only in (None, "reported"):
        bench_reported_case(2 if args.quick else args.seeds, 10.0 if args.quick else args.reported_rate)


if __name__ == "__main__":
    main()
