"""Maximum-likelihood refinement of the noise terms: debiased Whittle likelihood of the differenced rate.

The rate-type signal (rad/s or m/s^2) is differenced once, which makes every
term stationary (the random walk becomes white, the ramp a constant that the
mean removal takes away). The expected periodogram of the differenced series
is linear in the squared coefficients ``theta = (Q^2, N^2, B^2, K^2)``::

    E I(f_j) = sum_t theta_t P_t(f_j)

with ``P_t`` computed exactly from each term's autocovariance and the
triangular (Fejer) weight of a finite record ("debiased Whittle", Sykulski et
al. 2019), so leakage and the finite record need no asymptotic correction. The
negative log-likelihood ``sum_j log E I_j + I_j / E I_j`` over the Fourier
frequencies 0 < f_j < fs/2 is minimised in log theta (L-BFGS-B, analytic
gradient), seeded by the Allan-variance fit. Covariance: the inverse Fisher
information ``sum_j P_a P_b / (E I_j)^2`` (the periodogram ordinates are nearly
independent, each exponential), times the taper's variance inflation ``n sum h^4``.
The differences are Tukey-tapered (10 %): without a taper the record's end
values enter every low-frequency ordinate as one shared term, so the ordinates
are not independent there and the K estimate loses a third of its precision. Flicker uses the synthetic generator's
spectrum ``B^2 / (pi f) sinc^2(f/fs)`` (one-sided), a Gauss-Markov bias its
exponential autocovariance at a fixed correlation time.

:class:`WhittleProblem` keeps one record's periodogram and the columns per term,
so fits of several term sets (the term choice in :mod:`imu_calib.noise_fit`)
share them; above the lowest ``SINGLE_BINS`` ordinates the bins are pooled in
groups 1 % wide in frequency, where every expected ordinate is nearly constant
(``m log s + sum I / s`` per group), which makes each fit cheap.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft, optimize, signal

WHITTLE_TERMS = ("Q", "N", "B", "K")
"""Terms the likelihood models (a rate ramp is deterministic and differenced away)."""
TAPER_ALPHA = 0.1
"""Tukey taper fraction: the untapered record's end effect is one term shared by all low bins (see README)."""


@dataclass
class WhittleFit:
    """Squared coefficients ``theta`` of ``terms``, their covariance, and the optimiser's status."""

    terms: tuple
    theta: np.ndarray
    cov: np.ndarray
    converged: bool
    n_bins: int
    nll: float = float("nan")
    """Negative log-likelihood at the estimate (up to a constant shared by fits of one record)."""


def _acov_differenced(term: str, n: int, rate_hz: float, tau_c: float) -> np.ndarray:
    """Autocovariance, lags 0..n-1, of the differenced samples of one term with unit squared coefficient."""
    c = np.zeros(n)
    fs = rate_hz
    if term == "N":  # white rate of variance fs: differenced -> MA(1)
        c[:2] = [2.0 * fs, -fs]
    elif term == "K":  # random walk: differenced -> white of variance dt
        c[0] = 1.0 / fs
    elif term == "Q":  # angle rounding error of variance Q^2, differenced twice and scaled by fs
        c[:3] = np.array([6.0, -4.0, 1.0])[: min(3, n)] * fs ** 2
    elif term == "B" and tau_c > 0:  # Gauss-Markov of unit variance
        phi = np.exp(-1.0 / (fs * tau_c))
        lags = np.arange(n + 1.0)
        g = phi ** lags
        c = 2.0 * g[:n] - g[1:n + 1] - np.concatenate(([g[1]], g[:n - 1]))
    elif term == "B":
        c = _flicker_acov_differenced(n, fs)
    else:
        raise ValueError(f"Whittle likelihood has no term {term!r}")
    return c


def fast_length_below(n: int) -> int:
    """Largest length <= n whose FFT is fast (5-smooth): the record is cut to it (an odd prime length is 100x slower)."""
    m = n
    while fft.next_fast_len(m) != m:
        m -= 1
    return m


