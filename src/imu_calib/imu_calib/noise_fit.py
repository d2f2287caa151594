"""Five-term noise model fitted to an Allan variance curve, IEEE slope readings, Gauss-Markov alternative.

Model (IEEE Std 952, rate-type signal, SI units)::

    avar(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2

is linear in c = (Q^2, N^2, B^2, K^2, R^2). The fit is generalised least
squares with c >= 0 (``scipy.optimize.nnls`` on whitened columns), iteratively
reweighted: the variance of each Allan-variance point is ``2 avar_model^2 / edf``
(edf from the model's dominant noise type, NIST SP 1065), and the points are
correlated as the fitted spectrum says (:mod:`imu_calib.allan_cov`), so the
covariance of c and the chi-square come from the variance's degrees of freedom,
with no tuned factor.

Term selection by the chi-square: backward elimination drops a term only if
removing it raises the chi-square by less than the 95 % point of chi-square(1)
(a term that never reaches ``min_share`` of the model: the 99.9 % point). A fit
whose chi-square is still far beyond its dof (p < ``MISFIT_P_VALUE``) gets back
the dropped term the residual asks for. A dropped term is "not identifiable
from this record": it keeps the 95 % upper bound of the last fit that had it.
``fit_quality`` reports the verdict (good / poor) with chi-square, dof, p-value.

Real curves have bumps no term explains (vibration, temperature); when the
fit of all terms is beyond its dof, a relative model-error floor is added to
every point's sigma (found so that the reduced chi-square is 1), which keeps
the few precise short-tau points from dictating the fit and widens the
intervals honestly; ``fit_quality`` then says ``poor``.

Given the samples (``fit_noise(..., samples=x)``, as the pipeline does), the
long-cluster-time terms (B, K, R) are chosen on the exact Gaussian likelihood of
the samples and the kept terms re-estimated by maximum likelihood
(:mod:`imu_calib.whittle`), whose Fisher information gives the intervals; the
Allan fit chooses Q and N, checks the choice against the curve, and stays the
fallback where the five-term model misfits.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from imu_calib.allan import (ALPHA_FLICKER_FM, ALPHA_RW_FM, ALPHA_WHITE_FM, ALPHA_WHITE_PM, AllanDeviation,
                             edf_overlapping)
from imu_calib.allan_cov import allan_correlation, flicker_avar
from imu_calib.intervals import Z95, chi2_interval, profile_bound, rival_bounds
from imu_calib.synthetic import FLICKER_LEVEL, gm_avar
from imu_calib.whittle import VARIANCE_TERMS, WHITTLE_TERMS, WhittleProblem

TERMS = ("Q", "N", "B", "K", "R")
"""Term names: quantization, white noise, bias instability, rate random walk, rate ramp."""
SCHEMA_NAMES = {"Q": "quantization", "N": "white_noise", "B": "bias_instability", "K": "rate_random_walk",
                "R": "rate_ramp"}
_POWERS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
_FACTORS = np.array([3.0, 1.0, FLICKER_LEVEL, 1.0 / 3.0, 0.5])
_ALPHAS = np.array([ALPHA_WHITE_PM, ALPHA_WHITE_FM, ALPHA_FLICKER_FM, ALPHA_RW_FM, ALPHA_RW_FM])
MISFIT_P_VALUE = 1e-3
"""A fit whose generalised chi-square has a p-value below this is far beyond its dof: poor."""
DROP_CHI2 = 3.841458820694124
"""A term is dropped only if removing it raises the chi-square by less than the 95 % point of chi-square(1)."""
DROP_CHI2_NEGLIGIBLE = 10.827566170662733
"""... or, for a term below ``min_share`` of the model everywhere and for a rate ramp, by less than the 99.9 %
point: one record's random walk often looks like a ramp, so a ramp must be overwhelming to be kept."""
NOT_IDENTIFIABLE = "not identifiable from this record"
SHORT_TAU_TERMS, LONG_TAU_TERMS = ("Q", "N"), ("B", "K")
GM_PENALTY = 4.0
"""A Gauss-Markov bias replaces flicker only if chi2 drops by more than GM_PENALTY * ln(points)."""


