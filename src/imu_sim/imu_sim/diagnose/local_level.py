"""Exact likelihood of block means under white noise plus a bias random walk (the local-level model).

Block means y_k (interval tb s) of white rate noise plus a rate random walk K are exactly a
local-level model: y_k = mu_k + e_k, mu_k = mu_{k-1} + w_k, var w = q = K^2 tb, var e = h.
(Their first differences are MA(1) with spectral density q at zero frequency whatever the
averaging, so K = sqrt(q / tb) holds for continuous and sampled walks; the averaging only
moves h.) The Kalman filter with a diffuse initial level gives the exact Gaussian likelihood
with the turn-on bias a nuisance parameter, with no detrending or end-effect to correct
(the Whittle test on detrended block means loses the end-to-end drift and underestimates K;
on differences it meets a spectral zero). The scale h is concentrated out, so the likelihood
is a function of the ratio r = q / h only, evaluated on a grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

RATIO_DECADES = (-9.0, 1.0)
"""Grid of q/h ratios (log10 range) besides 0; a walk stronger than 10 x the white noise per block is not concealed."""
PER_DECADE = 40
CHI2_1_95 = 3.841


DIFFUSE = 1e9
"""Initial level variance in units of h: the turn-on bias is a nuisance (its innovation is not scored)."""


@njit(cache=True)
def _filter(y, ratios, start, gm_vars, phi):
    """Per (ratio, gm_var) pair: sums of v^2/F and of log F over innovations k >= max(1, start), white variance h = 1.

    State: the walking level (step variance ``ratio``) and a Gauss-Markov bias (AR(1) factor ``phi``,
    stationary block variance ``gm_var``, both in units of h; 0 for none).
    """
    nr = len(ratios)
    ss = np.zeros(nr)
    lf = np.zeros(nr)
    for j in range(nr):
        r = ratios[j]
        gm_var = gm_vars[j]
        qg = gm_var * (1.0 - phi * phi)
        a0 = y[0]
        a1 = 0.0
        p00 = DIFFUSE
        p01 = 0.0
        p11 = gm_var
        s = 0.0
        l = 0.0
        for k in range(len(y)):
            f = p00 + 2.0 * p01 + p11 + 1.0
            v = y[k] - a0 - a1
            if k >= start and k >= 1:
                s += v * v / f
                l += np.log(f)
            g0 = (p00 + p01) / f
            g1 = (p01 + p11) / f
            a0 += g0 * v
            a1 += g1 * v
            n00 = p00 - g0 * (p00 + p01)
            n01 = p01 - g0 * (p01 + p11)
            n11 = p11 - g1 * (p01 + p11)
            p00 = n00 + r
            p01 = phi * n01
            p11 = phi * phi * n11 + qg
            a1 = phi * a1
        ss[j] = s
        lf[j] = l
    return ss, lf


def loglik(y: np.ndarray, ratios, gm_var=0.0, phi: float = 0.0) -> tuple:
    """(concentrated log-likelihood, h estimate) per walk ratio / GM block variance (arrays broadcast) of y (n,)."""
    y = np.ascontiguousarray(y, dtype=float)
    ratios, gm_var = np.broadcast_arrays(np.asarray(ratios, dtype=float), np.asarray(gm_var, dtype=float))
    ss, lf = _filter(y, np.array(ratios), 1, np.array(gm_var), float(phi))
    m = len(y) - 1
    h = ss / m
    return -0.5 * (m * (np.log(2 * np.pi * np.maximum(h, 1e-300)) + 1.0) + lf), h


def ratio_grid(q_min_ratio: float = 0.0) -> np.ndarray:
    """0 (or the floor ratio) followed by the log grid above it."""
    grid = np.logspace(*RATIO_DECADES, int(PER_DECADE * (RATIO_DECADES[1] - RATIO_DECADES[0])) + 1)
    return np.concatenate([[q_min_ratio], grid[grid > q_min_ratio]])


@dataclass
class Background:
    """Noise the model already has besides white noise, in units of its white block variance."""

    gm_var: float = 0.0
    """Stationary variance of its Gauss-Markov bias at block level, over the white block variance."""
    phi: float = 0.0
    """Block-to-block correlation of that bias, exp(-tb / correlation time)."""
    rw_ratio: float = 0.0
    """Its random walk's q / h (a floor for the fitted walk)."""


