"""Five-term noise model fitted to an Allan variance curve, IEEE slope readings, Gauss-Markov alternative.

Model (IEEE Std 952, rate-type signal, SI units)::

    avar(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2

is linear in c = (Q^2, N^2, B^2, K^2, R^2). The fit is weighted least squares
with c >= 0 (``scipy.optimize.nnls``), iteratively reweighted: the
variance of each Allan-variance point is ``2 avar_model^2 / edf`` (edf from the
model's dominant noise type), so weights come from the confidence of each point
and do not bias the fit towards low points. Terms the data do not support are
dropped by backward elimination: a term stays only if its 95 % interval
excludes zero and it contributes at least ``min_share`` of the model somewhere
on the fitted cluster times.

Overlapping Allan-variance points at nearby cluster times are correlated; the
WLS covariance ignores that, so it is multiplied by ``CORRELATION_INFLATION``
(chosen by Monte Carlo on synthetic data, see README) before forming intervals.
Real curves have bumps no term explains (vibration, temperature); when the
reduced chi-square exceeds ``MISFIT_REDUCED_CHI2`` a relative model-error floor
is added to every point's sigma (found so that the reduced chi-square is 1),
which keeps the few precise short-tau points from dictating the fit and widens
the intervals honestly.

Given the samples (``fit_noise(..., samples=x)``, as the pipeline does), the
kept terms are then refined by the Whittle likelihood (:mod:`imu_calib.whittle`),
whose Fisher information gives the intervals without the Monte Carlo factor;
the WLS stays the term selector and the fallback where the model misfits.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from imu_calib.allan import (ALPHA_FLICKER_FM, ALPHA_RW_FM, ALPHA_WHITE_FM, ALPHA_WHITE_PM, AllanDeviation,
                             edf_overlapping)
from imu_calib.synthetic import FLICKER_LEVEL, gm_avar
from imu_calib.whittle import WHITTLE_TERMS, fit_whittle

TERMS = ("Q", "N", "B", "K", "R")
"""Term names: quantization, white noise, bias instability, rate random walk, rate ramp."""
SCHEMA_NAMES = {"Q": "quantization", "N": "white_noise", "B": "bias_instability", "K": "rate_random_walk",
                "R": "rate_ramp"}
_POWERS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
_FACTORS = np.array([3.0, 1.0, FLICKER_LEVEL, 1.0 / 3.0, 0.5])
_ALPHAS = np.array([ALPHA_WHITE_PM, ALPHA_WHITE_FM, ALPHA_FLICKER_FM, ALPHA_RW_FM, ALPHA_RW_FM])
Z95 = 1.959963984540054
MISFIT_REDUCED_CHI2 = 3.0
GM_PENALTY = 4.0
"""A Gauss-Markov bias replaces flicker only if chi2 drops by more than GM_PENALTY * ln(points)."""
CORRELATION_INFLATION = 4.0
"""Variance inflation of the WLS covariance for correlated Allan points (Monte Carlo, README)."""


@dataclass
class NoiseFit:
    """Fitted coefficients of one axis (SI), 95 % intervals, goodness of fit, alternatives."""

    values: dict
    """Term -> coefficient (Q, N, B, K, R); 0 for a dropped term."""
    intervals: dict
    """Term -> (low, high) 95 % interval; (0, upper bound when last fitted) for a dropped term."""
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
    """``whittle`` when the values and intervals come from the likelihood refinement, else ``avar_wls``."""

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
        return {"terms_kept": list(self.kept), "chi2_reduced": float(self.chi2_reduced),
                "n_points": int(self.n_points), "relative_model_error": float(self.model_error),
                "estimator": self.estimator, "ieee_slope_readings": self.slope_readings,
                "gauss_markov_alternative": self.gauss_markov}


def design(taus, terms=TERMS, tau_c: float = 0.0) -> np.ndarray:
    """Columns f_i(tau) so that avar = design @ c, c = coefficient^2; B is Gauss-Markov if tau_c > 0."""
    idx = [TERMS.index(t) for t in terms]
    taus = np.asarray(taus, dtype=float)
    F = _FACTORS[idx] * taus[:, None] ** _POWERS[idx]
    if tau_c > 0 and "B" in terms:
        F[:, list(terms).index("B")] = gm_avar(taus, 1.0, tau_c)
    return F


def _irls(F, avar_hat, edf_fn, alphas_of_terms, floor: float, n_iter: int = 6):
    """IRLS non-negative WLS; point variance 2 model^2 / edf + (floor * model)^2. Returns c, cov, chi2."""
    sigma = avar_hat * np.sqrt(2.0 / edf_fn(np.full(len(avar_hat), ALPHA_WHITE_FM)) + floor ** 2)
    c = np.zeros(F.shape[1])
    for _ in range(n_iter):
        scale = np.maximum(np.abs(F / sigma[:, None]).max(axis=0), 1e-300)
        c = optimize.nnls(F / sigma[:, None] / scale, avar_hat / sigma)[0] / scale
        model = F @ c
        if not np.all(model > 0):
            break
        alphas = alphas_of_terms[np.argmax(F * c, axis=1)]
        sigma = model * np.sqrt(2.0 / edf_fn(alphas) + floor ** 2)
    A = F / sigma[:, None]
    cov = np.linalg.pinv(A.T @ A) * CORRELATION_INFLATION
    chi2 = float(np.sum(((avar_hat - F @ c) / sigma) ** 2))
    return c, cov, chi2


class _Problem:
    """One axis's Allan variance and the edf law of its points."""

    def __init__(self, adev: AllanDeviation):
        self.taus, self.avar = adev.taus, adev.adev ** 2
        ms = np.round(self.taus * adev.rate_hz)
        self.edf_fn = (lambda alphas: edf_overlapping(adev.n_samples, ms, alphas))

    def fit(self, terms, tau_c: float, floor: float):
        """c, cov, chi2 of the given terms."""
        alphas = _ALPHAS[[TERMS.index(t) for t in terms]]
        return _irls(design(self.taus, terms, tau_c), self.avar, self.edf_fn, alphas, floor)

    def floor_for(self, terms, tau_c: float) -> float:
        """Relative model-error floor that brings the reduced chi2 to 1 (0 if the fit is already good)."""
        dof = max(len(self.taus) - len(terms), 1)
        if self.fit(terms, tau_c, 0.0)[2] / dof <= MISFIT_REDUCED_CHI2:
            return 0.0
        lo, hi = -5.0, 1.0  # log10 of the floor
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.fit(terms, tau_c, 10.0 ** mid)[2] / dof > 1.0 else (lo, mid)
        return 10.0 ** hi


