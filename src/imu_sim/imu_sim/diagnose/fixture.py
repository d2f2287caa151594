"""The fixture as a nuisance: can a tilt of each static segment, within the scenario's tolerance, mimic a finding?

A static segment's real attitude differs from its stated one by a small rotation d (rad, body axes), the same for the
whole segment; it changes the true specific force by f_b x d and the true rate by w_b x d (both from the truth,
varying in time on a rate table). A candidate's fitted contribution (n, 6) is regressed jointly on these columns
(three tilt parameters per segment, shared by the six channels) and a turn-on bias per channel, each channel weighted
by its noise level, on the holds only; the tilts' second-order term follows from them (Gauss-Newton). When the candidate's likelihood
ratio given the tilts is below its threshold and the tilts lie within ``attitude_tolerance_deg``, the effect is not
separable from the reference on this record. The held-out fit of a regression on such a record is scored on the
holds with the tilts removed (:func:`without_tilts`).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import block_diag

from imu_sim.diagnose.plausibility import (BOUNDED, implausible_on_holds as _implausible_on_holds,
                                           reported_on_whole as _reported_as_model_error)
from imu_sim.diagnose.fixture_notes import (NOT_SEPARABLE, floor_note, free_note as _free_note, tilt_note as _note,
                                            wander_note)
from imu_sim.diagnose.candidate import add_effect
from imu_sim.diagnose.hold_noise import (INFLATION_BLOCKS_S, WANDER_TERMS, Prior, bias_wander, hold_scale_blocks,
                                         inflation, noise_key as _noise_key, penalised_fit, stated_inflation)
from imu_sim.diagnose.fixture_holds import STILL_RAD_S, hold_weights as _weights
from imu_sim.diagnose.unstated import is_rate_table, unreferenced_segments

TILT_EFFECTS = ("axis_misalignment", "scale_factor", "gyro_g_sensitivity", "gravity_model", "earth_rotation",
                "warmup_drift", "temperature_bias")
"""Effects whose regressors a fixture tilt can reproduce (true rate / specific force on a static segment; a slow
drift sampled by a sequence of holds, each with its own offset)."""


TILT_SLACK = 1.5
"""A fitted tilt up to this many tolerances is within it; beyond, an effect below threshold given them stands, but not
a slow curve, whose hold-to-hold part any offset pattern makes (own navigation nulls 8000, 8004: tilts of 1.8 deg)."""
def _tilt_design(case, weights: np.ndarray) -> np.ndarray:
    """Stacked design (6 n, 3 per segment + 6 biases): f_b x d on accel, w_b x d + dd/dt on gyro (first order in the
    tilt d); the second-order term is not a free parameter but follows from d (:func:`_second_order`)."""
    w, wdot = weights
    n = case.n
    cols = []
    for s in range(w.shape[1]):
        for a in range(3):
            e = np.zeros(3)
            e[a] = 1.0
            col = np.zeros((n, 6))
            col[:, :3] = w[:, s:s + 1] * np.cross(case.gyro_true, e) + wdot[:, s:s + 1] * e
            col[:, 3:] = w[:, s:s + 1] * np.cross(case.accel_true, e)
            cols.append(col.T.ravel())
    for c in range(6):
        col = np.zeros((6, n))
        col[c] = 1.0
        cols.append(col.ravel())
    return np.column_stack(cols)


def _second_order(case, weights: np.ndarray, tilts: np.ndarray) -> np.ndarray:
    """The tilts' second-order term (6 n, stacked like the design), d x (d x v) / 2 for v the true rate and specific
    force: a tilt theta shortens the specific force along its nominal direction by 1 - cos theta (1.5e-4 g at 1 deg).

    It is fixed by the fitted tilts, not free: a free specific-force scale per hold (tried first) took a missing
    gravity model, a scale common to every hold, which no tilt can make."""
    d = weights[0] @ tilts  # (n, 3) tilt at each sample
    out = np.zeros((case.n, 6))
    out[:, :3] = 0.5 * np.cross(d, np.cross(d, case.gyro_true))
    out[:, 3:] = 0.5 * np.cross(d, np.cross(d, case.accel_true))
    return out.T.ravel()


def _shortening(case, weights: np.ndarray, tol: float):
    """(columns (6 n, m), prior precisions (m,)) of a free shortening of each hold's specific force along itself, or
    None when the holds determine their tilts. With fewer than three holds (an up/down) the accelerometers' turn-on
    biases and the tilts they see are confounded (3 m readings, 3 + 2 m unknowns), so the fitted tilts cannot fix
    their second-order term: the cosine error of a tilt within the tolerance, up to (1.5 tol)^2 / 2 of g (3.4e-4 at
    1 deg), is then a nuisance of its own, with that as its prior sd (an up/down null's accel-x step of 1.5e-3
    m/s^2 between its holds was fitted as a temperature coefficient, a scale factor and a misalignment)."""
    w = weights[0]
    m = w.shape[1]
    if m >= 3:
        return None
    cols = np.zeros((6 * case.n, m))
    for s in range(m):
        col = np.zeros((case.n, 6))
        col[:, 3:] = w[:, s:s + 1] * case.accel_true
        cols[:, s] = col.T.ravel()
    sd = 0.5 * (TILT_SLACK * tol) ** 2
    return cols, np.full(m, 1.0 / sd)


GAUSS_NEWTON_STEPS = 3
"""Refits of the tilts with their second-order term from the previous fit (it is ~1e-2 of the first-order one)."""


def _fit_tilts(case, weights, tilt, y, w, prior, eff=None) -> tuple:
    """(rss, theta, second-order offset) of the weighted tilt fit (with ``eff`` columns), Gauss-Newton on the
    second-order term."""
    m = weights.shape[2]
    x = tilt if eff is None else np.hstack([tilt, eff])
    off = np.zeros_like(y)
    for _ in range(GAUSS_NEWTON_STEPS):
        rss, theta = penalised_fit(x * w[:, None], (y - off) * w, prior)
        off = _second_order(case, weights, theta[:3 * m].reshape(m, 3))
    rss, theta = penalised_fit(x * w[:, None], (y - off) * w, prior)
    return rss, theta, off


def _stack(columns: dict, n: int, k: int) -> np.ndarray:
    """A candidate's columns per channel (n, k each, shared parameters) as one (6 n, k) design."""
    out = np.zeros((6 * n, k))
    for c, x in columns.items():
        out[c * n:(c + 1) * n] = x
    return out


