"""The diagnosis loop: residual -> test every effect -> fit the strongest -> re-simulate -> repeat.

Each effect of the vocabulary is tested by its own statistic (likelihood ratio, chi-square under
the null; :mod:`effect_tests`, :mod:`noise_candidates`, :mod:`gnss_candidates`); its threshold is the chi-square
quantile at a family-wise level ALPHA shared (Bonferroni) across the effects tested and the grid points profiled,
times a factor calibrated by Monte Carlo on null simulations (``calibration.yaml``, written by
``benchmarks/bench_diagnosis.py --calibrate``, see :mod:`calibrate`). Among significant effects the one with the
largest excess (statistic - threshold, an information-criterion-like penalty per parameter; for the slow-wander
effects, their statistic given the strongest rival, see :mod:`ranking`) is fitted, added to the model, and the
model re-simulated; a finding is kept only if the held-out statistic improves by MIN_GAIN (:mod:`heldout`).
Effects with a motion or physics regressor are fitted before stochastic terms; a known constant that matches its
value is ranked with zero free parameters; a fit outside the sensor grade's bounds is reported as a
``reference_or_model_error``, never as sensor physics (:mod:`plausibility`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core.sensor_model import EFFECTS, SensorModel

from imu_sim.diagnose import collinear, fixture, gnss_candidates, metrics, mounting, plausibility, reference, share
from imu_sim.diagnose.candidate import (ALPHA, EXPLAIN, GNSS_EFFECTS, Candidate, Context, add_effect, evidence,
                                        load_calibration, rounded)
from imu_sim.diagnose.case import CHANNELS, Case, residual
from imu_sim.diagnose.effect_tests import TESTS
from imu_sim.diagnose.heldout import fit_metric
from imu_sim.diagnose.ranking import (SLOW_CURVES, heldout_fraction, order_by_heldout_evidence, rank_low_frequency,
                                      slow_curve_metric, slow_curve_on_table)
from imu_sim.diagnose.spectral import Whitener, noise_psd

__all__ = ["Candidate", "Diagnosis", "diagnose", "evaluate"]
MIN_GAIN = 2e-4
"""Smallest practically meaningful held-out gain, relative to |metric before| (0.02 %): a fit moving from 0.96580
to 0.96579 (1e-5) is not a finding; the independent suite's concealed temperature coefficient gains 0.083 %."""
MIN_DEVIANCE_GAIN = 1e-3
"""Smallest held-out gain of a deviance metric, per held-out block (absolute)."""
SHARE_SCALE = ("findings ordered by evidence (a known constant matching its value first, then held_out_evidence: the "
               "fraction of the held-out mismatch the finding explains, from fit_before and fit_after); "
               "share_of_mismatch is each finding's drop-one contribution in the joint fit "
               "(drop_one_energy: how much the final model's residual energy, over the per-sample noise variance, "
               "grows when that finding alone is removed and the others keep their fitted values; for noise terms "
               "their variance times the samples), over the sum for all findings; mismatch_energy is the finding's "
               "own energy when it was fitted")


