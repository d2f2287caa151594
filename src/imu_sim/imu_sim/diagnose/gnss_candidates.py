"""The GNSS-side effects as diagnosis candidates: test, fit with intervals, held-out metric, where it shows."""
from __future__ import annotations

import numpy as np

from imu_sim.diagnose import gnss_tests as gt
from imu_sim.diagnose import metrics
from imu_sim.diagnose.candidate import Candidate, not_testable, threshold
from imu_sim.gnss import GpsEffects

BLOCK_S = 5.0
"""Averaging time (s) of the held-out block means of the fix residual."""


def candidates(case, model, m_tests: int, factors: dict, exclude=()) -> list:
    """gps_latency, gps_lever_arm, colored_gps_noise (those not in ``exclude``)."""
    names = [e for e in ("gps_lever_arm", "gps_latency", "colored_gps_noise") if e not in exclude]
    if case.gnss is None:
        return [not_testable(e, "no GNSS recording given (--gnss)") for e in names]
    gr = gt.gnss_residual(case, model)
    if gr is None:
        return [not_testable(e, f"fewer than {gt.MIN_FIXES} valid fixes inside the scenario") for e in names]
    make = {"gps_latency": _latency, "gps_lever_arm": _lever_arm, "colored_gps_noise": _colored}
    out = [make[e](case, model, gr, m_tests, factors) for e in names]
    pair = [c for c in out if c.effect in ("gps_latency", "gps_lever_arm") and c.significant]
    if len(pair) == 2:
        _order_pair(pair, gt.conditional_lrs(gr))
    return out


def _order_pair(pair: list, cond: dict) -> None:
    """Latency and lever arm both significant: the one the data need more (conditional LR) ranks where the
    pair ranked; the other ranks by its conditional excess (and says so when it is not separable)."""
    top = max(c.stat - c.threshold for c in pair)
    win, lose = sorted(pair, key=lambda c: cond[c.effect] - c.threshold, reverse=True)
    win.rank, lose.rank = top, cond[lose.effect] - lose.threshold
    for c in pair:
        other = (lose if c is win else win).effect
        c.reason = (c.reason + "; " if c.reason else "") + f"LR given {other}: {cond[c.effect]:.4g}"
    if cond[win.effect] <= win.threshold:
        win.reason += f"; not separable from {lose.effect} by this scenario (neither needed given the other)"


def _regression(effect, design, gr, thr, statistic, names, base, unit_note):
    fit, _, _ = gt.gls_whiteness_first(gr, design)
    if len(fit.used) == 0:
        return not_testable(effect, "its regressor is zero or constant over this scenario (" + unit_note + ")")
    cand = Candidate(effect, fit.lr, thr, statistic + "; whitened by " + fit.whitened_by, kind="gnss")
    sd = np.sqrt(np.diag(fit.cov))
    for i in fit.used:
        val = float(base[i] + fit.theta[i])
        cand.params[names[i]] = val
        cand.intervals[names[i]] = [val - 1.96 * float(sd[i]), val + 1.96 * float(sd[i])]
    missing = [i for i in range(design.shape[2]) if i not in fit.used]
    if missing:
        cand.reason = "not identifiable by this scenario: " + "; ".join(_floor(names[i], fit, i, thr) for i in missing)
    contrib = np.einsum("nak,k->na", design, np.nan_to_num(fit.theta))
    cand.channels = [gt.CHANNELS[a] for a in range(3) if np.std(contrib[:, a]) > 0.05 * np.std(contrib)]
    cand.columns = {a: design[:, a, fit.used] for a in range(3)}
    cand.contrib = contrib
    cand.block_s = BLOCK_S
    return cand


def _floor(name: str, fit, i: int, thr: float) -> str:
    """Why parameter ``i`` was left out, with the smallest size the record would see: the size whose likelihood ratio
    alone reaches the test's threshold, sqrt(threshold) times its standard error in the joint fit (a vertical lever
    arm on a level drive shows only through the body's roll and pitch: a few centimetres per metre in the turns)."""
    sd = fit.sd_joint[i] if fit.sd_joint is not None else np.inf
    if not np.isfinite(sd):
        return f"{name} (its regressor is constant or explained by the others on this record)"
    unit = name.split("[")[0].rsplit("_", 1)[-1]  # lever_arm_m[z] -> m, latency_s -> s
    return (f"{name} ({gt.WEAK_SD_RATIO:g}x less determined than the others: +-{sd:.3g} {unit} in the joint fit, "
            f"so one smaller than {np.sqrt(thr) * sd:.3g} {unit} would not reach the threshold on this record)")


