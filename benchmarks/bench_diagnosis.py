"""Concealed-effect suite of the sim-versus-real diagnosis: detection, coverage, fit improvement, false alarms.

    .venv/bin/python benchmarks/bench_diagnosis.py [--seeds 20] [--null-seeds 40] [--out /tmp/diag_suite] [--quick]
    .venv/bin/python benchmarks/bench_diagnosis.py --calibrate --null-seeds 100   # rewrite calibration.yaml
    .venv/bin/python benchmarks/bench_diagnosis.py --concealment                  # how hidden each IMU effect is
    (add ``--nulls NAME ... --merge OLD/rows.json`` to run some null cases and reuse earlier uncalibrated rows)

The suite uses the committed threshold factors (``imu_sim/diagnose/calibration.yaml``, floored at 1) and
seeds 1000.. (nulls 3000..); ``--calibrate`` runs the null cases only, uncalibrated, on seeds 5000.. (so the
suite's false-alarm rate is measured on runs the calibration never saw) and writes the factors.
Writes ``rows.json`` (every case) and ``table.md`` (per effect) into ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml
from tqdm import tqdm

from scipy import stats

from imu_sim.diagnose import calibrate
from imu_sim.diagnose.candidate import CALIBRATION_FILE
from imu_sim.diagnose.suite import EFFECT_CASES, GNSS_CASES, NULLS, concealment, run_case, summarise


def table(summary: dict) -> str:
    """Markdown table of the summary."""
    lines = ["| case | runs | right name first | interval coverage | held-out fit before -> after (median) |",
             "|---|---|---|---|---|"]
    for eff, s in summary.items():
        if "false_alarm_rate" in s:
            k, n = round(s["false_alarm_rate"] * s["cases"]), s["cases"]
            hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
            by = f" ({', '.join(s['alarm_effects'])})" if s["alarm_effects"] else ""
            lines.append(f"| {eff} | {n} | false alarms {s['false_alarm_rate']:.1%}{by}, 95 % upper bound "
                         f"{hi:.1%}; kept findings {s['kept_finding_rate']:.1%} | | |")
            continue
        cov = "-" if s["coverage"] is None else f"{s['coverage']:.0%}"
        fit = "-" if s["median_fit_before"] is None else f"{s['median_fit_before']:.3g} -> {s['median_fit_after']:.3g}"
        wrong = f" (else: {', '.join(s['wrong_first'])})" if s["wrong_first"] else ""
        lines.append(f"| {eff} | {s['cases']} | {s['detection_rate']:.0%}{wrong} | {cov} | {fit} |")
    nulls = [s for s in summary.values() if "false_alarm_rate" in s]
    if nulls:
        n = sum(s["cases"] for s in nulls)
        k = round(sum(s["false_alarm_rate"] * s["cases"] for s in nulls))
        hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
        lines.append(f"| all null cases | {n} | false alarms {k / n:.1%} (95 % upper bound {hi:.1%}) | | |")
    return "\n".join(lines)


def concealment_table(effects, seeds) -> str:
    """Markdown table: peak |effect| over per-sample noise std and Allan ratio of each IMU case (max over seeds)."""
    lines = ["| effect | peak / per-sample std | Allan ratio (noise + effect) / noise, max over channels and "
             "tau <= run/10 | at tau | 95 % interval factor of that noise point |", "|---|---|---|---|---|"]
    for eff in tqdm(effects, desc="concealment", file=sys.stderr):
        rows = [concealment(eff, s) for s in seeds]
        worst = max(rows, key=lambda r: r["allan_ratio_max"])
        lines.append(f"| {eff} | {max(r['peak_over_noise'] for r in rows):.2f} | "
                     f"{np.median([r['allan_ratio_max'] for r in rows]):.2f} median, {worst['allan_ratio_max']:.2f} max "
                     f"({worst['allan_channel']}) | {worst['allan_tau_s']:.0f} s | {worst['allan_ci_factor']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeds per effect")
    parser.add_argument("--null-seeds", type=int, default=40, help="seeds per null case")
    parser.add_argument("--out", default="/tmp/diag_suite")
    parser.add_argument("--quick", action="store_true", help="1 seed, 2 effects + the nulls")
    parser.add_argument("--effects", nargs="*", default=None)
    parser.add_argument("--no-nulls", action="store_true", help="skip the null cases (to split a run in two)")
    parser.add_argument("--calibrate", action="store_true",
                        help=f"null cases only, uncalibrated; write {CALIBRATION_FILE.name} from them")
    parser.add_argument("--calibration-out", default=str(CALIBRATION_FILE))
    parser.add_argument("--nulls", nargs="*", default=None, help=f"null cases to run (default all: {NULLS})")
    parser.add_argument("--merge", nargs="*", default=[], help="rows.json of earlier runs to add (calibration)")
    parser.add_argument("--resume", default=None,
                        help="rows.json of an interrupted run of the same code: its (case, seed) rows are reused")
    parser.add_argument("--concealment", action="store_true",
                        help="only print how hidden each IMU case's effect is (seeds 1000..1002)")
    args = parser.parse_args(argv)
    if args.concealment:
        text = concealment_table(args.effects or list(EFFECT_CASES), range(1000, 1003))
        Path(args.out).mkdir(parents=True, exist_ok=True)
        (Path(args.out) / "concealment.md").write_text(text + "\n")
        print(text)
        return 0
    n_eff, n_null = (1, 1) if args.quick else (args.seeds, args.null_seeds)
    effects = [] if args.calibrate else (args.effects or (["scale_factor", "gps_latency"]
                                                          if args.quick else list(EFFECT_CASES) + list(GNSS_CASES)))
    nulls = [] if args.no_nulls else list(NULLS if args.nulls is None else args.nulls)
    # nulls 3000..: fresh seeds (2000.. were seen while choosing the threshold floor; 5000.. calibrated)
    base = 5000 if args.calibrate else 3000
    # null cases first: the false-alarm rate is the figure a cut-short run must not lose
    cases = [(e, base + s) for e in nulls for s in range(n_null)] + [(e, 1000 + s) for e in effects
                                                                     for s in range(n_eff)]
    done = {(r["effect"], r["seed"]): r for r in json.loads(Path(args.resume).read_text())} if args.resume else {}
    factors = {} if args.calibrate else None
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, start = [], time.perf_counter()
    for eff, seed in tqdm(cases, desc="diagnose-suite", file=sys.stderr):
        rows.append(done.get((eff, seed)) or run_case(eff, seed, factors=factors))
        (out / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    text = table(summarise(rows))
    (out / "table.md").write_text(text + "\n")
    print(text)
    if args.calibrate:
        merged = [r for path in args.merge for r in json.loads(Path(path).read_text())]
        result = calibrate.calibrate(rows + merged, NULLS)
        path = calibrate.write(result, Path(args.calibration_out))
        print(yaml.safe_dump(result["factors"]).strip())
        print(f"calibration written to {path}")
    elapsed = time.perf_counter() - start
    print(f"{len(rows)} cases in {elapsed:.0f} s ({elapsed / max(len(rows), 1):.1f} s per case); outputs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