def _setup(case, cand_columns: dict, resid: np.ndarray, slow: bool = False, model=None):
    """Shared pieces of the joint fit: weights, design, stacked effect, residual, row weights (noise std per channel
    on the holds only; a ``slow`` curve's by :func:`hold_noise.stated_inflation` too), tilt prior; None when the
    record has no fixture holds or no tolerance."""
    if "fixture_weights" not in case.cache:  # the same for every candidate and pass
        case.cache["fixture_weights"] = _weights(case)
    weights = case.cache["fixture_weights"]
    tol = np.radians(case.scenario.attitude_tolerance_deg)
    if weights is None or tol <= 0:
        return None
    n, m = case.n, weights.shape[2]
    k = next(iter(cand_columns.values())).shape[1]
    if "fixture_tilt_design" not in case.cache:
        case.cache["fixture_tilt_design"] = _tilt_design(case, weights)
    tilt = case.cache["fixture_tilt_design"]
    short = _shortening(case, weights, tol)
    if short is not None:
        tilt = np.hstack([tilt, short[0]])
    model = case.model if model is None else model  # the model under test: a noise term found before is in it
    key = ("fixture_hold_bias", _noise_key(model))
    wander = case.cache[key] = case.cache[key] if key in case.cache else bias_wander(case, weights[0], model)
    if wander is not None:
        tilt = np.hstack([tilt, wander[0]])
    eff = _stack(cand_columns, n, k)
    raw = resid.T.ravel()
    design = np.hstack([tilt, eff])
    _, th = penalised_fit(design, raw)
    fit_resid = (raw - design @ th).reshape(6, n)
    sigma = np.std(fit_resid, axis=1)
    # the moves between holds are left out: the simulator's path between two tilted holds is not the first-order
    # blend of their tilts (a rotation-vector path of up to 180 deg), so only the holds are compared
    hold = np.all(np.isin(weights[0], (0.0, 1.0)), axis=1)
    if getattr(case, "unstated", None) is not None:  # a hold's first sample may still hold the end of the move
        hold &= ~case.unstated
    # a noise-level weight per channel would count every sample as independent: the residual's wander within a hold
    # (flicker, a Gauss-Markov bias) makes a hold's offsets vary more than white noise, so each channel is weighted
    # by its effective sample size too (a consumer fixture's warm-up and Gauss-Markov bias were taken by a
    # misalignment of white-noise statistic far above threshold)
    infl = inflation(fit_resid, hold, case.dt, hold_scale_blocks(hold, case.dt) if slow else INFLATION_BLOCKS_S)
    if slow:  # its evidence within a hold lies at the hold's own scale, where a stated flicker has grown
        infl = np.maximum(infl, stated_inflation(model, hold, case.dt))
    w = np.repeat(1.0 / np.maximum(sigma * np.sqrt(infl), 1e-300), n) * np.tile(hold, 6)
    # the tolerance is a Gaussian prior (sd = tolerance) on each tilt: a rotation about the gravity axis, which the
    # specific force cannot see, stays within it instead of fitting the Earth rate's noise with tens of degrees
    bound = np.diag(np.r_[np.full(3 * m, 1.0 / tol), np.zeros(6), [] if short is None else short[1]])
    prior = bound if wander is None else block_diag(bound, wander[1])
    charged = np.r_[np.zeros(bound.shape[0], bool), [] if wander is None else np.ones(len(wander[2]), bool)]
    case.cache["fixture_gyro_offset_rows"] = (  # this model's (another model's wander may charge other channels)
        None if wander is None else np.r_[np.zeros(bound.shape[0], bool), wander[2] < 3])
    return weights, tol, tilt, eff, raw, w, Prior(prior, charged), hold