def evaluate(case: Case, model: SensorModel, resid: np.ndarray, exclude=(), factors: dict | None = None) -> list:
    """Test every effect of the vocabulary not in ``exclude``; list of :class:`Candidate`.

    ``factors`` scale the analytic thresholds per effect (None: the committed calibration; {}: analytic).
    """
    factors = load_calibration() if factors is None else factors
    resid = reference.clean(case, resid)
    psd = reference.with_reference_error(case, resid, noise_psd(model, np.fft.rfftfreq(case.n, case.dt), case.dt))
    wh = Whitener.from_psd(psd, resid, case.dt)
    wh.unstated = getattr(case, "unstated", None)  # a move between holds carries no reference: no regressor there
    ctx = Context(case, model, resid, wh, np.fft.rfft(resid, axis=0), len(EFFECTS), factors)
    gnss = {c.effect: c for c in gnss_candidates.candidates(case, model, ctx.m_tests, factors, exclude)}
    out = [gnss[effect] if effect in GNSS_EFFECTS else TESTS[effect](ctx) for effect in EFFECTS
           if effect not in exclude]
    for cand in out:
        reference.constant_given_slow_reference(ctx, cand)  # a known regressor, fitted with the truth's slow error
        if cand.effect == "coriolis" and cand.identifiable is False and "constant" in cand.reason:
            # a moving truth file's Coriolis is weak only under the weight of its own slow error (a slow vehicle,
            # a navigation-grade unit): not a static truth (blind drive, 2cf2e33: 'no velocity' on a 1.4-km drive)
            cand.reason = (reference.CORIOLIS_WEAK if reference.moving_file_truth(case)
                           else "the truth has no velocity here (static): Coriolis cannot show")
        if cand.effect in ("gauss_markov_bias", "bias_random_walk", "warmup_drift") and reference.moving_file_truth(case):
            cand.identifiable, cand.reason = False, reference.NOT_SEPARABLE
        if (cand.effect in KNOWN_CONSTANTS and cand.identifiable and cand.constant_se
                and 1.96 * cand.constant_se > SEPARABLE_SCALE and reference.moving_file_truth(case)):
            cand.identifiable = False
            cand.reason = (f"not separable from the reference on this record: weighted by the truth file's own slow "
                           f"error, the constant's scale is determined only to +-{1.96 * cand.constant_se:.2g} "
                           f"(95 %), which cannot tell it from 0; not ranked")
        if cand.effect == "colored_gps_noise" and cand.significant and reference.moving_file_truth(case):
            note = reference.colored_fix_note(cand)
            if note:
                cand.identifiable, cand.reason = False, note
        if note := reference.attitude_note(ctx, cand):
            cand.identifiable, cand.reason = False, (cand.reason + "; " if cand.reason else "") + note
        _rank_known_constant(cand)
    rank_low_frequency(ctx, out)
    fixture.rank_given_tilts(case, out, resid, model)  # the fixture's tilts are a nuisance of every ranking
    for cand in out:  # a hand-mounted table: each mounting's rotation is a nuisance of every tilt-sensitive fit
        mounting.mounting_fit(ctx, cand)
    collinear.note_collinear(case, out, resid, model)  # a warm-up and a temperature: ranked on the holds, noted
    return out


def _rank_known_constant(cand: Candidate) -> None:
    """A known constant (Earth rate, normal gravity, Coriolis) matching its value within the 95 % interval is ranked
    with zero free parameters: its evidence is the likelihood ratio of the constant itself, with no penalty."""
    if cand.constant_scale is None or not cand.constant_se or not cand.significant:
        return
    z = (cand.constant_scale - 1.0) / cand.constant_se
    if abs(z) <= 1.96:
        cand.rank = float(cand.stat - z * z)
        cand.caveat = (f"It matches the known constant within its 95 % interval (scale {cand.constant_scale:.4g} "
                       f"+- {1.96 * cand.constant_se:.2g}): evidence with zero free parameters.")


KNOWN_CONSTANTS = ("earth_rotation", "gravity_model", "coriolis")
SEPARABLE_SCALE = 1.0
"""On a moving truth file, a known constant whose scale's 95 % half-width exceeds this is not separable from the
reference's own error (its interval reaches 0)."""
MOTION_EFFECTS = ("earth_rotation", "gravity_model", "coriolis", "scale_factor", "axis_misalignment",
                  "gyro_g_sensitivity", "gps_latency", "gps_lever_arm")
"""Effects with a motion or physics regressor (the GNSS ones: -v and C_nb): fitted before any stochastic term."""


def _deterministic_first(sig: list) -> Candidate:
    """The candidate to fit next from the significant ones (best evidence first): a significant effect with a motion
    or physics regressor goes before any stochastic term, which only takes what remains once it is fitted (a
    Gauss-Markov bias can mimic the step response of a rate table's scale factor); so does a slow deterministic
    curve (temperature, warm-up) still significant with the stochastic term in the model (blind seed 3: a
    temperature coefficient of 1e-3 m/s^2/degC came third, behind a bias random walk fitted to its curve and an
    accelerometer scale factor fitted to what the walk left on the holds)."""
    if sig[0].kind == "noise" or sig[0].effect == "colored_gps_noise":
        noise = sig[0].effect
        first = [c for c in sig if c.effect in MOTION_EFFECTS or (
            c.effect in SLOW_CURVES and c.kind == "regression" and c.given_rivals.get(noise, -np.inf) > c.threshold)]
        if first:
            what = "a motion regressor" if first[0].effect in MOTION_EFFECTS else (
                f"a regressor of its own, significant given {noise} "
                f"({first[0].given_rivals.get(noise, np.nan):.4g} against {first[0].threshold:.3g})")
            first[0].caveat = " ".join(filter(None, [first[0].caveat, (
                f"Fitted before the stochastic term {noise} (which ranked higher alone): deterministic "
                f"effects come first ({what}).")]))
            return first[0]
    return sig[0]