@dataclass
class NoiseFit:
    """Fitted coefficients of one axis (SI), 95 % intervals, goodness of fit, alternatives."""

    values: dict
    """Term -> coefficient (Q, N, B, K, R); 0 for a dropped term."""
    intervals: dict
    """Term -> (low, high) 95 % interval; (0, bound covering every term set the data do not reject) for a dropped term."""
    kept: tuple
    chi2_reduced: float
    n_points: int
    bias_correlation_time: float = 0.0
    """> 0 when a Gauss-Markov bias fits better than flicker (then B is its sigma)."""
    model_error: float = 0.0
    """Relative model-error floor added to each point's sigma when the terms cannot explain the data."""
    slope_readings: dict = field(default_factory=dict)
    gauss_markov: dict = field(default_factory=dict)
    estimator: str = "avar_wls"
    """``likelihood`` when the values and intervals come from the ML refinement on the samples, else ``avar_wls``."""
    upper_bounds: dict = field(default_factory=dict)
    """Dropped term -> 95 % upper bound of its coefficient (from the last fit that included it)."""
    fit_quality: dict = field(default_factory=dict)
    """Verdict ``good`` / ``poor`` with the generalised chi-square, its dof and p-value (see _quality)."""

    def identifiable(self, term: str) -> bool:
        """Whether the record shows ``term`` (kept by the selection); else only ``upper_bounds[term]`` is known."""
        return term in self.kept

    def reported_value(self, term: str) -> float:
        """The estimate of a kept term, else its 95 % upper bound: never 0 for a term that was fitted."""
        return self.values[term] if term in self.kept else float(self.upper_bounds.get(term, 0.0))

    def avar(self, taus) -> np.ndarray:
        """Model Allan variance at ``taus`` s."""
        return sum(self.term_avar(t, taus) for t in TERMS)

    def term_avar(self, term: str, taus) -> np.ndarray:
        """Allan variance of one fitted term at ``taus`` s (the GM law when the bias is Gauss-Markov)."""
        taus = np.asarray(taus, dtype=float)
        if term == "B" and self.bias_correlation_time > 0:
            return gm_avar(taus, self.values["B"], self.bias_correlation_time)
        i = TERMS.index(term)
        return _FACTORS[i] * self.values[term] ** 2 * taus ** _POWERS[i]

    def summary(self) -> dict:
        """Plain mapping for the sensor-model ``info`` field."""
        status = {t: ("estimated" if t in self.kept else NOT_IDENTIFIABLE) for t in TERMS
                  if t in self.kept or t in self.upper_bounds}
        return {"terms_kept": list(self.kept), "terms": status, "fit_quality": self.fit_quality,
                "chi2_reduced": float(self.chi2_reduced),
                "n_points": int(self.n_points), "relative_model_error": float(self.model_error),
                "estimator": self.estimator, "ieee_slope_readings": self.slope_readings,
                "gauss_markov_alternative": self.gauss_markov}


def design(taus, terms=TERMS, tau_c: float = 0.0, flicker=None) -> np.ndarray:
    """Columns f_i(tau) so that avar = design @ c, c = coefficient^2; B is Gauss-Markov if tau_c > 0, else
    flicker: ``flicker`` (the sampled law per unit B^2 at ``taus``, imu_calib.allan_cov.flicker_avar) or the
    flat (2 ln 2 / pi)."""
    idx = [TERMS.index(t) for t in terms]
    taus = np.asarray(taus, dtype=float)
    F = _FACTORS[idx] * taus[:, None] ** _POWERS[idx]
    if tau_c > 0 and "B" in terms:
        F[:, list(terms).index("B")] = gm_avar(taus, 1.0, tau_c)
    elif flicker is not None and "B" in terms:
        F[:, list(terms).index("B")] = flicker
    return F