SLOW_CURVES = ("warmup_drift", "temperature_bias")  # tested against free per-hold gyro offsets (:func:`_given`)
FREE_TILT_SD_RAD = 10.0
"""Prior sd of a tilt left free (:func:`_given` with ``free``): no bound at all within a first-order fit."""


def _given(case, cand, resid: np.ndarray, cache: dict | None = None, columns: dict | None = None,
           free: bool = False):
    """(likelihood ratio on the holds given the biases alone, given the tilts too, largest |tilt| rad, the effect's
    parameters and covariance in the joint fit) or None when the record has no fixture holds, or the candidate no
    evidence on them. ``cache`` keeps the tilt-only fit; ``columns`` replace the candidate's (a warm-up's time
    constant profiled); ``free`` leaves each hold's attitude free instead of within the tolerance."""
    setup = _setup(case, columns or cand.columns, resid, slow=cand.effect in SLOW_CURVES,
                   model=(cache or {}).get("model"))
    if setup is None:
        return None
    weights, tol, tilt, eff, raw, w, prior, _ = setup
    m = weights.shape[2]
    if free:
        prior = prior.copy()
        prior[:3 * m, :3 * m] = np.eye(3 * m) / FREE_TILT_SD_RAD
    if cand.effect in SLOW_CURVES and case.cache.get("fixture_gyro_offset_rows") is not None:
        # a curve in time sampled by the holds is what the gyro wander itself makes (a flicker's 1/f tail, a walk):
        # its stated level cannot tell them apart, so the gyro offsets stay free for it, as before (own consumer
        # null 8003 with them charged: a warm-up at 50 against 26.7); a pattern keyed to each hold's attitude
        # (g-sensitivity, the Earth rate) is not one the wander makes, and the charged offsets keep it as evidence
        prior = Prior(prior, prior.charged & ~case.cache["fixture_gyro_offset_rows"])
    bias = tilt[:, 3 * m:3 * m + 6] * w[:, None]
    y = raw * w
    lr_alone = penalised_fit(bias, y)[0] - penalised_fit(np.hstack([bias, eff * w[:, None]]), y)[0]
    if lr_alone <= 0:
        return None
    if getattr(case.scenario, "source", None) != "static_segments" and lr_alone < cand.threshold:
        return MOVES_ONLY  # a truth file's effect seen only off its still holds: a rate table's spins or the moves
    cache = {} if cache is None else cache
    key = (id(resid), w.tobytes().__hash__(), free)
    if key not in cache:
        rss_tilt, th_tilt, _ = _fit_tilts(case, weights, tilt, raw, w, prior)
        cache[key] = (rss_tilt, float(np.max(np.abs(th_tilt[:3 * m]))))
    rss_tilt, top = cache[key]
    rss_joint, theta, off = _fit_tilts(case, weights, tilt, raw, w, prior, eff)
    x = np.hstack([tilt, eff]) * w[:, None]
    p = np.zeros((prior.shape[0], x.shape[1]))
    p[:, :prior.shape[1]] = prior
    info = x.T @ x + p.T @ p
    k = eff.shape[1]
    cov = np.linalg.pinv(info)[-k:, -k:]
    return lr_alone, max(rss_tilt - rss_joint, 0.0), top, theta[-k:], cov


