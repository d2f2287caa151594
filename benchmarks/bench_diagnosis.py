"""Concealed-effect suite of the sim-versus-real diagnosis: detection, coverage, fit improvement, false alarms.

    .venv/bin/python benchmarks/bench_diagnosis.py [--seeds 20] [--out /tmp/diag_suite] [--quick]

Writes ``rows.json`` (every case), ``table.md`` (per effect) and ``null_factors.yaml`` (per-effect
max statistic / threshold on the null cases: the Monte Carlo check of the thresholds).
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

from imu_sim.diagnose.suite import EFFECT_CASES, NULLS, run_case, summarise


def table(summary: dict) -> str:
    """Markdown table of the summary."""
    lines = ["| case | runs | right name first | interval coverage | held-out fit before -> after (median) |",
             "|---|---|---|---|---|"]
    for eff, s in summary.items():
        if "false_alarm_rate" in s:
            lines.append(f"| {eff} | {s['cases']} | false alarms {s['false_alarm_rate']:.0%} | | |")
            continue
        cov = "-" if s["coverage"] is None else f"{s['coverage']:.0%}"
        fit = "-" if s["median_fit_before"] is None else f"{s['median_fit_before']:.3g} -> {s['median_fit_after']:.3g}"
        wrong = f" (else: {', '.join(s['wrong_first'])})" if s["wrong_first"] else ""
        lines.append(f"| {eff} | {s['cases']} | {s['detection_rate']:.0%}{wrong} | {cov} | {fit} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--out", default="/tmp/diag_suite")
    parser.add_argument("--quick", action="store_true", help="2 seeds, 3 effects + nulls")
    parser.add_argument("--effects", nargs="*", default=None)
    parser.add_argument("--no-nulls", action="store_true", help="skip the null cases (to split a run in two)")
    args = parser.parse_args(argv)
    effects = args.effects or (["earth_rotation", "scale_factor", "quantization"] if args.quick
                               else list(EFFECT_CASES))
    seeds = range(2 if args.quick else args.seeds)
    cases = [(e, s) for e in list(effects) + ([] if args.no_nulls else list(NULLS)) for s in seeds]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, start = [], time.perf_counter()
    for eff, seed in tqdm(cases, desc="diagnose-suite", file=sys.stderr):
        rows.append(run_case(eff, 1000 + seed))
        (out / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    summary = summarise(rows)
    text = table(summary)
    (out / "table.md").write_text(text + "\n")
    ratios = {}
    for r in rows:
        if r["effect"] in NULLS:
            for eff, (val, thr) in r["stats"].items():
                if val is not None and thr:
                    ratios.setdefault(eff, []).append(val / thr)
    (out / "null_factors.yaml").write_text(yaml.safe_dump({k: float(np.max(v)) for k, v in ratios.items()}))
    print(text)
    print(f"{len(rows)} cases in {time.perf_counter() - start:.0f} s; outputs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