def _irls(F, avar_hat, edf_fn, alphas_of_terms, floor: float, n_iter: int = 6):
    """IRLS non-negative WLS; point variance 2 model^2 / edf + (floor * model)^2.

    Returns c, the sampling sd of each point (model-based), the model-error sd of each point, chi2.
    """
    sd_stat = avar_hat * np.sqrt(2.0 / edf_fn(np.full(len(avar_hat), ALPHA_WHITE_FM)))
    sd_floor = floor * avar_hat
    c = np.zeros(F.shape[1])
    for _ in range(n_iter):
        sigma = np.hypot(sd_stat, sd_floor)
        scale = np.maximum(np.abs(F / sigma[:, None]).max(axis=0), 1e-300)
        c = optimize.nnls(F / sigma[:, None] / scale, avar_hat / sigma)[0] / scale
        model = F @ c
        if not np.all(model > 0):
            break
        alphas = alphas_of_terms[np.argmax(F * c, axis=1)]
        sd_stat, sd_floor = model * np.sqrt(2.0 / edf_fn(alphas)), floor * model
    sigma = np.hypot(sd_stat, sd_floor)
    chi2 = float(np.sum(((avar_hat - F @ c) / sigma) ** 2))
    return c, sd_stat, sd_floor, chi2


@dataclass
class _Fit:
    """One WLS fit: c, its covariance (sandwich), chi2, and what the point correlation does to both."""

    c: np.ndarray
    cov: np.ndarray
    chi2: float
    kappa: np.ndarray
    """Per term: sandwich variance / naive WLS variance (> 1 when correlated points repeat one another)."""
    scale: float = 1.0
    dof: float = 1.0
    """Satterthwaite law of the chi2: chi2 / scale ~ chi-square(dof) under the model."""

    def p_value(self) -> float:
        return float(stats.chi2.sf(self.chi2 / self.scale, self.dof))


def _sandwich(F, sd_stat, sd_floor, corr):
    """Covariance of the WLS c, kappa per term, and the Satterthwaite scale and dof of its chi2."""
    sigma = np.hypot(sd_stat, sd_floor)
    A = F / sigma[:, None]
    bread = np.linalg.pinv(A.T @ A)
    # whitened points' covariance: correlated sampling part plus independent model error
    S = (corr * np.outer(sd_stat, sd_stat) if corr is not None else np.diag(sd_stat ** 2)) + np.diag(sd_floor ** 2)
    S = S / np.outer(sigma, sigma)
    cov = bread @ A.T @ S @ A @ bread
    naive = np.maximum(np.diag(bread), 1e-300)
    kappa = np.maximum(np.diag(cov) / naive, 1.0)
    resid_op = np.eye(len(sigma)) - A @ bread @ A.T
    lam = np.linalg.eigvalsh(resid_op @ S @ resid_op)
    lam = lam[lam > 1e-12 * max(lam.max(), 1e-300)]
    scale, dof = (float(np.sum(lam ** 2) / np.sum(lam)), float(np.sum(lam) ** 2 / np.sum(lam ** 2))) \
        if len(lam) else (1.0, 1.0)
    return cov, kappa, scale, dof