def _latency(case, model, gr, m_tests, factors):
    eff = GpsEffects.from_physics(model.physics, case.scenario.gps_lever_arm_m)
    cand = _regression("gps_latency", gt.design_latency(gr), gr,
                       threshold(1, m_tests, 1, factors.get("gps_latency", 1.0)),
                       "GLS likelihood ratio of the fix residual on -velocity", ["latency_s"],
                       [eff.latency_s], "the truth velocity")
    lat = cand.params.get("latency_s")
    if cand.identifiable and lat < 0:
        # the fixes lead the truth: physics.gps_latency holds 0-10 s (own short drive, lever-arm case 7017: a
        # latency of -0.14 s was kept and the next round could not simulate the model)
        lo, hi = cand.intervals["latency_s"]
        cand.identifiable = False
        cand.reason = (f"a negative latency ({lat:.3g} s, 95 % [{lo:.3g}, {hi:.3g}]): the fixes lead the truth, an "
                       "offset of the recording's or the truth's time base, not a receiver latency; not ranked")
    elif cand.identifiable:
        cand.physics = {"latency_s": lat}
    return cand


def _lever_arm(case, model, gr, m_tests, factors):
    eff = GpsEffects.from_physics(model.physics, case.scenario.gps_lever_arm_m)
    names = [f"lever_arm_m[{a}]" for a in "xyz"]
    cand = _regression("gps_lever_arm", gt.design_lever_arm(gr), gr,
                       threshold(3, m_tests, 1, factors.get("gps_lever_arm", 1.0)),
                       "GLS likelihood ratio of the fix residual on the body-to-ENU rotation", names,
                       eff.lever_arm_m, "the attitude does not change")
    if cand.identifiable:
        arm = eff.lever_arm_m.copy()
        for i, n in enumerate(names):
            arm[i] = cand.params.get(n, arm[i])
        cand.physics = {"lever_arm_m": arm.tolist()}
    return cand


def _colored(case, model, gr, m_tests, factors):
    col = gt.colored_fit(gr.r, gr)
    cand = Candidate("colored_gps_noise", col.lr, threshold(6, m_tests, col.n_grid, factors.get("colored_gps_noise", 1.0)),
                     "Whittle likelihood ratio of the fix residual, extra Gauss-Markov, correlation time profiled",
                     kind="gnss")
    var, tau, tau_ci, var_ci = _colored_estimate(gr, col)
    sig = np.sqrt(gr.colored_sigma**2 + var)
    for a, ax in enumerate("enu"):
        cand.params[f"sigma_m[{ax}]"] = float(sig[a])
        lo, hi = var_ci[a]
        cand.intervals[f"sigma_m[{ax}]"] = [float(np.sqrt(gr.colored_sigma[a] ** 2 + lo)),
                                            float(np.sqrt(gr.colored_sigma[a] ** 2 + hi))]
    cand.params["correlation_time_s"] = tau
    cand.intervals["correlation_time_s"] = tau_ci
    cand.channels = [gt.CHANNELS[a] for a in range(3) if col.lr_axes[a] > 6.63]
    cand.physics = {"sigma_m": sig.tolist(), "correlation_time_s": tau}
    cand.band = {"frequency_hz": [0.0, float(1.0 / (2 * np.pi * tau))]}
    return cand


def _colored_estimate(gr, col) -> tuple:
    """(variance (3,) m^2, tau s, tau interval, variance intervals) of the extra Gauss-Markov: on a short record
    (:data:`gt.EXACT_MAX_FIXES`) from its exact restricted likelihood, correlation times up to the run's length
    (:func:`gt.exact_profile`); on a long one from the Whittle fit that tested it."""
    if len(gr.r) > gt.EXACT_MAX_FIXES:
        return col.var, col.tau, col.tau_ci, col.var_ci
    prof = gt.exact_profile(gr, gt.whitening_taus(gr))
    var, tau = prof.best()
    tau_ci, var_ci = prof.intervals()
    return var, tau, tau_ci, var_ci


def fit_metric(case, cand, model_before, model_after):
    """(metric name, before, after) on held-out fixes."""
    gr = gt.gnss_residual(case, model_before)
    if cand.effect != "colored_gps_noise":
        b, a = metrics.heldout_rms(gr.r, cand.columns, gr.dt, cand.block_s)
        return (f"RMS of held-out {cand.block_s:g}-s block means of the fix residual over their scatter "
                "(odd tenths, fit on even tenths)"), b, a
    if len(gr.r) > gt.EXACT_MAX_FIXES:  # many correlation times a half: its periodogram shows the term
        half = len(gr.r) // 2
        first = gt.half(gr, slice(0, half))
        col = gt.colored_fit(first.r, first)
        test = gr.r[half:]
        return ("Whittle deviance per bin of the second half's fix residual (noise fitted on the first half)",
                gt.whittle_deviance(test, gr), gt.whittle_deviance(test, gr, col.var, col.tau))
    name = ("deviance per fix of each half's fix residual predicted one step from its neighbours (exact covariance, "
            "level and datum free per axis) under the noise fitted on the other half, summed over the halves")
    return (name, *gt.heldout_noise_deviance(gr))


def location(case, cand, model_before) -> tuple:
    """(time span s, band) of a GNSS finding."""
    gr = gt.gnss_residual(case, model_before)
    if cand.effect == "colored_gps_noise":
        return [float(gr.t_rel[0]), float(gr.t_rel[-1])], cand.band
    band, _, _ = metrics.allan_band(gr.r, gr.r - cand.contrib, 1.0 / gr.dt)
    return metrics.time_span(gr.r, cand.contrib, gr.t_rel), band