NOT_SEPARABLE_MARK = "not separable from the reference"
"""What every not-separable note (fixture tilt, moving truth, unstated moves) says."""
BARRED_MARKS = (NOT_SEPARABLE_MARK, "not significant on the holds")
"""Notes that bar a candidate from later passes: not separable, or below threshold on a fixture's holds."""


def _bar_not_separable(cands: list, barred: dict, first_pass: bool) -> None:
    """Record every candidate a pass finds not separable from the reference: it is not tested again in later passes,
    so ``findings`` never holds an effect its ``tested`` entry calls not separable (a warm-up not separable from the
    fixture's tilts in the first pass was fitted in the second, with 96 % of the share). The first pass's own notes
    are in ``tested`` already; a later pass's are added there."""
    for cand in cands:
        if not cand.identifiable and any(m in (cand.reason or "") for m in BARRED_MARKS) and cand.effect not in barred:
            barred[cand.effect] = "" if first_pass else f"in a later pass: {cand.reason}"


def _is_deviance(name: str) -> bool:
    """A deviance is a log-likelihood: its origin depends on the units, so its gain is absolute (per block)."""
    return "deviance" in name


def _gain_ok(before: float, after: float, name: str = "") -> bool:
    """Whether the held-out metric improved by a practically meaningful amount: MIN_GAIN relative, or MIN_GAIN
    per block for a deviance (a log-likelihood ratio per held-out block)."""
    if _is_deviance(name):
        return bool(after < before - MIN_DEVIANCE_GAIN)
    return bool(after < before - MIN_GAIN * max(abs(before), 1e-300))


def _metric_text(name: str, before: float, after: float) -> str:
    """The metric's name with its held-out gain stated."""
    if _is_deviance(name):
        return f"{name}; held-out gain {before - after:.3g} per block (a finding needs >= {MIN_DEVIANCE_GAIN:g})"
    gain = (before - after) / max(abs(before), 1e-300)
    return f"{name}; held-out gain {100 * gain:.3g} % (a finding needs >= {100 * MIN_GAIN:g} %)"


def _model_error(cand: Candidate, broken: list, grade: str, how: str) -> dict:
    """The ``reference_or_model_error`` entry of a significant fit outside the sensor grade's bounds."""
    worst = max(broken, key=lambda b: abs(b["value"]) / b["bound"] if isinstance(b["bound"], float) else np.inf)
    return {"kind": "reference_or_model_error", "effect_tested": cand.effect, "parameter": worst["parameter"],
            "value": worst["value"], "bound": worst["bound"], "grade": grade, "grade_source": how,
            "all_out_of_bounds": broken, "parameters": cand.params, "intervals": cand.intervals,
            "statistic": {"name": cand.statistic, "value": rounded(cand.stat), "threshold": rounded(cand.threshold)},
            "explanation": (f"A {cand.effect} fit of this size is not possible for a "
                            f"{plausibility.grade_text(grade, how)} sensor: the "
                            "reference (fixture attitude, trajectory, site) or the model is wrong, not the sensor.")}