class _Problem:
    """One axis's Allan variance, the edf law of its points and (once set) their correlation."""

    def __init__(self, adev: AllanDeviation):
        self.taus, self.avar = adev.taus, adev.adev ** 2
        self.n_samples, self.rate_hz = adev.n_samples, adev.rate_hz
        ms = np.round(self.taus * adev.rate_hz)
        self.edf_fn = (lambda alphas: edf_overlapping(adev.n_samples, ms, alphas))
        self.corr = None
        # the flat flicker law is 15 % high at one sample and low near the record length: N would absorb it
        self.flicker = flicker_avar(self.taus, self.n_samples, self.rate_hz)

    def fit(self, terms, tau_c: float, floor: float) -> _Fit:
        """WLS fit of the given terms with the sandwich covariance of the (correlated) points."""
        alphas = _ALPHAS[[TERMS.index(t) for t in terms]]
        F = design(self.taus, terms, tau_c, self.flicker)
        c, sd_stat, sd_floor, chi2 = _irls(F, self.avar, self.edf_fn, alphas, floor)
        cov, kappa, scale, dof = _sandwich(F, sd_stat, sd_floor, self.corr)
        return _Fit(c, cov, chi2, kappa, scale, dof)

    def set_correlation(self, terms, tau_c: float) -> None:
        """Correlate the points with the spectrum of the full fit of ``terms`` (see imu_calib.allan_cov)."""
        c = self.fit(terms, tau_c, 0.0).c
        self.corr = allan_correlation(self.taus, self.n_samples, self.rate_hz, dict(zip(terms, c)), tau_c)

    def dof(self, terms) -> int:
        return max(len(self.taus) - len(terms), 1)

    def floor_for(self, terms, tau_c: float) -> float:
        """Relative model-error floor that brings the reduced chi2 to 1 (0 if the fit is within its dof)."""
        dof = self.dof(terms)
        if self.fit(terms, tau_c, 0.0).p_value() >= MISFIT_P_VALUE:
            return 0.0
        lo, hi = -5.0, 1.0  # log10 of the floor
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.fit(terms, tau_c, 10.0 ** mid).chi2 / dof > 1.0 else (lo, mid)
        return 10.0 ** hi


def fit_noise(adev: AllanDeviation, terms=TERMS, min_share: float = 0.1, try_gauss_markov: bool = True,
              samples=None) -> NoiseFit:
    """Fit the noise terms to one axis of an overlapping Allan deviation (see module doc).

    With ``samples`` (the axis's rate samples the Allan deviation came from) the
    long-cluster-time terms are chosen and the kept terms refined by the likelihood (:func:`refine_whittle`).
    """
    if adev.adev.ndim != 1:
        raise ValueError("fit_noise takes one axis: use AllanDeviation.axis(i)")
    if samples is not None and np.shape(samples) != (adev.n_samples,):
        raise ValueError(f"fit_noise: samples of shape {np.shape(samples)} do not match the Allan deviation's "
                         f"{adev.n_samples} samples of one axis")
    prob = _Problem(adev)
    terms = list(terms)
    tau_c, gm_info = 0.0, {}
    if try_gauss_markov and "B" in terms and len(prob.taus) > 5:
        tau_c, gm_info = _choose_bias_law(prob, terms)
    prob.set_correlation(terms, tau_c)
    floor = prob.floor_for(terms, tau_c)
    kept, upper = _select(prob, terms, tau_c, floor, min_share)
    kept = _add_what_the_residual_asks_for(prob, terms, kept, upper, tau_c, floor)
    if floor > 0 and prob.fit(kept, tau_c, 0.0).p_value() >= MISFIT_P_VALUE:
        # the terms chosen explain the curve within its dof after all: no model error, choose again without
        floor = 0.0
        kept, upper = _select(prob, terms, tau_c, floor, min_share)
        kept = _add_what_the_residual_asks_for(prob, terms, kept, upper, tau_c, floor)
    whittle, covering = None, {}
    if samples is not None and floor == 0 and any(t in WHITTLE_TERMS for t in kept):
        whittle = WhittleProblem(samples, adev.rate_hz, tau_c)
        kept = _whittle_select(prob, whittle, terms, kept, upper, tau_c, covering)
        # the likelihood's choice must still explain the Allan curve within its dof
        kept = _add_what_the_residual_asks_for(prob, terms, kept, upper, tau_c, floor)
    if whittle is None:
        covering = dict(upper)
        rival_bounds(prob, terms, kept, covering, tau_c, floor, DROP_CHI2)
    final = prob.fit(kept, tau_c, floor)
    fit = _make_fit(final.c, final.cov, final.chi2, kept, len(prob.taus))
    for term in TERMS:
        if term not in kept:
            # the interval covers every term set the data do not reject; the reported value (what the filter and
            # the simulator are tuned with) stays the chosen set's bound: the covering one, up to 12x larger on a
            # 20-s record, made the Katwijk rover's filter 25x worse (0.12 -> 3.1 m RMS)
            fit.intervals[term] = (0.0, max(covering.get(term, 0.0), upper.get(term, 0.0)))
            fit.upper_bounds[term] = upper.get(term, 0.0)
    fit.model_error = floor
    fit.fit_quality = _quality(prob, kept, tau_c, floor)
    fit.bias_correlation_time = tau_c if "B" in kept else 0.0
    fit.gauss_markov = gm_info
    fit.slope_readings = ieee_slope_readings(adev)
    if whittle is not None:
        refine_whittle(fit, whittle, adev.rate_hz)
    return fit