def fit_noise(adev: AllanDeviation, terms=TERMS, min_share: float = 0.1, try_gauss_markov: bool = True,
              samples=None) -> NoiseFit:
    """Fit the noise terms to one axis of an overlapping Allan deviation (see module doc).

    With ``samples`` (the axis's rate samples the Allan deviation came from) the
    kept terms are refined by the Whittle likelihood (:func:`refine_whittle`).
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
    floor = prob.floor_for(terms, tau_c)
    kept, upper_of_dropped = list(terms), {}
    while True:
        c, cov, chi2 = prob.fit(kept, tau_c, floor)
        weakest = _weakest_unsupported(prob.taus, c, cov, kept, min_share, tau_c)
        if weakest is None or len(kept) == 1:
            break
        i = kept.index(weakest)
        upper_of_dropped[weakest] = float(np.sqrt(c[i] + Z95 * np.sqrt(max(cov[i, i], 0.0))))
        kept.remove(weakest)
    fit = _make_fit(c, cov, chi2, kept, len(prob.taus))
    for term, upper in upper_of_dropped.items():
        fit.intervals[term] = (0.0, upper)
    fit.model_error = floor
    fit.bias_correlation_time = tau_c if "B" in kept else 0.0
    fit.gauss_markov = gm_info
    fit.slope_readings = ieee_slope_readings(adev)
    if samples is not None:
        refine_whittle(fit, samples, adev.rate_hz)
    return fit


def refine_whittle(fit: NoiseFit, samples, rate_hz: float) -> bool:
    """Replace the kept terms' values and intervals by the Whittle ML estimate (in place); True if done.

    Skipped (the Allan fit stays) when the Allan fit needed a model-error floor
    (the five-term spectrum does not describe the data, so a likelihood built on
    it would be overconfident), when a rate ramp is kept (deterministic, not in
    the likelihood) or when the optimiser does not converge. Intervals are Wald
    intervals of log theta from the Fisher information: theta = coefficient^2.
    """
    kept = fit.kept
    if fit.model_error > 0 or any(t not in WHITTLE_TERMS for t in kept):
        return False
    theta0 = [fit.values[t] ** 2 for t in kept]
    w = fit_whittle(samples, rate_hz, kept, theta0, fit.bias_correlation_time)
    if not w.converged or not np.all(np.isfinite(w.theta)):
        return False
    rel_sd = np.sqrt(np.maximum(np.diag(w.cov), 0.0)) / w.theta
    for i, t in enumerate(kept):
        fit.values[t] = float(np.sqrt(w.theta[i]))
        fit.intervals[t] = tuple(float(fit.values[t] * np.exp(0.5 * z * rel_sd[i])) for z in (-Z95, Z95))
    fit.estimator = "whittle"
    return True


def _choose_bias_law(prob: _Problem, terms) -> tuple:
    """Correlation time of a Gauss-Markov bias if it beats flicker by more than GM_PENALTY * ln(points), else 0."""
    chi2_flicker = prob.fit(terms, 0.0, 0.0)[2]
    best = None
    # correlation times near the shortest cluster times would only mimic white noise
    for tau_c in np.geomspace(prob.taus[min(3, len(prob.taus) - 1)], prob.taus[-1] * 10, 32):
        c, _, chi2 = prob.fit(terms, tau_c, 0.0)
        if best is None or chi2 < best[0]:
            best = (chi2, tau_c, c)
    chi2_gm, tau_c, c = best
    b = c[list(terms).index("B")]
    chosen = bool(b > 0 and chi2_gm + GM_PENALTY * np.log(len(prob.taus)) < chi2_flicker)
    info = {"sigma": float(np.sqrt(b)), "correlation_time_s": float(tau_c), "chi2": chi2_gm,
            "chi2_flicker": chi2_flicker, "chosen": chosen}
    return (float(tau_c) if chosen else 0.0), info


def _weakest_unsupported(taus, c, cov, kept, min_share, tau_c):
    """The least significant term that is unsupported (interval touches 0 or negligible share), or None."""
    F = design(taus, kept, tau_c)
    model = F @ c
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    share = np.max(F * c / model[:, None], axis=0) if np.all(model > 0) else np.zeros(len(kept))
    significance = np.where(sd > 0, c / np.where(sd > 0, sd, 1.0), np.inf)
    bad = (c - Z95 * sd <= 0) | (share < min_share)
    if not np.any(bad):
        return None
    candidates = np.flatnonzero(bad)
    return kept[candidates[np.argmin(significance[candidates])]]


def _make_fit(c, cov, chi2, kept, n_points) -> NoiseFit:
    values = {t: 0.0 for t in TERMS}
    intervals = {t: (0.0, 0.0) for t in TERMS}
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    for i, t in enumerate(kept):
        values[t] = float(np.sqrt(c[i]))
        intervals[t] = (float(np.sqrt(max(c[i] - Z95 * sd[i], 0.0))), float(np.sqrt(c[i] + Z95 * sd[i])))
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