def _flicker_acov_differenced(n: int, fs: float) -> np.ndarray:
    """Differenced flicker (B = 1) autocovariance on the generator's grid: one-sided PSD 1/(pi f) sinc^2, f >= ~fs/2n."""
    size = fft.next_fast_len(2 * n, real=True)
    k = np.arange(size // 2 + 1)
    f = k * fs / size
    power = np.zeros_like(f)
    # |gain|^2 = S(f) fs / 2 per rfft bin of unit white noise (see synthetic.flicker)
    power[1:] = 1.0 / (np.pi * f[1:]) * fs / 2.0 * np.sinc(f[1:] / fs) ** 2
    power *= 4.0 * np.sin(np.pi * k / size) ** 2
    return fft.irfft(power, size)[:n]


def taper(n: int, alpha: float = TAPER_ALPHA) -> np.ndarray:
    """Tukey taper of n points, unit energy (sum of squares 1)."""
    h = signal.windows.tukey(n, alpha)
    return h / np.sqrt(np.sum(h * h))


def _taper_acov(h) -> np.ndarray:
    """Lag weights sum_t h_t h_{t+k}, k = 0..n-1 (1 - k/n for the untapered record)."""
    n = len(h)
    size = fft.next_fast_len(2 * n, real=True)
    return fft.irfft(np.abs(fft.rfft(h, size)) ** 2, size)[:n]


def expected_periodogram(terms, n: int, rate_hz: float, tau_c: float = 0.0, alpha: float = TAPER_ALPHA) -> np.ndarray:
    """(bins, terms) expected tapered periodogram of n differenced samples per unit squared coefficient, 0 < f < fs/2."""
    weight = _taper_acov(taper(n, alpha))
    bins = np.arange(1, (n - 1) // 2 + 1)
    cols = []
    for term in terms:
        c = _acov_differenced(term, n, rate_hz, tau_c) * weight
        cols.append(2.0 * fft.rfft(c)[bins].real - c[0])
    return np.column_stack(cols)


def periodogram_of_differences(x, alpha: float = TAPER_ALPHA) -> np.ndarray:
    """Tapered periodogram |DFT(h d)|^2 of the mean-removed first differences d of ``x``, 0 < f < fs/2."""
    d = np.diff(np.asarray(x, dtype=float))
    d = d - d.mean()
    n = len(d)
    return np.abs(fft.rfft(d * taper(n, alpha))[1:(n - 1) // 2 + 1]) ** 2


SINGLE_BINS = 512
"""The lowest Fourier bins enter one by one; above them bins are pooled in groups of at most 1 % in frequency."""


def _group_edges(n_bins: int, single: int = SINGLE_BINS, width: float = 0.01) -> np.ndarray:
    """Start indices of the bin groups and the end: single bins up to ``single``, then groups of relative
    width ``width``. Within a group every expected ordinate is nearly constant (all terms are smooth power
    laws there), so the pooled likelihood ``m log s + sum I / s`` equals the sum over the bins."""
    edges = list(range(min(single, n_bins)))
    k = len(edges)
    while k < n_bins:
        edges.append(k)
        k = max(k + 1, int(k * (1.0 + width)))
    edges.append(n_bins)
    return np.array(edges)


class WhittleProblem:
    """The periodogram of one record and the expected-periodogram column of each term, computed once, so that
    fits of several term sets (for likelihood-ratio tests) share them."""

    def __init__(self, x, rate_hz: float, tau_c: float = 0.0, alpha: float = TAPER_ALPHA):
        x = np.asarray(x, dtype=float)
        self.x = x[:fast_length_below(len(x) - 1) + 1]
        self.rate_hz, self.tau_c, self.alpha = float(rate_hz), float(tau_c), alpha
        pgram = periodogram_of_differences(self.x, alpha)
        self.n_bins = len(pgram)
        self.edges = _group_edges(len(pgram))
        self.counts = np.diff(self.edges).astype(float)
        self.pgram = np.add.reduceat(pgram, self.edges[:-1])
        h = taper(len(self.x) - 1, alpha)
        # tapered ordinates are slightly correlated: n sum h^4 is the variance inflation of their averages
        self.inflation = float(len(h) * np.sum(h ** 4))
        self._columns: dict = {}

    def column(self, term: str) -> np.ndarray:
        """Expected periodogram per unit squared coefficient of ``term`` (cached)."""
        if term not in self._columns:
            col = expected_periodogram((term,), len(self.x) - 1, self.rate_hz, self.tau_c, self.alpha)[:, 0]
            col = np.add.reduceat(col, self.edges[:-1]) / self.counts
            # round-off leaves ~1e-16 relative negatives where a term has a spectral zero (Q, N at f = 0)
            self._columns[term] = np.maximum(col, 1e-12 * np.max(np.abs(col)))
        return self._columns[term]

    def fit(self, terms, theta0, max_iter: int = 200) -> WhittleFit:
        """ML squared coefficients of ``terms`` (subset of WHITTLE_TERMS) from start ``theta0``."""
        terms = tuple(terms)
        if not terms or any(t not in WHITTLE_TERMS for t in terms):
            raise ValueError(f"Whittle terms must be a non-empty subset of {WHITTLE_TERMS}, got {terms}")
        P = np.column_stack([self.column(t) for t in terms])
        pgram, counts = self.pgram, self.counts
        # scale each column so the start point is u = 0 for every term: a well-conditioned problem
        theta0 = np.maximum(np.asarray(theta0, dtype=float), 1e-30)
        Ps = P * theta0

        def nll(u):
            w = np.exp(u)
            s = Ps @ w
            r = pgram / s
            value = np.sum(counts * np.log(s) + r)
            grad = (Ps.T @ ((counts - r) / s)) * w
            return value, grad

        res = optimize.minimize(nll, np.zeros(len(terms)), jac=True, method="L-BFGS-B",
                                bounds=[(-30.0, 30.0)] * len(terms), options={"maxiter": max_iter})
        theta = theta0 * np.exp(res.x)
        A = P / (P @ theta)[:, None] * np.sqrt(counts)[:, None]
        cov = np.linalg.pinv(A.T @ A) * self.inflation
        ok = bool(res.success) and bool(np.isfinite(res.fun))
        return WhittleFit(terms, theta, cov, ok, self.n_bins, float(res.fun))


def fit_whittle(x, rate_hz: float, terms, theta0, tau_c: float = 0.0, max_iter: int = 200,
                alpha: float = TAPER_ALPHA) -> WhittleFit:
    """ML squared coefficients of ``terms`` (subset of WHITTLE_TERMS) for rate samples ``x``, from start ``theta0``."""
    return WhittleProblem(x, rate_hz, tau_c, alpha).fit(terms, theta0, max_iter)


def cramer_rao_relative_sd(n: int, rate_hz: float, terms, coefficients, tau_c: float = 0.0) -> np.ndarray:
    """Relative sd of each coefficient (not squared) that the Whittle Fisher information allows for n samples."""
    theta = np.asarray(coefficients, dtype=float) ** 2
    m = fast_length_below(n - 1)
    P = expected_periodogram(tuple(terms), m, rate_hz, tau_c)
    A = P / (P @ theta)[:, None]
    h = taper(m)
    cov = np.linalg.inv(A.T @ A) * (m * np.sum(h ** 4))
    return 0.5 * np.sqrt(np.diag(cov)) / theta
