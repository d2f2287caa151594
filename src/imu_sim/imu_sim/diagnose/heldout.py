"""Held-out fit of a finding (lower is better): the engine keeps a finding only when this improves.

Regressions: RMS of held-out block means over their scatter (odd tenths, fit on even tenths, see
:func:`metrics.heldout_rms`); a vibration line: the held-out second half's periodogram power at the line over its
local level, before and after removing the line fitted on the first half (:func:`line_metric`); quantization:
distinct-value counts of the second half; noise terms: one-step
prediction deviance of the second half's block means (or the Whittle deviance where the filter cannot hold the
model's noise); GNSS effects: :func:`gnss_candidates.fit_metric`.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from nav_core.sensor_model import SensorModel

from imu_sim.diagnose import fixture, gnss_candidates, local_level, metrics, noise_tests, reference
from imu_sim.diagnose.candidate import Candidate, Context, add_effect
from imu_sim.diagnose.case import CHANNELS, Case, deterministic
from imu_sim.diagnose.noise_candidates import noise
from imu_sim.diagnose.spectral import noise_psd


def fit_metric(case: Case, cand: Candidate, model_before: SensorModel, model_after: SensorModel,
               resid: np.ndarray, seed: int = 0):
    """(metric name, before, after) on held-out data. A known constant (Earth rate, normal gravity, Coriolis) is
    added to the model at its value whatever its fitted scale, so it is scored at that value, not trained."""
    if cand.kind == "gnss":
        return gnss_candidates.fit_metric(case, cand, model_before, model_after)
    if cand.kind == "vibration":
        return line_metric(case, cand, resid)
    if cand.kind == "regression":
        cols = {c: x for c, x in cand.columns.items() if CHANNELS[c] in cand.channels} or cand.columns
        what = f"{cand.block_s:.3g}-s block means"
        keep = None
        if reference.moving_file_truth(case):
            resid, cols = reference.whitened(case, model_before, resid, cols)
            what += " of the residual whitened by the model's noise plus the reference's error"
        elif cand.kind == "regression" and (held := fixture.without_tilts(case, cols, resid)) is not None:
            resid, keep = held
            what += " on the fixture's holds, each hold's tilt (within attitude_tolerance_deg) fitted with it"
        elif cand.kind == "regression" and _coloured(case, model_before):
            # weighted as the test was: a flicker bias instability's wander of the held-out half otherwise moved
            # the block means more than a fitted 30-min temperature wave (1.0321 -> 1.0327 at LR 87, not kept)
            resid, cols = reference.whitened(case, model_before, resid, cols)
            what += " of the residual whitened by the model's noise"
        if keep is None and getattr(case, "unstated", None) is not None:
            keep = ~case.unstated  # a move between holds has no reference: scored on the stated samples only
        b, a = metrics.heldout_rms(resid, cols, case.dt, cand.block_s, keep,
                                   fixed=[1.0] if cand.constant_scale is not None else None)
        return f"RMS of held-out {what} over their scatter (odd tenths of the run, fit on even tenths)", b, a
    if cand.kind == "quantization":
        half = case.n // 2
        real = case.measured[half:]
        vals = []
        for mdl in (model_before, model_after):
            sim = deterministic(case, mdl, stochastic=True, seed=seed + 1)[half:]
            ratio = [np.log10(len(np.unique(real[:, c])) / len(np.unique(sim[:, c])))
                     for c in range(6) if CHANNELS[c] in cand.channels]
            vals.append(float(np.sqrt(np.mean(np.square(ratio)))))
        return "RMS log10 ratio of distinct-value counts, real vs simulated (second half held out)", vals[0], vals[1]
    held = _filter_metric(case, cand, model_before, resid)
    if held is not None:
        return held
    return _whittle_metric(case, cand, model_before, resid)


LINE_GUARD_BINS, LINE_LOCAL_BINS = 3, 60
"""The line's own bins (either side of it) and the band either side whose median periodogram ordinate is the local
noise level the line's power is measured against."""


def line_metric(case: Case, cand: Candidate, resid: np.ndarray):
    """(name, before, after): the held-out second half's periodogram power at the line's frequency over the local
    level (median ordinate of the bins around it, less the line's own, / ln 2; about 1 where there is no line),
    averaged over the line's channels, before and after subtracting the sinusoid (amplitude and phase per channel)
    fitted on the first half. Block means cannot see a line well above the block rate (a 16.4-Hz line significant
    at 278 against 34 went 102.004 -> 102.004 on 1-s means of a fixture, whose holds' offsets filled the metric);
    a line that is the record's own (a stable source) is coherent from one half to the other, noise is not.
    Samples with no reference (a fixture's moves, a table's ramps) are zero in both the residual and the sinusoid."""
    from imu_sim.diagnose.noise_tests import _mean_cos, _mean_sin
    freq = float(cand.params["frequency_hz"])
    t = case.sim_t_abs
    x = np.column_stack([_mean_sin(t, case.dt, freq), _mean_cos(t, case.dt, freq)])
    keep = reference.stated_samples(case)
    half = case.n // 2
    first, second = slice(0, half), slice(half, 2 * half)
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    out = np.zeros(2)
    for c in chans:
        y = np.where(keep, resid[:, c], 0.0)
        xk = x * keep[:, None]
        coef = np.linalg.lstsq(xk[first], y[first] - np.mean(y[first][keep[first]]), rcond=None)[0]
        held = np.where(keep[second], y[second] - np.mean(y[second][keep[second]]), 0.0)
        out += [_line_power(held, freq, case.dt), _line_power(held - xk[second] @ coef, freq, case.dt)]
    out /= len(chans)
    return ("periodogram power at the line over its local level in the held-out second half (about 1 without a "
            "line), before and after removing the line fitted on the first half"), float(out[0]), float(out[1])