def _select(prob: _Problem, terms, tau_c: float, floor: float, min_share: float):
    """Backward elimination on the chi-square rise of removing each term, divided by that term's kappa
    (the adjusted likelihood ratio for correlated points): drop the least needed term while its rise is below
    the 95 % point of chi-square(1) - or, for a ramp or a term that never reaches ``min_share`` of the model,
    the 99.9 % point. Returns the kept terms and the 95 % upper bound of each dropped one."""
    kept, upper = list(terms), {}
    while len(kept) > 1:
        full = prob.fit(kept, tau_c, floor)
        rise = np.array([prob.fit([t for t in kept if t != u], tau_c, floor).chi2 - full.chi2
                         for u in kept]) / full.kappa
        share = _shares(prob, full.c, kept, tau_c)
        strict = (share < min_share) | (np.array(kept) == "R")
        droppable = (rise < DROP_CHI2) | (strict & (rise < DROP_CHI2_NEGLIGIBLE))
        if not np.any(droppable):
            break
        # a ramp the random walk can explain goes first: a walk over one record resembles a ramp, not the reverse
        i = kept.index("R") if "R" in kept and droppable[kept.index("R")] else \
            int(np.flatnonzero(droppable)[np.argmin(rise[droppable])])
        upper[kept[i]] = float(np.sqrt(max(full.c[i], 0.0) + Z95 * np.sqrt(max(full.cov[i, i], 0.0))))
        kept.pop(i)
    return kept, upper


def _add_what_the_residual_asks_for(prob: _Problem, terms, kept, upper, tau_c: float, floor: float):
    """While the fit is far beyond its dof (p < MISFIT_P_VALUE), add back the dropped term that lowers the
    chi-square most, if its adjusted rise exceeds DROP_CHI2."""
    kept = list(kept)
    while True:
        now = prob.fit(kept, tau_c, floor)
        missing = [t for t in terms if t not in kept]
        if not missing or now.p_value() >= MISFIT_P_VALUE:
            return kept
        gains = {}
        for t in missing:
            trial = [u for u in terms if u in kept or u == t]
            with_t = prob.fit(trial, tau_c, floor)
            gains[t] = (now.chi2 - with_t.chi2) / with_t.kappa[trial.index(t)]
        # a ramp comes back last: a walk's drift looks like one in the last few-dof points
        useful = {t: g for t, g in gains.items() if g >= DROP_CHI2}
        if not useful:
            return kept
        best = max((t for t in useful if t != "R"), key=useful.get, default="R")
        kept = [u for u in terms if u in kept or u == best]
        upper.pop(best, None)


