"""Monte Carlo calibration of the per-effect thresholds on null simulations.

On null cases (nothing missing; a single static orientation) every effect's statistic S is
divided by its analytic threshold T (chi-square / Gumbel quantile at ALPHA / 16 per effect,
grid points Bonferroni-split), u = S / T. The null distribution of u is fitted by moments —
a scaled chi-square a*chi2(nu) for likelihood ratios, a Gumbel for the maximum-type
statistics (periodogram line, lattice) — and the factor is its (1 - ALPHA / 16) quantile,
never below the largest u seen and never below FLOOR = 1. Threshold = T * factor, so each
effect keeps a false-alarm rate of ALPHA / 16 and the family-wise rate stays <= ALPHA
(Bonferroni over the 16 effects).

Why the floor: the analytic threshold already bounds each test's level (a likelihood ratio of
k parameters, some on a boundary such as a variance >= 0, is stochastically below chi-square(k),
and Bonferroni over a profiled grid is conservative), so the Monte Carlo is only trusted to
*raise* a threshold where those asymptotics fail. Lowering one needs the null tail at the
0.3 % level, which 100-300 runs cannot give: the moment-fitted tails came out too light
(factors 0.48-0.80 for the Gauss-Markov, random-walk and warm-up tests) and every false
alarm of the validation runs came from exactly those tests.
"""
from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np
import yaml
from scipy import stats

from nav_core.sensor_model import EFFECTS

from imu_sim.diagnose.candidate import ALPHA, FLOOR

MAX_TYPE = ("vibration", "quantization")
"""Statistics that are maxima over many bins / channels: Gumbel tail rather than chi-square."""
EULER_GAMMA = 0.5772156649


def null_ratios(rows: list, nulls) -> dict:
    """Per effect, the array of S / analytic threshold over the null rows (uncalibrated runs only)."""
    out = {}
    for r in rows:
        if r["effect"] not in nulls or r.get("factors"):
            continue
        for eff, (val, thr) in r["stats"].items():
            if val is not None and thr:
                out.setdefault(eff, []).append(val / thr)
    return {k: np.asarray(v) for k, v in out.items()}


def tail_quantile(u: np.ndarray, effect: str, level: float) -> float:
    """(1 - level) quantile of the moment-fitted null distribution of u."""
    mu, var = float(np.mean(u)), float(np.var(u, ddof=1))
    if var <= 0 or mu <= 0:
        return float(np.max(u))
    if effect in MAX_TYPE:
        beta = np.sqrt(6 * var) / np.pi
        return float(mu - EULER_GAMMA * beta - beta * np.log(-np.log1p(-level)))
    scale, dof = var / (2 * mu), 2 * mu * mu / var
    return float(scale * stats.chi2.isf(level, dof))


def calibrate(rows: list, nulls, alpha: float = ALPHA) -> dict:
    """Factors per effect and what they rest on (a YAML-ready dict)."""
    level = alpha / len(EFFECTS)
    ratios = null_ratios(rows, nulls)
    factors, detail = {}, {}
    for eff, u in sorted(ratios.items()):
        if len(u) < 10 or not np.any(u > 0):
            continue
        q = tail_quantile(u, eff, level)
        factors[eff] = round(max(q, float(np.max(u)), FLOOR), 4)
        detail[eff] = {"null_runs": int(len(u)), "mean_ratio": round(float(np.mean(u)), 4),
                       "max_ratio": round(float(np.max(u)), 4),
                       "fit": "gumbel" if eff in MAX_TYPE else "scaled chi-square",
                       "fitted_quantile": round(q, 4)}
    seeds = sorted({r["seed"] for r in rows if r["effect"] in nulls})
    return {"factors": factors,
            "produced": {"by": "benchmarks/bench_diagnosis.py --calibrate", "date": _dt.date.today().isoformat(),
                         "alpha_familywise": alpha, "per_effect_level": level, "floor": FLOOR, "null_cases": sorted(nulls),
                         "seeds": f"{seeds[0]}..{seeds[-1]}" if seeds else "", "detail": detail}}


def write(result: dict, path: Path) -> Path:
    """Write the calibration YAML (small, committed)."""
    path = Path(path)
    header = ("# Threshold factors of the diagnosis, from the null Monte Carlo (see diagnose/calibrate.py).\n"
              "# Regenerate: .venv/bin/python benchmarks/bench_diagnosis.py --calibrate --null-seeds 100 "
              "(about 20 min, one core)\n")
    path.write_text(header + yaml.safe_dump(result, sort_keys=False))
    return path