def _line_power(y: np.ndarray, freq: float, dt: float) -> float:
    """Periodogram ordinate of ``y`` at ``freq`` (its nearest bin) over the median of the bins around it (the line's
    own excluded), / ln 2: a white ordinate is exponential with median ln 2 times its mean."""
    p = np.abs(np.fft.rfft(y)) ** 2
    k = int(round(freq * len(y) * dt))
    k = min(max(k, 0), len(p) - 1)
    lo, hi = max(k - LINE_LOCAL_BINS, 1), min(k + LINE_LOCAL_BINS + 1, len(p))
    idx = np.arange(lo, hi)
    local = np.median(p[idx[np.abs(idx - k) > LINE_GUARD_BINS]]) / np.log(2.0)
    return float(np.max(p[max(k - 1, 0):k + 2]) / max(local, 1e-300))


def _coloured(case, model) -> bool:
    """Whether the model's noise PSD is not flat (flicker, a walk, a Gauss-Markov bias): then block means of the raw
    residual weight its low frequencies unlike the test did."""
    psd = noise_psd(model, np.fft.rfftfreq(case.n, case.dt), case.dt)[:, 1:]
    return bool(np.any(psd.max(axis=1) > 1.01 * psd.min(axis=1)))


def _filter_metric(case, cand, model_before, resid):
    """One-step prediction deviance of the second half's block means, the noise term and level fitted on the first half.

    None when the model's noise is one the filter cannot hold (then the Whittle deviance is used).
    """
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    yb = noise_tests.block_means(resid, m)
    half = len(yb) // 2
    bgs = noise_tests.walk_backgrounds(model_before, tb, yb[:half])
    if bgs is None or any(bg.gm_var > 0 for bg in bgs):
        return None
    taus = np.logspace(np.log10(5 * tb), np.log10(half * tb / 20), 8)
    out = np.zeros(2)
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    for c in chans:
        bg = bgs[c]
        _, h0 = local_level.loglik(yb[:half, c], [bg.rw_ratio])
        before = local_level.predictive_deviance(yb[:, c], bg.rw_ratio, h0[0], half, bg)
        if cand.effect == "bias_random_walk":
            fit = local_level.fit(yb[:half, c], tb, bg)
            after = local_level.predictive_deviance(yb[:, c], fit.ratio, fit.h, half, bg)
        else:
            fit = local_level.fit_gauss_markov(yb[:half, c], tb, taus, bg)
            after = local_level.predictive_deviance(yb[:, c], bg.rw_ratio, fit.h, half,
                                                    local_level.Background(fit.gm_var, fit.phi, bg.rw_ratio))
        out += [before, after]
    out /= len(chans)
    return ("one-step prediction deviance per block mean of the held-out second half (v^2/F + log 2 pi F over "
            "the noise level), noise term and level fitted on the first half"), float(out[0]), float(out[1])


def _whittle_metric(case, cand, model_before, resid):
    """Whittle deviance per bin of the second half's block means; the noise term and levels fitted on the first half."""
    half = case.n // 2
    # the noise test needs only the length and the sample interval of what it tests
    refit = noise(Context(SimpleNamespace(n=half, dt=case.dt), model_before, resid[:half]), cand.effect)
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    m = noise_tests.block_interval(half)
    tb = m * case.dt
    out = []
    for mdl in (model_before, add_effect(model_before, refit)):
        dev = []
        for part in (resid[:half], resid[half:2 * half]):
            freqs, pgram = noise_tests.periodogram(noise_tests.detrended(noise_tests.block_means(part, m)), tb)
            dev.append((pgram, noise_tests.noise_model_psd(mdl, freqs, tb)))
        (p1, s1), (p2, s2) = dev
        tot = []
        for c in chans:
            ratio = p2[:, c] / (np.mean(p1[:, c] / s1[c]) * s1[c])
            tot.append(2 * (ratio - np.log(ratio) - 1))
        out.append(float(np.mean(np.concatenate(tot))))
    return ("Whittle deviance per periodogram bin of the held-out second half's block means, noise term and "
            "levels fitted on the first half (about 1.15 when the noise model is right)"), out[0], out[1]