def _refit_without(cand: Candidate, broken: list, grade: str, case=None, resid=None,
                   label: str | None = None) -> Candidate | None:
    """The regression refitted without its out-of-bound or unidentified parameters (the former reported as
    reference_or_model_error), when the rest is still significant and plausible - on a fixture, given the holds'
    tilts again (:func:`fixture.rank_given_tilts`) - ; None otherwise."""
    names = [b["parameter"] for b in broken]
    while True:
        if cand.refit is None or len(names) >= len(cand.params):
            return None
        again = cand.refit(names)
        # a hand-mounted table's refit is the joint fit with its mountings again, which evaluate() also applies after
        # the fixture's tilts: the tilts' joint fit must not overwrite it (own tactical long table 7001: gyro z
        # 6.87e-5 [6.61e-5, 7.14e-5] for 7e-5 in the first pass, 4.05e-5 [3.78e-5, 4.31e-5] after the refit)
        if case is not None and again.significant and getattr(again, "mounting_theta", None) is None:
            fixture.rank_given_tilts(case, [again], resid)
            if again.rank == fixture.IMPLAUSIBLE_RANK:
                return None
        # a parameter the refit moves outside its bound undetermined is dropped too (own long industrial table
        # 7002: without gyro y, gyro x left its bound with an interval of +-0.46, and gyro z at LR 2811 was lost)
        more = [v["parameter"] for v in plausibility.unidentified(again, grade) if v["parameter"] not in names]
        if not more or not again.significant:
            break
        names += more
    if (not again.significant or plausibility.violations(again, grade, again.constant_scale)
            or plausibility.unidentified(again, grade)
            or (case is not None and plausibility.below_reference(again, case))):
        return None
    again.caveat = " ".join(filter(None, [again.caveat, (
        f"Refitted without {', '.join(names)}: outside the {label or grade + '-grade'} bounds (reported under "
        "reference_or_model_error, or not identifiable on this record), not sensor physics.")]))
    return again


def _unidentified_note(vague: list, label: str | None = None) -> str:
    """The ``tested`` note of parameters fitted outside the grade's bounds with intervals wider than the bound."""
    worst = max(vague, key=lambda v: abs(v["value"]) / v["bound"])
    return (f"not identifiable on this record: {', '.join(v['parameter'] for v in vague)} fitted outside the "
            f"{label or worst['grade'] + '-grade'} bound ({worst['parameter']} = {worst['value']:.4g}, 95 % interval "
            f"[{worst['interval'][0]:.3g}, {worst['interval'][1]:.3g}], bound {worst['bound']:g}) without being "
            "determined to it: the fit takes what the record cannot tell from it (on still holds, each hold's "
            "gyro bias change against the Earth rate), not sensor physics")


