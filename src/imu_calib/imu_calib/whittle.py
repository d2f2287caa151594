"""Maximum-likelihood fit of the noise terms: the exact Gaussian likelihood of the differenced rate in its sine basis.

The rate-type signal x (rad/s or m/s^2, n samples) is differenced once, which
makes every term stationary: the random walk becomes white, white noise an
MA(1), the quantization error an MA(2), a rate ramp the constant mean
``mu = R dt``. The covariance of the m = n - 1 differences of white noise plus
a random walk is a symmetric tridiagonal Toeplitz matrix, which the orthonormal
DST-I diagonalises exactly: the sine coefficients ``z_k`` (k = 1..m, frequency
k fs / 2n) are independent, ``z_k ~ N(0, lambda_k)`` with::

    lambda_k = sum_t theta_t P_t(k),   P_N = 4 fs sin^2(pi k / 2n),   P_K = dt

and theta = (Q^2, N^2, B^2, K^2). So for N and K (the cases where a random
walk must be told from white noise) the likelihood below is the exact
likelihood of the record, with its initial level unknown; no taper, no
asymptotics, and the record's end-to-end drift (the walk's strongest single
piece of evidence) stays in. For the other terms ``P_t(k) = E z_k^2`` is still
exact (from the term's autocovariance, :func:`expected_power`) but the
coefficients are then only nearly independent (quantization: a rank-2 edge
correction; flicker and Gauss-Markov: a debiased Whittle approximation in the
sine basis, Sykulski et al. 2019).

A rate ramp is the mean of the differences, a fixed effect: it is profiled out
(generalised least squares on the DST of a constant, ``u``), and the variance
terms of a model with a ramp are estimated by REML (the 1-dof correction
``0.5 log u' Lambda^-1 u``); models are compared on the profile likelihood.

Negative log-likelihood ``0.5 sum_k (log lambda_k + z_k^2 / lambda_k)``,
minimised by Fisher scoring in log theta with a backtracking line search (run
to convergence: the likelihood of a long record is a sum of ~1e6 terms, so a
relative function tolerance stops a quasi-Newton method at its start).
Covariance: the inverse Fisher information ``0.5 sum_k P_a P_b / lambda_k^2``.
Above the lowest ``SINGLE_BINS`` coefficients they are pooled in groups 1 %
wide in frequency, where every lambda is nearly constant, which makes each fit
cheap. :func:`cramer_rao_relative_sd` gives the bound from the same Fisher
information (all coefficients, no pooling).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft

WHITTLE_TERMS = ("Q", "N", "B", "K", "R")
"""Terms the likelihood models: four variance terms and the rate ramp (the differences' mean)."""
VARIANCE_TERMS = ("Q", "N", "B", "K")
PROFILE_UPPER_LEVEL = 2.705543454095404
"""chi-square(1) 90 % point: a profile-likelihood rise this large bounds a coefficient at one-sided 95 %."""
SINGLE_BINS = 512
"""The lowest sine coefficients enter one by one; above them they are pooled in groups of at most 1 % in frequency."""


@dataclass
class WhittleFit:
    """Squared coefficients ``theta`` of the variance ``terms``, their covariance, the ramp, the optimiser's status."""

    terms: tuple
    theta: np.ndarray
    cov: np.ndarray
    converged: bool
    n_bins: int
    nll: float = float("nan")
    """Negative profile log-likelihood at the estimate (up to a constant shared by fits of one record)."""
    ramp: float = 0.0
    """|R| (unit/s^2) when the ramp is among the fitted terms, else 0."""
    ramp_sd: float = 0.0
    iterations: int = 0


def fast_length_below(n: int) -> int:
    """Largest length <= n whose FFT is fast (5-smooth): the record is cut to it (a prime length is 100x slower)."""
    m = n
    while fft.next_fast_len(m) != m:
        m -= 1
    return m


def _acov_differenced(term: str, m: int, rate_hz: float, tau_c: float) -> np.ndarray:
    """Autocovariance, lags 0..m-1, of the differenced samples of one term with unit squared coefficient."""
    c = np.zeros(m)
    fs = rate_hz
    if term == "N":  # white rate of variance fs: differenced -> MA(1)
        c[:2] = [2.0 * fs, -fs]
    elif term == "K":  # random walk: differenced -> white of variance dt
        c[0] = 1.0 / fs
    elif term == "Q":  # angle rounding error of variance Q^2, differenced twice and scaled by fs
        c[:3] = np.array([6.0, -4.0, 1.0])[: min(3, m)] * fs ** 2
    elif term == "B" and tau_c > 0:  # Gauss-Markov of unit variance
        phi = np.exp(-1.0 / (fs * tau_c))
        g = phi ** np.arange(m + 1.0)
        c = 2.0 * g[:m] - g[1:m + 1] - np.concatenate(([g[1]], g[:m - 1]))
    elif term == "B":
        c = _flicker_acov_differenced(m, fs)
    else:
        raise ValueError(f"the likelihood has no variance term {term!r}")
    return c


def _flicker_acov_differenced(m: int, fs: float) -> np.ndarray:
    """Differenced flicker (B = 1) autocovariance on the generator's grid: one-sided PSD 1/(pi f) sinc^2 from fs/2m."""
    size = fft.next_fast_len(2 * m, real=True)
    k = np.arange(size // 2 + 1)
    f = k * fs / size
    power = np.zeros_like(f)
    # |gain|^2 = S(f) fs / 2 per rfft bin of unit white noise (see synthetic.flicker)
    power[1:] = 1.0 / (np.pi * f[1:]) * fs / 2.0 * np.sinc(f[1:] / fs) ** 2
    power *= 4.0 * np.sin(np.pi * k / size) ** 2
    return fft.irfft(power, size)[:m]


def expected_power(terms, m: int, rate_hz: float, tau_c: float = 0.0) -> np.ndarray:
    """(m, terms) ``E z_k^2`` per unit squared coefficient, z the orthonormal DST-I of m differences, k = 1..m.

    For a stationary series of autocovariance c (lags 0..m-1), exactly::

        E z_k^2 = c_0 + 2/(m+1) sum_tau c_tau [(m+1-tau) cos(a tau) + cot(a) sin(a tau)],  a = pi k/(m+1)

    (the sine products summed over the record), one FFT of length 2(m+1) per term.
    """
    size = 2 * (m + 1)
    k = np.arange(1, m + 1)
    a = np.pi * k / (m + 1)
    lags = np.arange(m, dtype=float)
    cols = []
    for term in terms:
        c = _acov_differenced(term, m, rate_hz, tau_c)
        ct = c.copy()
        ct[0] = 0.0
        cos_part = fft.rfft(ct * (m + 1 - lags), size)[1:m + 1].real
        sin_part = -fft.rfft(ct, size)[1:m + 1].imag
        cols.append(c[0] + 2.0 / (m + 1) * (cos_part + sin_part / np.tan(a)))
    return np.column_stack(cols)


def sine_coefficients(x) -> np.ndarray:
    """Orthonormal DST-I of the first differences of ``x`` (no mean removal: a drift is evidence)."""
    return fft.dst(np.diff(np.asarray(x, dtype=float)), type=1, norm="ortho")


def drift_vector(m: int) -> np.ndarray:
    """Orthonormal DST-I of m ones: how a constant mean of the differences (a rate ramp) shows in z."""
    return fft.dst(np.ones(m), type=1, norm="ortho")


def _group_edges(n_bins: int, single: int = SINGLE_BINS, width: float = 0.01) -> np.ndarray:
    """Start indices of the coefficient groups and the end: single ones up to ``single``, then groups of relative
    width ``width``, within which every lambda is nearly constant (all terms are smooth power laws there)."""
    edges = list(range(min(single, n_bins)))
    k = len(edges)
    while k < n_bins:
        edges.append(k)
        k = max(k + 1, int(k * (1.0 + width)))
    edges.append(n_bins)
    return np.array(edges)


class WhittleProblem:
    """One record's sine coefficients (pooled) and each term's expected power, computed once, so that fits of
    several term sets (the term choice in :mod:`imu_calib.noise_fit`) share them."""

    def __init__(self, x, rate_hz: float, tau_c: float = 0.0):
        x = np.asarray(x, dtype=float)
        # DST-I of m differences runs an FFT of 2(m+1) = 2 n: cut the record to a 5-smooth n
        self.x = x[:fast_length_below(len(x))]
        self.m = len(self.x) - 1
        self.rate_hz, self.tau_c = float(rate_hz), float(tau_c)
        z = sine_coefficients(self.x)
        u = drift_vector(self.m)
        self.n_bins = self.m
        self.edges = _group_edges(self.m)
        starts = self.edges[:-1]
        self.counts = np.diff(self.edges).astype(float)
        self.zz = np.add.reduceat(z * z, starts)
        self.zu = np.add.reduceat(z * u, starts)
        self.uu = np.add.reduceat(u * u, starts)
        self._columns: dict = {}

    def column(self, term: str) -> np.ndarray:
        """Expected power per unit squared coefficient of ``term``, averaged over each group (cached)."""
        if term not in self._columns:
            col = expected_power((term,), self.m, self.rate_hz, self.tau_c)[:, 0]
            col = np.add.reduceat(col, self.edges[:-1]) / self.counts
            # round-off leaves ~1e-16 relative negatives where a term has a spectral zero (Q, N at f = 0)
            self._columns[term] = np.maximum(col, 1e-12 * np.max(np.abs(col)))
        return self._columns[term]

    def _nll(self, s, ramp: bool, reml: bool):
        """Negative log-likelihood (profile over the ramp's mean if ``ramp``; REML adds 0.5 log a), the pooled
        residual sums of squares, the ramp's mean and its GLS precision ``a``."""
        zz, mu, a = self.zz, 0.0, 0.0
        if ramp:
            a = float(np.sum(self.uu / s))
            mu = float(np.sum(self.zu / s)) / a
            zz = self.zz - 2.0 * mu * self.zu + mu * mu * self.uu
        value = 0.5 * float(np.sum(self.counts * np.log(s) + zz / s))
        if ramp and reml:
            value += 0.5 * np.log(a)
        return value, zz, mu, a

    def fit(self, terms, theta0, max_iter: int = 100, reml: bool = True, fixed=None) -> WhittleFit:
        """ML (REML with a ramp) squared coefficients of the variance terms among ``terms`` (subset of
        WHITTLE_TERMS, at least one variance term), from start ``theta0`` (one value per variance term);
        ``fixed`` (term -> squared coefficient) adds terms held at those values (a profile likelihood)."""
        terms = tuple(terms)
        s0 = sum((v * self.column(t) for t, v in (fixed or {}).items()), np.zeros(len(self.counts)))
        if any(t not in WHITTLE_TERMS for t in terms) or not any(t in VARIANCE_TERMS for t in terms):
            raise ValueError(f"likelihood terms must be a subset of {WHITTLE_TERMS} with a variance term, got {terms}")
        ramp = "R" in terms
        var_terms = tuple(t for t in terms if t != "R")
        P = np.column_stack([self.column(t) for t in var_terms])
        theta0 = np.asarray(theta0, dtype=float)[:len(var_terms)].copy()
        bad = ~(np.isfinite(theta0) & (theta0 > 0))
        if np.any(bad):  # no usable start (e.g. a kept term the WLS set to 0): a tenth of the most the data allow
            theta0[bad] = 0.1 * np.min((self.zz / self.counts)[:, None] / P[:, bad], axis=0)
        Ps = P * theta0  # scaled so that the start is u = 0 for every term: a well-conditioned problem
        u = np.zeros(len(var_terms))
        f, zz, mu, a = self._nll(Ps @ np.exp(u) + s0, ramp, reml)
        converged, it = False, 0
        for it in range(1, max_iter + 1):
            w = np.exp(u)
            s = Ps @ w + s0
            A = Ps * w / s[:, None]
            r = (self.counts - zz / s)
            grad = 0.5 * (A.T @ r)
            if ramp and reml:
                grad -= 0.5 * (A.T @ (self.uu / s)) / a
            info = 0.5 * (A * self.counts[:, None]).T @ A
            step = -np.linalg.lstsq(info, grad, rcond=1e-12)[0]
            step = np.clip(step, -5.0, 5.0)
            t = 1.0
            while True:  # backtracking (Armijo) line search on the likelihood
                u_new = np.clip(u + t * step, -60.0, 60.0)
                f_new, zz_new, mu_new, a_new = self._nll(Ps @ np.exp(u_new) + s0, ramp, reml)
                if f_new <= f + 1e-4 * t * float(grad @ step) or t < 1e-8:
                    break
                t *= 0.5
            moved = float(np.max(np.abs(u_new - u)))
            u, f, zz, mu, a = u_new, f_new, zz_new, mu_new, a_new
            if moved < 1e-7:
                converged = True
                break
        theta = theta0 * np.exp(u)
        s = P @ theta + s0
        A = P / s[:, None]
        cov = np.linalg.pinv(0.5 * (A * self.counts[:, None]).T @ A)
        nll = self._nll(s, ramp, reml=False)[0]  # models are compared on the profile likelihood
        ramp_value = abs(mu) * self.rate_hz if ramp else 0.0
        ramp_sd = self.rate_hz / np.sqrt(a) if ramp else 0.0
        ok = converged and bool(np.isfinite(nll)) and bool(np.all(np.isfinite(theta)))
        return WhittleFit(var_terms, theta, cov, ok, self.n_bins, float(nll), float(ramp_value), float(ramp_sd), it)


    def profile_upper(self, terms, term: str, theta0, level: float = PROFILE_UPPER_LEVEL, guess: float = 0.0) -> float:
        """Upper bound of ``term``'s squared coefficient (a variance term among ``terms``) from the profile
        likelihood: where twice the negative log-likelihood, the other terms re-fitted, rises ``level`` above its
        minimum (2.706: the one-sided 95 % bound, also at the boundary theta = 0). ``theta0``: start values as
        for :meth:`fit`, ``guess`` a value near the bound (where the search starts). The Wald interval of a term
        near zero is not one; this is (Wilks, and Self & Liang)."""
        terms = tuple(terms)
        best = self.fit(terms, theta0, reml=False)
        var_terms = [t for t in terms if t != "R"]
        i = var_terms.index(term)
        others = tuple(t for t in terms if t != term)
        start = [v for t, v in zip(var_terms, best.theta) if t != term]

        def rise(v):
            return 2.0 * (self.fit(others, start, reml=False, fixed={term: v}).nll - best.nll) - level

        # a bracket from the estimate (the rise is below the level there) up, then bisection in log
        lo = max(float(best.theta[i]), 1e-12 * float(np.max(self.zz / self.counts / self.column(term))))
        hi = max(4.0 * lo, guess)
        for _ in range(60):
            if rise(hi) > 0:
                break
            lo, hi = hi, 4.0 * hi
        for _ in range(40):
            mid = np.sqrt(lo * hi)
            lo, hi = (mid, hi) if rise(mid) < 0 else (lo, mid)
            if hi / lo < 1.01:
                break
        return float(hi)


def fit_whittle(x, rate_hz: float, terms, theta0, tau_c: float = 0.0, max_iter: int = 100) -> WhittleFit:
    """ML squared coefficients of the variance ``terms`` (subset of WHITTLE_TERMS) for rate samples ``x``."""
    return WhittleProblem(x, rate_hz, tau_c).fit(terms, theta0, max_iter)


def fisher_information(n: int, rate_hz: float, terms, coefficients, tau_c: float = 0.0) -> np.ndarray:
    """Fisher information of theta = coefficient^2 of the variance ``terms`` for n samples (every coefficient)."""
    theta = np.asarray(coefficients, dtype=float) ** 2
    P = expected_power(tuple(terms), n - 1, rate_hz, tau_c)
    A = P / (P @ theta)[:, None]
    return 0.5 * A.T @ A


def cramer_rao_relative_sd(n: int, rate_hz: float, terms, coefficients, tau_c: float = 0.0) -> np.ndarray:
    """Relative sd of each coefficient (not squared) that the likelihood's Fisher information allows for n
    samples: exact for white noise, random walk and quantization, the sine-basis Whittle approximation for B."""
    theta = np.asarray(coefficients, dtype=float) ** 2
    cov = np.linalg.inv(fisher_information(n, rate_hz, terms, coefficients, tau_c))
    return 0.5 * np.sqrt(np.diag(cov)) / theta
