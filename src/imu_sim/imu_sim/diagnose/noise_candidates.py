"""Slow noise terms as diagnosis candidates: a Gauss-Markov bias and a bias random walk beyond the model's noise.

Both by the exact likelihood of the block means (:mod:`local_level`, a Kalman filter); a model whose own noise the
filter cannot hold (flicker, a Gauss-Markov bias of its own) falls back to the Whittle test of :mod:`noise_tests`.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import stats

from imu_sim.diagnose import hold_noise, local_level, noise_tests, reference, robust_noise
from imu_sim.diagnose.candidate import Candidate, Context, threshold
from imu_sim.diagnose.case import CHANNELS, effective_model


ROBUST_TEXT = ("per channel the smaller of it and the Whittle likelihood ratio against a free white level, the "
               f"model's other noise levels within +-{100 * robust_noise.NOISE_TOLERANCE:g} % and its bias "
               "instability as flicker noise (a misstated noise model and a flicker bias instability are no finding)")


def robust_lr(ctx: Context, effect: str, taus, lr_ch: np.ndarray, cut: float) -> np.ndarray:
    """Per channel (6,) the smaller of ``lr_ch`` and the term's likelihood ratio against the robust null of
    :mod:`robust_noise` (detrended block means; a Gauss-Markov bias' correlation time profiled over ``taus``),
    the latter computed only where ``lr_ch`` exceeds ``cut`` (elsewhere the minimum is ``lr_ch`` already small)."""
    out = np.asarray(lr_ch, float).copy()
    need = [c for c in range(6) if out[c] > cut]
    if not need:
        return out
    case = ctx.case
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    xb = noise_tests.detrended(noise_tests.block_means(ctx.resid, m))
    freqs, pgram = noise_tests.periodogram(xb, tb)
    extras = ([noise_tests.rw_extra(freqs)] if effect == "bias_random_walk"
              else [noise_tests.gm_extra(freqs, tc) for tc in taus])
    for c in need:
        out[c] = min(out[c], robust_noise.extra_lr(pgram[:, c], freqs, ctx.model, c, extras)[0])
    return out


def _random_walk(ctx: Context):
    """Bias random walk by the exact block-mean likelihood (None when the model's noise has flicker)."""
    case, model = ctx.case, ctx.model
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    yb = noise_tests.block_means(ctx.resid, m)
    bgs = noise_tests.walk_backgrounds(model, tb, yb)
    if bgs is None:
        return None
    fits = [local_level.fit(yb[:, c], tb, bgs[c]) for c in range(6)]
    cut = stats.chi2.isf(0.01, 2)
    lr_ch = robust_lr(ctx, "bias_random_walk", None, np.array([f.lr for f in fits]), cut)
    cand = Candidate("bias_random_walk", float(lr_ch.sum()),
                     threshold(6, ctx.m_tests, 1, ctx.factor("bias_random_walk")),
                     f"likelihood ratio of the {tb:.3g}-s block means (Kalman filter: model noise + a walk, "
                     f"its level free), {ROBUST_TEXT}", kind="noise")
    cand.channels = [CHANNELS[c] for c in range(6) if lr_ch[c] > cut]
    mdl = effective_model(model)
    phys = {}
    for c, f in enumerate(fits):
        tri, i, ax = ("gyro", "accel")[c // 3], c % 3, "xyz"[c % 3]
        unit = "rad_per_s_per_sqrt_s" if tri == "gyro" else "mps2_per_sqrt_s"
        cand.params[f"{tri}_{unit}[{ax}]"] = f.k
        cand.intervals[f"{tri}_{unit}[{ax}]"] = list(f.k_interval)
        kept = f.k if CHANNELS[c] in cand.channels else float(mdl.triad(tri).rate_random_walk[i])
        phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = kept
    cand.physics = phys
    return cand


def _gauss_markov_kf(case, model, resid, m, taus):
    """Per channel (lr, sigma^2, its interval, tau, tau interval) from the exact block-mean likelihood, or None.

    None when the model's own noise has flicker or a Gauss-Markov bias (the filter holds one such state).
    """
    tb = m * case.dt
    yb = noise_tests.block_means(resid, m)
    bgs = noise_tests.walk_backgrounds(model, tb, yb)
    if bgs is None or any(bg.gm_var > 0 for bg in bgs):
        return None
    out = []
    for c in range(6):
        f = local_level.fit_gauss_markov(yb[:, c], tb, taus, bgs[c])
        out.append((f.lr, f.sigma**2, (f.sigma_interval[0] ** 2, f.sigma_interval[1] ** 2), f.tau, f.tau_interval))
    return out


def _whittle_fits(model, resid, m, tb, effect, taus, fmin_hz: float = 0.0):
    """Per channel (lr, level, its interval, tau or None, tau interval) from the Whittle test on detrended block means
    (periodogram bins from ``fmin_hz`` up)."""
    # detrended, so a random walk's end-to-end drift is not evidence for a Gauss-Markov bias
    xb = noise_tests.detrended(noise_tests.block_means(resid, m))
    freqs, pgram = noise_tests.periodogram(xb, tb)
    keep = freqs >= fmin_hz
    freqs, pgram = freqs[keep], pgram[keep]
    s0 = noise_tests.noise_model_psd(model, freqs, tb)
    if effect == "bias_random_walk":
        grids = [(None, noise_tests.rw_extra(freqs))]
    else:
        grids = [(tc, noise_tests.gm_extra(freqs, tc)) for tc in taus]
    best = []
    for c in range(6):
        fits = [(*noise_tests.whittle_extra(pgram[:, c], s0[c], extra)[:3], tc) for tc, extra in grids]
        top = max(fits, key=lambda f: f[0])
        # level interval joined over the correlation times of the profile's 95 % set (tc's uncertainty carried)
        inside = [f for f in fits if f[0] >= top[0] - 3.84]
        ci = (min(f[2][0] for f in inside), max(f[2][1] for f in inside))
        tcs = [f[3] for f in inside if f[3] is not None]
        best.append((top[0], top[1], ci, top[3], (min(tcs), max(tcs)) if tcs else None))
    return best


def _above_hold_scale(case, model, resid, m: int, tb: float, best: list, effect: str = "gauss_markov_bias") -> list:
    """``best`` with each channel's Gauss-Markov level and correlation time intervals joined with those of a fit on
    the band above the median hold's frequency, the correlation time profiled up to the record's length, on a
    record of holds (the estimates and likelihood ratio kept). Each hold's own mean is removed first
    (:func:`reference.hold_demeaned`), which takes the process' plateau below that frequency: fitted there, the
    correlation time came out below the hold and the level with it (own consumer fixture, 5.6e-4 rad/s true at
    10 s: 3.9-4.7e-4, at 40 s 2.9-3.5e-4 and no interval covering; blind consumer fixtures 1/12 covered). Above
    it only the level over the correlation time is seen once the latter passes the hold, and the band's interval,
    joined over its profile's set, says how far the level can reach. A walk's level (``effect``) likewise: the
    demeaning takes its power below the hold's frequency, which the full band's interval counted as seen (own
    consumer fixture walks, 1e-4 rad/s/sqrt(s) and 5e-4 m/s^2/sqrt(s): 17/24 intervals covering, 20/24 joined)."""
    spans = reference.holds(case)
    if len(spans) < 2:
        return best
    hold_s = float(np.median([b - a for a, b in spans])) * case.dt
    taus = np.logspace(np.log10(5 * tb), np.log10(case.n * case.dt), 12)
    band = _whittle_fits(model, resid, m, tb, effect, taus, fmin_hz=1.0 / hold_s)
    return [(b[0], b[1], (min(b[2][0], f[2][0]), max(b[2][1], f[2][1])), b[3],
             None if b[4] is None else (min(b[4][0], f[4][0]), max(b[4][1], f[4][1]))) for b, f in zip(best, band)]


def _on_hold_means(case, model, raw: np.ndarray, c: int, fit: tuple) -> tuple:
    """A gyro channel's Whittle fit (lr, sigma^2, interval, tau, interval) with tau profiled on the hold means
    (:func:`hold_noise.gm_on_hold_means`, the raw residual's): the estimates from there, the intervals joined."""
    got = hold_noise.gm_on_hold_means(case, model, raw, c, fit[1], fit[3]) if fit[3] else None
    if got is None:
        return fit
    return (fit[0], got[0], (min(fit[2][0], got[1][0]), max(fit[2][1], got[1][1])), got[2],
            (min(fit[4][0], got[3][0]), max(fit[4][1], got[3][1])))


def smallest_walk(case, model, thr: float) -> tuple | None:
    """(gyro rad/s/sqrt(s), accel m/s^2/sqrt(s)): the bias random walk, on every axis of one triad, whose expected
    Whittle likelihood ratio on this record's holds reaches ``thr`` (each hold's own offset removed, so only
    frequencies above 1 / the longest hold count), or None on a record of fewer than two holds. Below it a walk is
    not detectable here, whatever the method: 2 sum (r - ln(1 + r)) over the block-mean periodogram's bins, r the
    walk's PSD over the model's noise (its flicker included)."""
    spans = reference.holds(case)
    if len(spans) < 2:
        return None
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    freqs = np.fft.rfftfreq(case.n // m, tb)[1:]
    freqs = freqs[freqs >= 1.0 / (max(b - a for a, b in spans) * case.dt)]
    if len(freqs) == 0:
        return None
    s0 = noise_tests.noise_model_psd(model, freqs, tb)
    extra = noise_tests.rw_extra(freqs)
    out = []
    for tri in range(2):
        def expected(k):
            r = k * k * extra[None, :] / s0[3 * tri:3 * tri + 3]
            return 2.0 * float(np.sum(r - np.log1p(r)))
        lo, hi = 1e-15, 1e2
        for _ in range(80):  # bisection in log k
            mid = np.sqrt(lo * hi)
            lo, hi = (mid, hi) if expected(mid) < thr else (lo, mid)
        out.append(float(hi))
    return tuple(out)


def _undetectable_note(ctx: Context, cand: Candidate) -> None:
    """On a record of holds, say how large a walk would have to be to show (:func:`smallest_walk`)."""
    walk = smallest_walk(ctx.case, ctx.model, cand.threshold) if hasattr(ctx.case, "scenario") else None
    if walk is None or cand.significant:
        return
    cand.reason = " ".join(filter(None, [cand.reason, (
        f"not detectable on this record below {walk[0]:.2g} rad/s/sqrt(s) on the gyros or {walk[1]:.2g} "
        "m/s^2/sqrt(s) on the accelerometers (the walk whose expected likelihood ratio on these holds, each with "
        "its own offset, reaches the threshold)")]))


def noise(ctx: Context, effect: str) -> Candidate:
    """Gauss-Markov bias or bias random walk beyond the model's noise (exact block-mean likelihood, else Whittle),
    on the residual less each hold's own offset when the record has several holds (:func:`reference.hold_demeaned`:
    the fixture's tilt per hold is a nuisance the slow terms must not take)."""
    # the held-out metric's refit on half a record is a stand-in with a length and an interval only: no holds
    on_record = hasattr(ctx.case, "scenario")
    raw = ctx.resid
    if on_record:
        ctx = replace(ctx, resid=reference.hold_demeaned(ctx.case, ctx.resid))
    case, model, resid = ctx.case, ctx.model, ctx.resid
    if effect == "bias_random_walk":
        cand = _random_walk(ctx)
        if cand is not None:
            _undetectable_note(ctx, cand)
            return cand
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    # the correlation time must lie well inside the record, else the wander is a random walk here; on three or more
    # still holds up to the record, as the hold means tell a bounded wander from a walk (hold_noise.level_preference)
    top = (case.n // m) * tb / 20
    taus = np.logspace(np.log10(5 * tb), np.log10(top), 8)
    if on_record and hold_noise.still_holds(case):  # the grid within the record kept, four more up to its length
        taus = np.r_[taus, np.logspace(np.log10(top), np.log10(20 * top), 5)[1:]]
    best = _gauss_markov_kf(case, model, resid, m, taus) if effect == "gauss_markov_bias" else None
    n_grid = 1 if effect == "bias_random_walk" else len(taus)
    if best is not None:
        statistic = (f"likelihood ratio of the {tb:.3g}-s block means (Kalman filter: model noise + a Gauss-Markov "
                     "bias, its level free), correlation time profiled")
    else:
        best = _whittle_fits(model, resid, m, tb, effect, taus)
        statistic = "Whittle likelihood ratio of the block-averaged residual" + (
            ", correlation time profiled" if n_grid > 1 else "")
    dof = 6 if effect == "bias_random_walk" else 12
    cut = stats.chi2.isf(0.01, dof // 6 + 1)
    lr_ch = robust_lr(ctx, effect, taus, np.array([b[0] for b in best]), cut)
    thr = threshold(dof, ctx.m_tests, n_grid, ctx.factor(effect))
    cand = Candidate(effect, float(lr_ch.sum()), thr, f"{statistic}; {ROBUST_TEXT}", kind="noise")
    if effect == "bias_random_walk" and statistic.startswith("Whittle") and on_record:
        best = _above_hold_scale(ctx.case, model, resid, m, tb, best, effect)
    if effect == "gauss_markov_bias" and statistic.startswith("Whittle") and on_record:
        best = _above_hold_scale(ctx.case, model, resid, m, tb, best)
        best = [_on_hold_means(case, model, raw, c, b) if c < 3 else b for c, b in enumerate(best)]
    cand.channels = [CHANNELS[c] for c in range(6) if lr_ch[c] > cut]
    mdl = effective_model(model)
    phys = {}
    for c in range(6):
        tri, i, ax = ("gyro", "accel")[c // 3], c % 3, "xyz"[c % 3]
        lr, lev, ci, tc, tc_ci = best[c]
        if effect == "bias_random_walk":
            unit = "rad_per_s_per_sqrt_s" if tri == "gyro" else "mps2_per_sqrt_s"
            key = f"{tri}_{unit}[{ax}]"
            k_old2 = mdl.triad(tri).rate_random_walk[i] ** 2
            cand.params[key] = float(np.sqrt(k_old2 + lev))
            cand.intervals[key] = [float(np.sqrt(k_old2 + ci[0])), float(np.sqrt(k_old2 + ci[1]))]
            phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = cand.params[key]
        else:
            unit = "sigma_rad_per_s" if tri == "gyro" else "sigma_mps2"
            key = f"{tri}_{unit}[{ax}]"
            sig_ch = CHANNELS[c] in cand.channels
            sigma = float(np.sqrt(lev)) if sig_ch else float(mdl.triad(tri).bias_instability[i])
            tcv = float(tc) if sig_ch else float(mdl.triad(tri).bias_correlation_time[i])
            cand.params[key] = sigma
            cand.intervals[key] = [float(np.sqrt(ci[0])), float(np.sqrt(ci[1]))]
            cand.params[f"{tri}_correlation_time_s[{ax}]"] = tcv
            if sig_ch:
                cand.intervals[f"{tri}_correlation_time_s[{ax}]"] = [float(tc_ci[0]), float(tc_ci[1])]
            phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = sigma
            phys.setdefault(f"{tri}_correlation_time_s", [0.0] * 3)[i] = tcv
    cand.physics = phys
    if effect == "bias_random_walk":
        _undetectable_note(ctx, cand)
    return cand


def line_residual(case, resid: np.ndarray) -> np.ndarray:
    """The residual (n, 6) a line search sees: on a fixture of still holds whose moves are not stated, less each
    hold's own level and refilled across the moves (:func:`reference.hold_demeaned`, :func:`unstated.fill_unstated`);
    else ``resid``. The fill across a move passes from one hold's level to the next's, which differ by the holds'
    tilts (0.2 m/s^2 on an up/down's level axes): that ramp of a few seconds puts its 1/f^2 power at the search band's
    lower edge, a false line at 1.00-1.02 Hz (own navigation up/downs: nulls 8000, 8002 and the Earth rate's 7001 on
    the y-z diagonal, LR 307 against 37 there, 19 without the ramp; own tactical null 8004; blind seed 9's navigation
    null)."""
    from imu_sim.diagnose.unstated import fill_unstated, is_rate_table, unreferenced_segments
    segs = unreferenced_segments(getattr(case, "scenario", None))
    if getattr(case, "unstated", None) is None or segs is None or is_rate_table(segs) or len(segs) < 2:
        return resid
    return fill_unstated(reference.hold_demeaned(case, resid), case.unstated)
