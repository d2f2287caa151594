"""The diagnosis loop: residual -> test every effect -> fit the strongest -> re-simulate -> repeat.

Each effect of the vocabulary is tested by its own statistic (likelihood ratio, chi-square under
the null; :mod:`effect_tests`, :mod:`noise_candidates`, :mod:`gnss_candidates`); its threshold is the chi-square
quantile at a family-wise level ALPHA shared (Bonferroni) across the effects tested and the grid points profiled,
times a factor calibrated by Monte Carlo on null simulations (``calibration.yaml``, written by
``benchmarks/bench_diagnosis.py --calibrate``, see :mod:`calibrate`). Among significant effects the one with the
largest excess (statistic - threshold, an information-criterion-like penalty per parameter; for the slow-wander
effects, their statistic given the strongest rival, see :mod:`ranking`) is fitted, added to the model, and the
model re-simulated; a finding is kept only if the held-out statistic improves (:mod:`heldout`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core.sensor_model import EFFECTS, SensorModel

from imu_sim.diagnose import gnss_candidates, metrics, reference, share
from imu_sim.diagnose.candidate import (ALPHA, EXPLAIN, GNSS_EFFECTS, Candidate, Context, add_effect, evidence,
                                        load_calibration, rounded)
from imu_sim.diagnose.case import CHANNELS, Case, residual
from imu_sim.diagnose.effect_tests import TESTS
from imu_sim.diagnose.heldout import fit_metric
from imu_sim.diagnose.ranking import rank_low_frequency
from imu_sim.diagnose.spectral import Whitener

__all__ = ["Candidate", "Diagnosis", "diagnose", "evaluate"]
GAIN_TOL = 1e-9
"""Smallest relative held-out gain that counts (below it the metric did not move)."""
SHARE_SCALE = ("findings ordered by share_of_mismatch: each finding's energy in the residual over the per-sample "
               "noise variance (sum of contrib^2 / sigma^2 over samples and channels; for noise terms their "
               "variance times the samples), over the sum for all findings")


def evaluate(case: Case, model: SensorModel, resid: np.ndarray, exclude=(), factors: dict | None = None) -> list:
    """Test every effect of the vocabulary not in ``exclude``; list of :class:`Candidate`.

    ``factors`` scale the analytic thresholds per effect (None: the committed calibration; {}: analytic).
    """
    factors = load_calibration() if factors is None else factors
    resid = reference.clean(case, resid)
    ctx = Context(case, model, resid, Whitener.from_model(model, resid, case.dt), np.fft.rfft(resid, axis=0),
                  len(EFFECTS), factors)
    gnss = {c.effect: c for c in gnss_candidates.candidates(case, model, ctx.m_tests, factors, exclude)}
    out = [gnss[effect] if effect in GNSS_EFFECTS else TESTS[effect](ctx) for effect in EFFECTS
           if effect not in exclude]
    for cand in out:
        if cand.effect == "coriolis" and cand.identifiable is False and "constant" in cand.reason:
            cand.reason = "the truth has no velocity here (static): Coriolis cannot show"
    rank_low_frequency(ctx, out)
    return out


@dataclass
class Diagnosis:
    """The result: JSON-ready dict plus arrays for the report."""

    result: dict
    model_updated: SensorModel
    case: Case
    resid_before: np.ndarray
    resid_after: np.ndarray
    findings_detail: list


def diagnose(case: Case, max_effects: int = 4, seed: int = 0, progress=None, factors: dict | None = None) -> Diagnosis:
    """Locate, attribute, model and iterate (see module docstring); ``factors`` as in :func:`evaluate`."""
    factors = load_calibration() if factors is None else factors
    model = case.model.copy()
    resid0 = residual(case, model)
    resid = resid0
    findings, details, tested, accepted = [], [], None, set()
    for _ in range(max_effects + 2):
        if len(findings) >= max_effects:
            break
        cands = evaluate(case, model, resid, exclude=accepted, factors=factors)
        if tested is None:
            tested = cands
        if progress is not None:
            progress.update()
        sig = sorted([c for c in cands if c.significant], key=evidence, reverse=True)
        if not sig or len(findings) >= max_effects:
            break
        best = sig[0]
        accepted.add(best.effect)
        new_model = add_effect(model, best)
        name, before, after = fit_metric(case, best, model, new_model, reference.clean(case, resid), seed)
        new_resid = residual(case, new_model)
        # no held-out gain, or one at the metric's rounding (a format artifact: 0 -> 0), is not a finding
        if not after < before - GAIN_TOL * max(abs(before), 1e-300):
            best.reason = f"significant but no held-out improvement ({before:.4g} -> {after:.4g}); not kept"
            continue
        if best.kind == "gnss":
            span, band = gnss_candidates.location(case, best, model)
            best.channels = best.channels or list(gnss_candidates.gt.CHANNELS)
        else:
            band = best.band or _band(case, resid, new_resid, best)
            contrib = best.contrib if best.contrib is not None else resid - new_resid
            span = (metrics.time_span(resid, contrib, case.t) if best.kind != "quantization"
                    else [0.0, float(case.t[-1])])
        findings.append({
            "effect": best.effect, "channels": best.channels or list(CHANNELS),
            "time_span_s": span,
            "band": band, "parameters": best.params, "intervals": best.intervals,
            "metric": name, "fit_before": before, "fit_after": after,
            "statistic": {"name": best.statistic, "value": rounded(best.stat), "threshold": rounded(best.threshold)},
            "explanation": " ".join(filter(None, [EXPLAIN.get(best.effect, best.effect), best.caveat])),
            "mismatch_energy": rounded(share.energy(case, best, model, reference.clean(case, resid)))})
        details.append((best, resid, new_resid))
        model, resid = new_model, new_resid
    _rank_by_share(findings, details)
    tested_out = [c.tested_entry() for c in tested]
    for entry in tested_out:
        if entry["effect"] in accepted and entry["effect"] not in [f["effect"] for f in findings]:
            entry["note"] = (entry["note"] + "; " if entry["note"] else "") + "not kept (no held-out improvement)"
    result = {"mismatch": bool(findings), "findings": findings, "tested": tested_out,
              "channels": list(CHANNELS), "samples": case.n, "rate_hz": 1.0 / case.dt, "notes": case.notes,
              "alpha_familywise": ALPHA,
              "calibration": factors or "uncalibrated (chi-square, Bonferroni)",
              "n_significant_first_pass": int(sum(c.significant for c in tested)),
              "share_scale": SHARE_SCALE}
    return Diagnosis(result, model, case, resid0, resid, details)


def _rank_by_share(findings: list, details: list) -> None:
    """Order findings (and their details) by their share of the mismatch, largest first; write the share."""
    for f, sh in zip(findings, share.shares([f["mismatch_energy"] or 0.0 for f in findings])):
        f["share_of_mismatch"] = round(sh, 4)
    order = sorted(range(len(findings)), key=lambda i: -findings[i]["share_of_mismatch"])
    findings[:] = [findings[i] for i in order]
    details[:] = [details[i] for i in order]


def _band(case, resid, new_resid, cand) -> dict:
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    band, _, _ = metrics.allan_band(resid[:, chans], new_resid[:, chans], 1.0 / case.dt)
    return band