MOVES_ONLY = "moves only"
"""What :func:`_given` returns for a truth file's effect with no evidence on its still holds."""


def _spinning_holds(case) -> bool:
    """Whether a truth file's record has constant-rate holds that turn (a rate table's), where an effect off the
    still holds is seen on a known motion."""
    from imu_sim.diagnose.reference import holds
    return any(np.max(np.abs(case.gyro_true[a:b])) >= STILL_RAD_S for a, b in holds(case))


def check(case, cand, resid: np.ndarray, model=None) -> str | None:
    """The note when a fixture tilt within tolerance can stand for ``cand`` (None: separable or not applicable): its
    likelihood ratio in the joint fit on the holds given the tilts and each hold's bias offset (:func:`_given`)."""
    if cand.effect not in TILT_EFFECTS or not cand.columns:
        return None
    got = _given(case, cand, resid, {"model": model})
    if got is None or got is MOVES_ONLY:
        return None
    lr_alone, given, top = got[:3]
    tol = np.radians(case.scenario.attitude_tolerance_deg)
    if given < cand.threshold and (top <= TILT_SLACK * tol or cand.effect in SLOW_CURVES):
        return _note(case, cand, lr_alone, given, top)
    return None


def rank_given_tilts(case, cands: list, resid: np.ndarray, model=None) -> None:
    """Rank every significant tilt-sensitive candidate by its evidence given the fixture's tilts (joint fit on the
    holds): its likelihood ratio there given the tilts (and a significant noise term's wander), less its threshold
    (a known constant matching its value, less its misfit z^2 only: zero free parameters); so of two nested effects
    (an accelerometer scale factor per axis and the gravity model) the one with fewer parameters wins unless the
    other explains more than its extra threshold. One not separable from the tilts is not ranked. Without this, a
    warm-up whose raw statistic was the tilts' own (6e5 on a 1-deg tumble) outranked the missing gravity model."""
    if (tol := np.radians(getattr(case.scenario, "attitude_tolerance_deg", 0.0) or 0.0)) <= 0:
        return
    cache: dict = {"model": model}  # the model under test (None: the user's); a g-sensitivity's floor said if unseen
    for cand in cands:
        if cand.effect == "gyro_g_sensitivity" and cand.columns and not cand.significant:
            floor_note(cand, _given(case, cand, resid, cache))
        if cand.effect not in TILT_EFFECTS or not cand.columns or not cand.significant:
            continue
        got = _given(case, cand, resid, cache)
        if got is MOVES_ONLY and not _spinning_holds(case):
            cand.identifiable, cand.reason = False, (
                f"{NOT_SEPARABLE}: its evidence lies in the moves between the fixture's holds, not on them, and a "
                f"tilt of each hold within attitude_tolerance_deg ({case.scenario.attitude_tolerance_deg:g} deg) "
                "changes each move's path (a 1-deg tilt is 1 % of a 90-deg turn); not ranked")
            continue
        if got is None or got is MOVES_ONLY:
            continue
        if cand.effect == "warmup_drift":
            got = _warmup_given_tilts(case, cand, resid, cache) or got
        lr_alone, given, top, theta, cov = got
        wander = _given_found_wander(case, cand, resid, cands, model)
        if cand.effect in BOUNDED and wander < cand.threshold <= given:  # a noise term's wander across holds
            cand.identifiable, cand.reason = False, wander_note(cand, wander)
            continue
        if given < cand.threshold and (top <= TILT_SLACK * tol or cand.effect in SLOW_CURVES):
            cand.identifiable, cand.reason = False, _note(case, cand, lr_alone, given, top)
            continue
        if cand.effect == "axis_misalignment" and _free_attitude_holds(case):
            free = _given(case, cand, resid, cache, free=True)
            if free is not None and free is not MOVES_ONLY and free[1] < cand.threshold:
                cand.identifiable, cand.reason = False, _free_note(case, cand, given, free[1])
                continue
        if cand.constant_scale is not None:
            _constant_given_tilts(case, cand, given, theta, cov)
        elif _implausible_on_holds(case, cand, theta, cov) and not _reported_as_model_error(case, cand):
            # its evidence on the holds needs a value no sensor of the grade has (a gyro scale factor of +5 for an
            # isotropic g-sensitivity: on a still hold the up axis' gyro sees the Earth rate's vertical part,
            # 5.7e-5 rad/s, along the axis that sees +-g): ranked below every plausible rival
            cand.rank = IMPLAUSIBLE_RANK
        else:
            own = min(given, wander) - cand.threshold
            cand.rank = own if cand.rank is None else min(cand.rank, own)
            _from_joint_fit(case, cand, theta, cov)