def _whittle_select(prob: _Problem, whittle: WhittleProblem, terms, kept, upper, tau_c: float, covering: dict):
    """Settle the long-cluster-time terms (B, K, R) on the samples (more powerful than the Allan points: a
    random walk that one record shows in a few low-frequency coefficients and in its end-to-end drift is judged
    on exactly those). Q and N stay as the Allan fit chose them: their short cluster times carry thousands of
    degrees of freedom there.

    Every subset of B, K, R beside the Allan fit's Q, N is fitted; the one with the least
    ``2 nll + DROP_CHI2 * terms`` (profile likelihood; a ramp costs DROP_CHI2_NEGLIGIBLE) wins: in nested
    pairs that is the likelihood-ratio test at DROP_CHI2, and it also decides between rivals that are not
    nested (flicker, random walk or ramp for a rise seen in few coefficients), where stepwise tests stop early.
    """
    start = _start_values(prob, terms, tau_c)
    base = [t for t in terms if t in kept and t in SHORT_TAU_TERMS]
    candidates = [t for t in terms if t in LONG_TAU_TERMS + ("R",)]
    scored = []
    for size in range(len(candidates) + 1):
        for extra in itertools.combinations(candidates, size):
            subset = _ordered(terms, base + list(extra))
            if not any(t in VARIANCE_TERMS for t in subset):
                continue
            w = whittle.fit(subset, [start[t] for t in subset if t != "R"])
            # a ramp pays the strict penalty: one record's random walk often looks like a ramp (see _select)
            score = 2.0 * w.nll + DROP_CHI2 * len(subset) + (DROP_CHI2_NEGLIGIBLE - DROP_CHI2) * ("R" in subset)
            if np.isfinite(w.nll):
                scored.append((score, subset))
    best = min(scored, key=lambda item: item[0], default=None)
    cur = best[1] if best is not None else [t for t in terms if t in kept]
    rivals = [subset for score, subset in scored if score <= best[0] + DROP_CHI2] if best is not None else [cur]
    for t in terms:
        if t not in cur:
            trial = _ordered(terms, cur + [t])
            f = prob.fit(trial, tau_c, 0.0)
            i = trial.index(t)
            upper[t] = float(np.sqrt(max(f.c[i], 0.0) + Z95 * np.sqrt(max(f.cov[i, i], 0.0))))
            if t in VARIANCE_TERMS:
                covering[t] = profile_bound(whittle, terms, rivals, t, start, upper[t])
        else:
            upper.pop(t, None)
    return cur


def _ordered(terms, subset) -> list:
    return [t for t in terms if t in subset]


def _start_values(prob: _Problem, terms, tau_c: float) -> dict:
    """Squared coefficients to start the likelihood from: the Allan fit of all terms; a term it set to 0
    starts at a tenth of the Allan variance where that term alone would be largest relative to it."""
    c = prob.fit(terms, tau_c, 0.0).c
    F = design(prob.taus, terms, tau_c, prob.flicker)
    return {t: float(c[i]) if c[i] > 0 else float(0.1 * np.min(prob.avar / F[:, i])) for i, t in enumerate(terms)}


def _shares(prob: _Problem, c, kept, tau_c) -> np.ndarray:
    """Largest share of the model each term reaches on the fitted cluster times."""
    F = design(prob.taus, kept, tau_c, prob.flicker)
    model = F @ c
    return np.max(F * c / model[:, None], axis=0) if np.all(model > 0) else np.zeros(len(kept))


def _quality(prob: _Problem, kept, tau_c: float, floor: float) -> dict:
    """The kept terms' fit without the model-error floor: chi2 with its Satterthwaite law, p-value, verdict."""
    f = prob.fit(kept, tau_c, 0.0)
    p = f.p_value()
    good = p >= MISFIT_P_VALUE
    dof = prob.dof(kept)
    note = ("the terms explain the Allan variance within its degrees of freedom" if good else
            f"poor: the five-term model misses features of this curve (reduced chi2 {f.chi2 / dof:.3g}, p = {p:.2g}); "
            f"a relative model error of {floor:.2g} per point widens the intervals")
    return {"verdict": "good" if good else "poor", "chi2": float(f.chi2), "points": int(len(prob.taus)),
            "terms": int(len(kept)), "chi2_scale": f.scale, "chi2_dof": f.dof, "p_value": p, "note": note}