@dataclass
class RandomWalkFit:
    """K (unit/s/sqrt(s)) with its 95 % profile interval, the likelihood ratio against the background, h, r."""

    k: float
    k_interval: tuple
    lr: float
    h: float
    ratio: float


def fit(y: np.ndarray, tb: float, bg: Background = Background()) -> RandomWalkFit:
    """Profile-likelihood fit of K to block means y (n,) of interval tb s (K no smaller than the background's)."""
    ratios = ratio_grid(bg.rw_ratio)
    ll, h = loglik(y, ratios, bg.gm_var, bg.phi)
    best = int(np.argmax(ll))
    k = np.sqrt(ratios * h / tb)
    lo = float(k[0]) if 2 * (ll[best] - ll[0]) <= CHI2_1_95 else _edge(k, ll, best, -1)
    hi = _edge(k, ll, best, +1)
    return RandomWalkFit(float(k[best]), (min(lo, float(k[best])), max(hi, float(k[best]))),
                         float(max(2 * (ll[best] - ll[0]), 0.0)), float(h[best]), float(ratios[best]))


def _edge(k, ll, best, step) -> float:
    """K where 2 (ll_best - ll) crosses the 95 % level going from ``best`` in direction ``step``, log-interpolated."""
    drop = 2 * (ll[best] - ll)
    i = best
    while 0 <= i + step < len(k) and drop[i + step] <= CHI2_1_95:
        i += step
    j = i + step
    if not 0 <= j < len(k) or k[j] <= 0 or k[i] <= 0:
        return float(k[i])
    w = (CHI2_1_95 - drop[i]) / max(drop[j] - drop[i], 1e-300)
    return float(np.exp(np.log(k[i]) + w * (np.log(k[j]) - np.log(k[i]))))


def predictive_deviance(y: np.ndarray, ratio: float, h: float, start: int, bg: Background = Background()) -> float:
    """Mean one-step-ahead deviance (v^2/F + log 2 pi F) of blocks k >= start, the filter run from the series start."""
    y = np.ascontiguousarray(y, dtype=float)
    ss, lf = _filter(y, np.array([ratio]), start, np.array([bg.gm_var]), bg.phi)
    m = len(y) - max(start, 1)
    return float((ss[0] / h + lf[0] + m * np.log(2 * np.pi * h)) / m)


def block_gm_variance(tau_s: float, tb: float) -> float:
    """Variance of a block mean (interval tb s) of a unit-variance Gauss-Markov process of correlation time tau_s."""
    x = tau_s / tb
    return 2 * x * (1 - x * (1 - np.exp(-1.0 / x)))


@dataclass
class GaussMarkovFit:
    """sigma (unit) and correlation time (s) with 95 % profile intervals, the LR against the background, h, r."""

    sigma: float
    sigma_interval: tuple
    tau: float
    tau_interval: tuple
    lr: float
    h: float
    gm_var: float
    phi: float


def fit_gauss_markov(y: np.ndarray, tb: float, taus, bg: Background = Background()) -> GaussMarkovFit:
    """Profile-likelihood fit of a Gauss-Markov bias (sigma, tau on the grid ``taus`` s) over a background walk."""
    grid = np.concatenate([[0.0], np.logspace(-4, 3, 141)])
    ll0, _ = loglik(y, [bg.rw_ratio], 0.0)
    rows = []
    for tau in taus:
        phi = float(np.exp(-tb / tau))
        ll, h = loglik(y, bg.rw_ratio, grid, phi)
        rows.append((ll, h, phi, tau))
    lls = np.array([r[0] for r in rows])
    i, j = np.unravel_index(np.argmax(lls), lls.shape)
    best = lls[i, j]
    inside = 2 * (best - lls) <= CHI2_1_95
    sig2 = np.array([grid * r[1] / block_gm_variance(r[3], tb) for r in rows])
    tau_in = [rows[k][3] for k in range(len(rows)) if inside[k].any()]
    ll_best, h_best, phi_best, tau_best = rows[i]
    return GaussMarkovFit(float(np.sqrt(sig2[i, j])), (float(np.sqrt(sig2[inside].min())), float(np.sqrt(sig2[inside].max()))),
                          float(tau_best), (float(min(tau_in)), float(max(tau_in))), float(max(2 * (best - ll0[0]), 0.0)),
                          float(h_best[j]), float(grid[j]), phi_best)