def _given_found_wander(case, cand, resid: np.ndarray, cands: list, model) -> float:
    """The smallest likelihood ratio on the holds given the tilts and a significant noise term's wander (in the offsets'
    prior and a slow curve's weights; inf if none), each in ``given_rivals``: whitened, the tilts count (own industrial
    fixture, Gauss-Markov 2.8e-4 rad/s at 40 s: a temperature curve 2.2e5 given it there, 8.2 on the holds)."""
    out = np.inf
    for noise in [c for c in cands if c.kind == "noise" and c.significant and c.effect in WANDER_TERMS]:
        got = _given(case, cand, resid, {"model": add_effect(case.model if model is None else model, noise)})
        if got is not None and got is not MOVES_ONLY:
            cand.given_rivals[noise.effect] = min(cand.given_rivals.get(noise.effect, np.inf), got[1])
            out = min(out, got[1])
    return out


def _free_attitude_holds(case) -> bool:
    """Whether the record is a fixture of still holds whose attitudes are each their own (static segments, none
    spinning, the moves not stated): there a hold's two level accelerometer readings are what its tilt and an
    accelerometer misalignment both make, one for one."""
    segs = unreferenced_segments(case.scenario)
    return segs is not None and not is_rate_table(segs)


WARMUP_TAU_STEP = 2
"""The joint fit profiles every second time constant of the GLS's grid (4 a decade): each is a fit of the tilts."""


def _warmup_given_tilts(case, cand, resid: np.ndarray, cache: dict):
    """The warm-up's time constant profiled in the joint fit with the tilts (the tilt-blind GLS put it at 20 s for a
    true 60 s on a six-position test, whose holds each took part of the decay): the best time constant's
    :func:`_given`, its columns, time constant and 95 % profile interval set on ``cand``; None if none fits."""
    from imu_sim.diagnose.effect_tests import profile_interval
    from imu_sim.diagnose.regressors import design_warmup, warmup_taus
    taus = warmup_taus(case.t[-1] - case.t[0], case.dt)[::WARMUP_TAU_STEP]
    fits = []
    for tau in taus:
        cols = design_warmup(case, case.model, tau).columns
        got = _given(case, cand, resid, cache, columns=cols)
        if got is not None and got is not MOVES_ONLY:
            fits.append((got[1], tau, cols, got))
    if not fits:
        return None
    fits = sorted(fits + _refined_tau(case, cand, resid, cache, fits), key=lambda f: f[1])
    i = int(np.argmax([f[0] for f in fits]))
    best = fits[i]
    cand.columns = best[2]
    cand.params["time_constant_s"] = float(best[1])
    cand.intervals["time_constant_s"] = profile_interval(np.log([f[1] for f in fits]), np.array([f[0] for f in fits]),
                                                         i)
    cand.physics = dict(cand.physics or {}, time_constant_s=float(best[1]))
    return _with_tau_uncertainty(case, cand, resid, cache, best)