def refine_whittle(fit: NoiseFit, samples, rate_hz: float) -> bool:
    """Replace the kept terms' values and intervals by the maximum-likelihood estimate (in place); True if done.

    Skipped (the Allan fit stays) when the Allan fit needed a model-error floor
    (the five-term spectrum does not describe the data, so a likelihood built on
    it would be overconfident) or when the optimiser does not converge. Intervals
    are Wald intervals of log theta from the Fisher information (theta =
    coefficient^2); the ramp's from the GLS precision of its mean.
    """
    kept = fit.kept
    if fit.model_error > 0 or any(t not in WHITTLE_TERMS for t in kept) or \
            not any(t in VARIANCE_TERMS for t in kept):
        return False
    theta0 = [fit.values[t] ** 2 for t in kept if t != "R"]
    problem = samples if isinstance(samples, WhittleProblem) else \
        WhittleProblem(samples, rate_hz, fit.bias_correlation_time)
    w = problem.fit(kept, theta0)
    if not w.converged or not np.all(np.isfinite(w.theta)):
        return False
    rel_sd = np.minimum(np.sqrt(np.maximum(np.diag(w.cov), 0.0)) / w.theta, 100.0)
    for i, t in enumerate(w.terms):
        fit.values[t] = float(np.sqrt(w.theta[i]))
        fit.intervals[t] = tuple(float(fit.values[t] * np.exp(0.5 * z * rel_sd[i])) for z in (-Z95, Z95))
    if "R" in kept:
        fit.values["R"] = w.ramp
        fit.intervals["R"] = (max(w.ramp - Z95 * w.ramp_sd, 0.0), w.ramp + Z95 * w.ramp_sd)
    fit.estimator = "likelihood"
    return True


def _choose_bias_law(prob: _Problem, terms) -> tuple:
    """Correlation time of a Gauss-Markov bias if it beats flicker by more than GM_PENALTY * ln(points), else 0."""
    chi2_flicker = prob.fit(terms, 0.0, 0.0).chi2
    best = None
    # correlation times near the shortest cluster times would only mimic white noise
    for tau_c in np.geomspace(prob.taus[min(3, len(prob.taus) - 1)], prob.taus[-1] * 10, 32):
        trial = prob.fit(terms, tau_c, 0.0)
        c, chi2 = trial.c, trial.chi2
        if best is None or chi2 < best[0]:
            best = (chi2, tau_c, c)
    chi2_gm, tau_c, c = best
    b = c[list(terms).index("B")]
    chosen = bool(b > 0 and chi2_gm + GM_PENALTY * np.log(len(prob.taus)) < chi2_flicker)
    info = {"sigma": float(np.sqrt(b)), "correlation_time_s": float(tau_c), "chi2": chi2_gm,
            "chi2_flicker": chi2_flicker, "chosen": chosen}
    return (float(tau_c) if chosen else 0.0), info


def _make_fit(c, cov, chi2, kept, n_points) -> NoiseFit:
    values = {t: 0.0 for t in TERMS}
    intervals = {t: (0.0, 0.0) for t in TERMS}
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    for i, t in enumerate(kept):
        values[t] = float(np.sqrt(c[i]))
        intervals[t] = chi2_interval(float(c[i]), float(sd[i]))
    dof = max(n_points - len(kept), 1)
    return NoiseFit(values, intervals, tuple(kept), chi2 / dof, n_points)


def ieee_slope_readings(adev: AllanDeviation) -> dict:
    """Classic readings: N on the -1/2 tangent at 1 s, K on the +1/2 tangent at 3 s, B = min adev / 0.664."""
    taus, dev = adev.taus, adev.adev
    return {"N": float(np.min(dev * np.sqrt(taus))),
            "K": float(np.min(dev / np.sqrt(taus)) * np.sqrt(3.0)),
            "B": float(np.min(dev) / np.sqrt(FLICKER_LEVEL)),
            "N_at_1s": float(np.exp(np.interp(0.0, np.log(taus), np.log(dev)))),
            "K_at_3s": float(np.exp(np.interp(np.log(3.0), np.log(taus), np.log(dev))))}