def _floor_note(small: list) -> str:
    """The ``tested`` note of accelerometer scale factors below what a fixture's reference can tell."""
    values = ", ".join(f"{v['parameter']} = {v['value']:.2g}" for v in small)
    return (f"below what the reference can tell on this record: {values}, within {small[0]['floor']:.2g} (the "
            f"site's gravity known to {plausibility.GRAVITY_ANOMALY:g} of g, each hold's tilt cosine error within "
            "attitude_tolerance_deg): not sensor physics")


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
    grade, grade_how = plausibility.grade_of(case.model)
    label = plausibility.grade_text(grade, grade_how)
    model_errors, rounds, not_separable, unidentified = [], 0, {}, {}
    while rounds < max_effects + 2:
        if len(findings) >= max_effects:
            break
        cands = evaluate(case, model, resid, exclude=accepted | set(not_separable), factors=factors)
        _bar_not_separable(cands, not_separable, first_pass=tested is None)
        if tested is None:
            tested = cands
        if progress is not None:
            progress.update()
        sig = sorted([c for c in cands if c.significant], key=evidence, reverse=True)
        if not sig or len(findings) >= max_effects:
            break
        best = _deterministic_first(sig)
        accepted.add(best.effect)
        clean = reference.clean(case, resid)
        # a hand-mounted table's candidate was fitted with each mounting (mounting.mounting_fit): no second check
        tilt_note = "" if best.mounting_theta is not None else fixture.check(case, best, clean, model)
        if tilt_note:  # the fixture's own tilt (a nuisance) can stand for it: not ranked
            not_separable[best.effect] = tilt_note
            continue
        broken = plausibility.violations(best, grade, best.constant_scale)
        vague = plausibility.unidentified(best, grade)
        floor = plausibility.below_reference(best, case)
        if broken or vague or floor:  # not sensor physics: kept out of the model, and it does not use up a round
            if broken:
                model_errors.append(_model_error(best, broken, grade, grade_how))
            if vague or floor:
                unidentified[best.effect] = "; ".join(filter(None, [vague and _unidentified_note(vague, label),
                                                                    floor and _floor_note(floor)]))
            best = _refit_without(best, broken + vague + floor, grade, case, clean, label)
            if best is None:
                continue
        rounds += 1
        new_model = add_effect(model, best)
        held = mounting.without_mountings(case, best, clean)  # a table's mountings: nuisance
        name, before, after = (slow_curve_metric(case, best, model, held) if slow_curve_on_table(case, best)
                               else fit_metric(case, best, model, new_model, held, seed))
        new_resid = residual(case, new_model)
        # a held-out gain below MIN_GAIN (or one at the metric's rounding: 0 -> 0) is not a finding
        if not _gain_ok(before, after, name):
            best.reason = (f"significant but no practically meaningful held-out improvement ({before:.6g} -> "
                           f"{after:.6g}, below {100 * MIN_GAIN:g} %); not kept")
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
            "metric": _metric_text(name, before, after), "fit_before": before, "fit_after": after,
            "held_out_evidence": round(heldout_fraction(before, after, name), 6),
            "free_parameters": 0 if best.rank is not None and best.constant_scale is not None else len(best.params),
            "evidence": rounded(evidence(best)),
            "statistic": {"name": best.statistic, "value": rounded(best.stat), "threshold": rounded(best.threshold)},
            "explanation": " ".join(filter(None, [EXPLAIN.get(best.effect, best.effect), best.caveat])),
            "mismatch_energy": rounded(share.energy(case, best, model, clean))})
        details.append((best, resid, new_resid))
        model, resid = new_model, new_resid
    drops = share.drop_one(case, model, case.model, findings, [d[0] for d in details])
    for f, e in zip(findings, drops):
        f["drop_one_energy"] = rounded(e)
    _rank_by_share(findings, details)
    tested_out = [c.tested_entry() for c in tested]
    for entry in tested_out:
        if entry["effect"] in not_separable:
            if not_separable[entry["effect"]]:
                entry["note"] = (entry["note"] + "; " if entry["note"] else "") + not_separable[entry["effect"]]
            continue
        if entry["effect"] in unidentified:
            entry["note"] = (entry["note"] + "; " if entry["note"] else "") + unidentified[entry["effect"]] + (
                "; the effect's other parameters refitted without them and kept"
                if entry["effect"] in [f["effect"] for f in findings] else "")
        flagged = [e for e in model_errors if e["effect_tested"] == entry["effect"]]
        if flagged:
            entry["note"] = (entry["note"] + "; " if entry["note"] else "") + (
                f"fit outside the {label} bounds ({flagged[0]['parameter']} = {flagged[0]['value']:.4g}, "
                f"bound {flagged[0]['bound']}): reported as reference_or_model_error, not as sensor physics" + (
                    "; the effect's other parameters refitted without it and kept"
                    if entry["effect"] in [f["effect"] for f in findings] else ""))
        if (entry["effect"] in accepted and entry["effect"] not in [f["effect"] for f in findings] and not flagged
                and entry["effect"] not in unidentified):
            entry["note"] = (entry["note"] + "; " if entry["note"] else "") + (
                "not kept (no practically meaningful held-out improvement)")
    result = {"mismatch": bool(findings), "findings": findings, "tested": tested_out,
              "channels": list(CHANNELS), "samples": case.n, "rate_hz": 1.0 / case.dt, "notes": case.notes,
              "alpha_familywise": ALPHA,
              "calibration": factors or "uncalibrated (chi-square, Bonferroni)",
              "n_significant_first_pass": int(sum(c.significant for c in tested)),
              "share_scale": SHARE_SCALE,
              "sensor_grade": {"grade": grade, "source": grade_how, "bounds": plausibility.BOUNDS[grade]},
              "reference_or_model_error": model_errors}
    return Diagnosis(result, model, case, resid0, resid, details)


def _rank_by_share(findings: list, details: list) -> None:
    """Write each finding's share of the mismatch (its drop-one contribution) and order findings (and their details)
    by evidence: a known constant matching its value first, then by the fraction of the held-out mismatch each
    explains (:func:`ranking.order_by_heldout_evidence`), the share breaking ties."""
    for f, sh in zip(findings, share.shares([f.get("drop_one_energy", f["mismatch_energy"]) or 0.0
                                             for f in findings])):
        f["share_of_mismatch"] = round(sh, 4)
    order = order_by_heldout_evidence(findings)
    findings[:] = [findings[i] for i in order]
    details[:] = [details[i] for i in order]


def _band(case, resid, new_resid, cand) -> dict:
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    band, _, _ = metrics.allan_band(resid[:, chans], new_resid[:, chans], 1.0 / case.dt)
    return band