TAU_XTOL = 0.01
"""Tolerance (in ln tau) of the warm-up's time constant refined between its grid's neighbours (1 %)."""
TAU_STEP_MAX = 0.05
"""Largest relative Gauss-Newton step of the time constant after the search (:func:`_with_tau_uncertainty`)."""


def _refined_tau(case, cand, resid: np.ndarray, cache: dict, fits: list) -> list:
    """More (LR, tau, columns, fit) of :func:`_warmup_given_tilts`, the time constant refined by a bounded search in
    ln tau between the best grid point's neighbours: the grid's step is a factor 3.2, and a navigation warm-up of
    160 s fitted at the grid's 185 s took its amplitudes 8 % high with intervals of +-1 %, and the time constant's
    profile interval [184.74, 184.78] s (own fx_warmup_temp 7000, 7001: 3-4 of 7 covering)."""
    from scipy.optimize import minimize_scalar
    from imu_sim.diagnose.regressors import design_warmup
    i = int(np.argmax([f[0] for f in fits]))
    lo, hi = fits[max(i - 1, 0)][1], fits[min(i + 1, len(fits) - 1)][1]
    if hi <= lo:
        return []
    more = []

    def neg(u: float) -> float:
        cols = design_warmup(case, case.model, float(np.exp(u))).columns
        got = _given(case, cand, resid, cache, columns=cols)
        if got is None or got is MOVES_ONLY:
            return np.inf
        more.append((got[1], float(np.exp(u)), cols, got))
        return -got[1]

    minimize_scalar(neg, bounds=(np.log(lo), np.log(hi)), method="bounded", options={"xatol": TAU_XTOL})
    return more


def _with_tau_uncertainty(case, cand, resid: np.ndarray, cache: dict, best: tuple) -> tuple:
    """The best time constant's joint fit, its amplitudes' covariance carried through the time constant's own
    uncertainty: refitted with the curve's derivative in tau as one more column (its Jacobian, as the tilt-blind GLS
    does). At a fixed tau the amplitudes' intervals knew nothing of it (blind navigation warm-ups: 4/7 covering)."""
    theta, k, rel = best[3][3], len(best[3][3]), (case.t - case.t[0]) / float(best[1]) ** 2
    got = _given(case, cand, resid, cache, columns={c: np.hstack([x, ((x @ theta) * rel)[:, None]])
                                                     for c, x in best[2].items()})
    if got is None or got is MOVES_ONLY or not np.all(np.isfinite(got[4])):
        return best[3]
    tau, step, half = float(best[1]), float(got[3][k]), 1.96 * np.sqrt(max(got[4][k, k], 0.0))
    if abs(step) > TAU_STEP_MAX * tau:  # a Gauss-Newton step beyond the search's last bracket: not taken
        return best[3]
    # the step from the Jacobian's fit: the bounded search stops within 1 % of tau, while a navigation warm-up's tau
    # is determined to 0.1 % (own fx_warmup_temp 7000: 16.7 standard errors off at the search's end)
    from imu_sim.diagnose.regressors import design_warmup
    cand.columns = design_warmup(case, case.model, tau + step).columns
    cand.params["time_constant_s"] = tau + step
    cand.physics = dict(cand.physics or {}, time_constant_s=tau + step)
    lo, hi = cand.intervals["time_constant_s"]  # tau's own interval from the same Jacobian, if the profile's is less
    cand.intervals["time_constant_s"] = [float(min(lo, tau + step - half)), float(max(hi, tau + step + half))]
    return (*best[3][:3], got[3][:k], got[4][:k, :k])


