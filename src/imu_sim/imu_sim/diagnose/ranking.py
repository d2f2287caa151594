"""Ranking of the slow-wander candidates, which all put power at the lowest frequencies, by their statistic given
each significant rival."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from imu_sim.diagnose import hold_noise, metrics, mounting, reference, regressors
from imu_sim.diagnose.candidate import Context, add_effect
from imu_sim.diagnose.noise_candidates import noise
from imu_sim.diagnose.spectral import Whitener, gls


LOW_FREQUENCY = ("temperature_bias", "warmup_drift", "gauss_markov_bias", "bias_random_walk")
"""Effects that all show as slow residual wander, so each is ranked by its statistic given its rivals."""


def _low_design(case, model, cand):
    if cand.effect == "temperature_bias":
        return regressors.design_temperature(case, model)
    return regressors.design_warmup(case, model, cand.params["time_constant_s"])


def _conditional_lr(ctx: Context, cand, rival) -> float:
    """Statistic of ``cand`` with ``rival`` already in the model (its fit removed or its noise in the PSD)."""
    case, model, resid, wh, resid_f = ctx.case, ctx.model, ctx.resid, ctx.wh, ctx.resid_f
    if cand.kind == "noise":
        if rival.kind == "noise":  # plus the hold means' evidence, which the tests on holds do not see
            return (noise(replace(ctx, model=add_effect(model, rival)), cand.effect).stat
                    + hold_noise.level_preference(case, model, resid, cand, rival))
        return noise(replace(ctx, resid=resid - rival.contrib), cand.effect).stat
    design = _low_design(case, model, cand)
    if rival.kind == "noise":
        # a random walk's record carries one random end-to-end drift per channel (the common part of its
        # periodogram, the DFT of a ramp), so under the rival's noise a free ramp per channel is a nuisance
        wh2 = Whitener.from_model(add_effect(model, rival), resid, case.dt)
        ramp = (case.t - case.t[0])[:, None] * np.eye(6)[None, 0]
        with_ramp = {c: np.hstack([design.columns.get(c, np.zeros((case.n, design.k))), np.roll(ramp, c, axis=1)])
                     for c in range(6)}
        ramp_only = {c: np.roll(ramp, c, axis=1) for c in range(6)}
        return gls(wh2, resid_f, with_ramp, design.k + 6).lr - gls(wh2, resid_f, ramp_only, 6).lr
    other = _low_design(case, model, rival)
    joint = {c: np.hstack([design.columns.get(c, np.zeros((case.n, design.k))),
                           other.columns.get(c, np.zeros((case.n, other.k)))])
             for c in set(design.columns) | set(other.columns)}
    return gls(wh, resid_f, joint, design.k + other.k).lr - gls(wh, resid_f, other.columns, other.k).lr


def rank_low_frequency(ctx: Context, cands: list) -> None:
    """Rank significant slow-wander candidates by their weakest statistic given one rival, minus threshold.

    A random walk, a Gauss-Markov wander, a temperature-linear bias and a warm-up exponential all
    put power at the lowest frequencies, so their unconditional statistics all rise together;
    the one that still stands once each rival is in the model is the one the data single out.
    """
    sig = [c for c in cands if c.effect in LOW_FREQUENCY and c.significant]
    given = {}
    for cand in sig:
        for rival in sig:
            if rival is not cand:
                given[cand.effect, rival.effect] = _conditional_lr(ctx, cand, rival)
    for cand in sig:
        mine = {r: v for (c, r), v in given.items() if c == cand.effect}
        if not mine:
            continue
        cand.given_rivals = mine
        worst = min(mine, key=mine.get)
        cand.rank = mine[worst] - cand.threshold
        cand.reason = (cand.reason + "; " if cand.reason else "") + (
            f"given {worst}: statistic {mine[worst]:.4g} (ranked by it)")
        thr = {c.effect: c.threshold for c in sig}
        twins = [r for r, v in mine.items() if v <= cand.threshold and given[r, cand.effect] <= thr[r]]
        if twins:
            cand.caveat = (f"This record cannot tell it from {' or '.join(twins)}: each is below its threshold once "
                           "the other is in the model; it is named because it ranks higher, not because the data "
                           "exclude the other.")


def heldout_fraction(before: float, after: float, metric: str) -> float:
    """The fraction (0..1) of the held-out mismatch a finding explains, from its held-out metric (lower is better).

    A normalised RMS (block means over their scatter, distinct-value counts, fix residual) is the square root of a
    chi-square per held-out block: the fraction is the chi-square's drop, 1 - (after / before)^2. A deviance is a
    log-likelihood with an offset of its own (about 1.15 per Whittle bin when the model is right): its relative drop
    (before - after) / before, a lower bound of the fraction, so a noise term never outranks a regression that
    explains as much of the held-out half. A power (a line's periodogram ordinate over its local level) is already
    a chi-square: its relative drop."""
    if not np.isfinite(before) or not np.isfinite(after) or before <= 0 or after >= before:
        return 0.0
    if "deviance" in metric or "power" in metric:
        return float((before - after) / before)
    return float(1.0 - (after / before) ** 2)


def order_by_heldout_evidence(findings: list) -> list:
    """Indices of ``findings`` in ranking order: a known constant matching its value first (zero free parameters),
    then by the fraction of the held-out mismatch each explains (its ``held_out_evidence``), then by share.

    The drop-one share measures energy, not evidence: on a rate table an accelerometer warm-up of 0.1 m/s^2 that
    explained 0.9 % of the held-out mismatch carried more energy than a gyro scale factor that explained 99 %. The
    fraction is not divided by the parameter count (that ranks an effect by how many channels it spans: a gyro and
    accelerometer misalignment's 12 against a temperature's 6); the count is paid in each test's threshold."""
    return sorted(range(len(findings)), key=lambda i: (findings[i].get("free_parameters") != 0,
                                                       -findings[i].get("held_out_evidence", 0.0),
                                                       -findings[i].get("share_of_mismatch", 0.0)))


SLOW_CURVES = ("temperature_bias", "warmup_drift")
"""Deterministic slow curves: on a rate table they must predict the unit's wander, not interpolate it."""


def slow_curve_on_table(case, cand) -> bool:
    """Whether ``cand`` is a slow curve fitted on a rate table (static segments that spin, or a truth file's
    spinning holds), whose held-out fit is :func:`slow_curve_metric`'s."""
    if cand.effect not in SLOW_CURVES or cand.kind != "regression" or not cand.columns:
        return False
    if mounting.table_record(case):
        return True
    return reference.moving_file_truth(case) and any(
        np.max(np.abs(case.gyro_true[a:b])) > 0.01 for a, b in reference.holds(case))


def slow_curve_metric(case, cand, model_before, resid: np.ndarray):
    """(name, before, after) of a slow curve on a rate table: block means of the residual whitened by the model's
    noise (the unit's own stochastic model, as the test weighted it), the curve and each channel's bias fitted on
    the first half of the run and scored on the second. A table run of tens of minutes wanders with the unit's bias
    instability and walk; on tenths interleaved with the fit's own a warm-up or temperature curve follows that
    wander (blind tables: nulls and a scale-factor case with warm-up, temperature findings at held-out gains of
    5-90 %), on a contiguous half it must extrapolate it, which a curve that is the sensor's does and a wander's
    does not."""
    from imu_sim.diagnose.case import CHANNELS
    cols = {c: x for c, x in cand.columns.items() if CHANNELS[c] in cand.channels} or cand.columns
    resid, cols = reference.whitened(case, model_before, resid, cols)
    keep = None if getattr(case, "unstated", None) is None else ~case.unstated
    b, a = metrics.heldout_rms(resid, cols, case.dt, cand.block_s, keep, contiguous=True)
    return (f"RMS of held-out {cand.block_s:.3g}-s block means of the residual whitened by the model's noise over "
            "their scatter (a slow curve on a rate table: fit on the first half of the run, scored on the second)"), b, a