def _from_joint_fit(case, cand, theta: np.ndarray, cov: np.ndarray) -> None:
    """A tilt-sensitive regression's parameters, intervals, physics entry and contribution from its joint fit with the
    tilts on the holds (each channel weighted by its effective sample size), not the tilt-blind GLS: a temperature
    coefficient that took a fixture tilt came out ten times its value there, and the intervals knew nothing of the
    tilts' uncertainty (blind fixture coverage 46 %)."""
    names = [m for m in cand.params if m != "time_constant_s"]
    design = getattr(cand, "design", None)
    if len(names) != len(theta) or cand.kind != "regression" or design is None:
        return
    half = 1.96 * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    cand.params.update({m: float(v) for m, v in zip(names, theta)})
    cand.intervals.update({m: [float(v - h), float(v + h)] for m, v, h in zip(names, theta, half)})
    tau = cand.params.get("time_constant_s")
    cand.physics = dict(design.to_physics(np.asarray(theta, float)), **({} if tau is None else
                                                                        {"time_constant_s": float(tau)}))
    cand.contrib = np.zeros((case.n, 6))
    for ch, x in cand.columns.items():
        cand.contrib[:, ch] = x @ theta


IMPLAUSIBLE_RANK = -1.0
"""Ranking key of a candidate whose fit on the holds, given the tilts, is outside its grade's bounds."""


def without_tilts(case, columns: dict, resid: np.ndarray):
    """(residual less each hold's fitted fixture tilt, (n,) mask of the hold samples) for a held-out fit, or None.

    The tilts are fitted jointly with ``columns`` (so they cannot take the effect), within the tolerance; only the
    holds are scored, as the path between tilted holds is not known (a 1-deg tilt changes a 6-s move's rate by
    3e-3 rad/s, which swamped a missing Earth rate's 7e-5 in the held-out gyro block means)."""
    if getattr(case.scenario, "source", None) != "static_segments" and _spinning_holds(case):
        return None  # a truth file's rate table: its evidence is on the spinning holds, which the still ones blend over
    setup = _setup(case, columns, resid)
    if setup is None or setup[0].shape[2] < 2:
        return None  # one hold: its tilt is its accelerometers' turn-on bias, which the held-out fit has anyway
    weights, _, tilt, eff, raw, w, prior, hold = setup
    m = weights.shape[2]
    _, theta, off = _fit_tilts(case, weights, tilt, raw, w, prior, eff)
    nuis = tilt[:, :3 * m] @ theta[:3 * m] + tilt[:, 3 * m + 6:] @ theta[3 * m + 6:tilt.shape[1]] + off
    return resid - nuis.reshape(6, case.n).T, hold


def _constant_given_tilts(case, cand, given: float, theta: np.ndarray, cov: np.ndarray) -> None:
    """A known constant's scale, interval and ranking from the joint fit with the tilts: the tilts' second-order term
    (1.5e-4 g at 1 deg) is ten times the gravity model's difference (1.6e-3 m/s^2 at Calgary), so the fit that
    ignores them put the gravity scale at 2.1; matching its value (|z| <= 1.96) it ranks with zero free parameters."""
    from imu_sim.diagnose.regressors import physical_value
    se = float(np.sqrt(max(cov[0, 0], 0.0)))
    ci = np.array([[theta[0] - 1.96 * se, theta[0] + 1.96 * se]])
    cand.params, cand.intervals = physical_value(cand.effect, theta, ci, case)
    cand.constant_scale, cand.constant_se = float(theta[0]), se
    cand.contrib = np.zeros((case.n, 6))
    for ch, x in cand.columns.items():
        cand.contrib[:, ch] = x @ theta
    z = (theta[0] - 1.0) / se if se > 0 else np.inf
    if abs(z) <= 1.96:
        cand.rank = float(given - z * z)
        cand.caveat = (f"It matches the known constant within its 95 % interval (scale {theta[0]:.4g} +- "
                       f"{1.96 * se:.2g}, fitted jointly with each hold's fixture tilt): evidence with zero free "
                       "parameters.")
    else:  # ranked with its free scale, by the statistic the ranking used
        cand.rank, cand.caveat, cand.stat = None, "", float(given)
        cand.statistic += " on the holds, given each hold's fixture tilt"
