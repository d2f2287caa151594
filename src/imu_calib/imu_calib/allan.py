"""Allan deviation (overlapping and non-overlapping), cluster-time grids, confidence intervals, PSD.

Input is a rate-type signal sampled at ``rate_hz``: angular rate in rad/s or
specific force in m/s^2, shape (n,) or (n, k) for k axes. Cluster times are in
s and are rounded to whole multiples ``m`` of the sample interval.

The overlapping (maximal-overlap) estimator works on the integrated signal
``theta_j = sum_{i<j} x_i / rate_hz`` (j = 0..n)::

    avar(tau) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 (n + 1 - 2m))

which is what ``allantools.oadev`` and the avar R package compute. Each cluster
time costs O(n) work, so an octave grid costs O(n log n); one blocked Numba pass
serves all cluster times (see ``_second_difference_means``).

Public API (used by imu_sim as well)::

    taus, adev, lo, hi = overlapping_adev(x, rate_hz, taus=None)   # None: octave grid
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy import signal, stats

ALPHA_WHITE_PM, ALPHA_WHITE_FM, ALPHA_FLICKER_FM, ALPHA_RW_FM = 2, 0, -1, -2
"""Power-law exponents of the frequency PSD (NIST SP 1065): quantization, white, flicker, random walk."""


class AllanError(ValueError):
    """The signal is too short (or otherwise unfit) for the requested cluster times."""


@dataclass
class AllanDeviation:
    """Allan deviation per cluster time: ``taus`` (k,) s; ``adev``, ``lo``, ``hi`` (k,) or (k, axes) in x's unit.

    Iterating yields ``(taus, adev, lo, hi)``; ``edf`` holds the equivalent
    degrees of freedom and ``confidence`` the interval's coverage.
    """

    taus: np.ndarray
    adev: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    edf: np.ndarray
    n_samples: int
    rate_hz: float
    confidence: float = 0.95
    overlapping: bool = True

    def __iter__(self):
        return iter((self.taus, self.adev, self.lo, self.hi))

    @property
    def avar(self) -> np.ndarray:
        """Allan variance (adev squared)."""
        return self.adev ** 2

    def axis(self, i: int) -> AllanDeviation:
        """The result of one axis (column ``i``) of a multi-axis result."""
        if self.adev.ndim == 1:
            return self
        return AllanDeviation(self.taus, self.adev[:, i], self.lo[:, i], self.hi[:, i], self.edf[:, i],
                              self.n_samples, self.rate_hz, self.confidence, self.overlapping)


# ----------------------------------------------------------------------------- grids


def max_cluster_size(n_samples: int) -> int:
    """Largest averaging factor m (samples) for n samples: at least two overlapping differences remain.

    m = n/2 would leave a single difference (one degree of freedom); like allantools we stop before it.
    """
    return int((n_samples - 1) // 2)


def octave_taus(n_samples: int, rate_hz: float, m_min: int = 1) -> np.ndarray:
    """Octave-spaced cluster times, s: m = 1, 2, 4, ... up to (n - 1)/2 samples."""
    m_max = max_cluster_size(n_samples)
    if m_max < m_min:
        raise AllanError(f"{n_samples} samples allow no cluster time (need at least {2 * m_min} samples)")
    ms = 2 ** np.arange(int(np.log2(m_min)), int(np.floor(np.log2(m_max))) + 1)
    return ms / float(rate_hz)


def log_taus(n_samples: int, rate_hz: float, per_decade: int = 10, m_min: int = 1) -> np.ndarray:
    """Log-spaced cluster times, s, ``per_decade`` points per decade (distinct whole m) up to (n - 1)/2 samples."""
    if per_decade < 1:
        raise AllanError(f"per_decade must be >= 1, got {per_decade}")
    m_max = max_cluster_size(n_samples)
    if m_max < m_min:
        raise AllanError(f"{n_samples} samples allow no cluster time (need at least {2 * m_min} samples)")
    n_pts = int(np.floor(np.log10(m_max / m_min) * per_decade)) + 1
    ms = np.unique(np.round(m_min * 10.0 ** (np.arange(n_pts) / per_decade)).astype(np.int64))
    return ms[ms <= m_max] / float(rate_hz)


def cluster_sizes(taus, n_samples: int, rate_hz: float) -> np.ndarray:
    """Whole averaging factors m for cluster times ``taus`` (s); AllanError if one is too long or short."""
    taus = np.atleast_1d(np.asarray(taus, dtype=float))
    ms = np.round(taus * rate_hz).astype(np.int64)
    if np.any(ms < 1):
        raise AllanError(f"cluster time {taus[ms < 1].min():.4g} s is shorter than one sample "
                         f"({1.0 / rate_hz:.4g} s at {rate_hz:g} Hz)")
    too_long = ms > max_cluster_size(n_samples)
    if np.any(too_long):
        duration = n_samples / rate_hz
        raise AllanError(f"recording too short: {n_samples} samples ({duration:.4g} s at {rate_hz:g} Hz) "
                         f"allow cluster times up to {max_cluster_size(n_samples) / rate_hz:.4g} s, "
                         f"but {taus[too_long].max():.4g} s was requested (need at least "
                         f"{2 * taus[too_long].max():.4g} s of data)")
    return ms


# ----------------------------------------------------------------------------- kernels


SECOND_DIFFERENCE_BLOCK = 65_536
"""Phase samples per block of the second-difference kernel (512 KiB, half a core's L2 here; 64-256 K measured
equal, 4-32 K and one whole-record block slower)."""


@numba.njit(cache=True)
def _column_means(x2):
    """Mean of each column of a 2-D array in one pass over its rows (sums of 4096-row blocks, then of blocks)."""
    n, k = x2.shape
    total = np.zeros(k)
    part = np.empty(k)
    for r0 in range(0, n, 4096):
        part[:] = 0.0
        for i in range(r0, min(r0 + 4096, n)):
            for c in range(k):
                part[c] += x2[i, c]
        total += part
    return total / n


@numba.njit(cache=True)
def _phase_into(x, mean, dt, theta):
    """Integrated (mean-removed) signal into ``theta`` (n+1 points, starting at 0); ``x`` may be strided."""
    theta[0] = 0.0
    acc = 0.0
    for i in range(x.shape[0]):
        acc += (x[i] - mean) * dt
        theta[i + 1] = acc


@numba.njit(cache=True, fastmath=True)
def _second_difference_means(theta, ms, block=SECOND_DIFFERENCE_BLOCK):
    """Mean of (theta[k+2m] - 2 theta[k+m] + theta[k])^2 over k = 0..len(theta)-2m-1, for each m.

    One pass over ``theta`` in blocks of ``block`` samples, every m per block: for the small m the three
    streams of a block stay in cache, so they cost one memory pass together instead of one each. The inner
    loop indexes slices from 0: with ``theta[k + m]`` Numba's per-element negative-index wraparound made
    LLVM vectorize with gather loads, 4x slower. Each block's sum is added to its m's total, which also keeps
    the rounding error per m small.
    """
    n1 = theta.shape[0]
    out = np.zeros(ms.shape[0])
    k_end = 0
    for j in range(ms.shape[0]):
        k_end = max(k_end, n1 - 2 * ms[j])
    for k0 in range(0, k_end, block):
        for j in range(ms.shape[0]):
            m = ms[j]
            k1 = min(k0 + block, n1 - 2 * m)
            if k1 <= k0:
                continue
            a = theta[k0:k1]
            b = theta[k0 + m:k1 + m]
            c = theta[k0 + 2 * m:k1 + 2 * m]
            acc = 0.0
            for k in range(k1 - k0):
                d = c[k] - 2.0 * b[k] + a[k]
                acc += d * d
            out[j] += acc
    for j in range(ms.shape[0]):
        out[j] /= n1 - 2 * ms[j]
    return out


@numba.njit(cache=True)
def _nonoverlapping_second_difference_means(theta, ms):
    """Mean of (theta[(j+2)m] - 2 theta[(j+1)m] + theta[jm])^2 over the K-1 pairs of K = (len(theta)-1)//m
    disjoint clusters, for each m."""
    out = np.empty(ms.shape[0])
    for j in range(ms.shape[0]):
        m = ms[j]
        pairs = (theta.shape[0] - 1) // m - 1
        acc = 0.0
        for i in range(pairs):
            d = theta[(i + 2) * m] - 2.0 * theta[(i + 1) * m] + theta[i * m]
            acc += d * d
        out[j] = acc / pairs
    return out


def _columns(x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim not in (1, 2):
        raise AllanError(f"expected a signal of shape (n,) or (n, k), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise AllanError("signal contains NaN or infinite values")
    return x


def _avar_columns(x, rate_hz, ms, overlapping: bool):
    """Allan variance per (m, column); one phase buffer serves every column (no copy of the column)."""
    x2 = x.reshape(len(x), -1)
    out = np.empty((len(ms), x2.shape[1]))
    dt = 1.0 / rate_hz
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    theta = np.empty(len(x2) + 1)
    kernel = _second_difference_means if overlapping else _nonoverlapping_second_difference_means
    means = _column_means(x2)  # one pass over the rows, not one strided pass per column
    for c in range(x2.shape[1]):
        _phase_into(x2[:, c], means[c], dt, theta)
        # eqs. 8-9 for the non-overlapping case: the cluster means are diff(theta[::m]) / (m dt)
        out[:, c] = kernel(theta, ms) / (2.0 * (ms * dt) ** 2)
    return out


# ----------------------------------------------------------------------------- confidence


def edf_overlapping(n_samples: int, ms, alphas) -> np.ndarray:
    """Equivalent degrees of freedom of overlapping AVAR (NIST SP 1065 Table 5) per m and noise exponent."""
    n_phase = float(n_samples + 1)
    ms = np.asarray(ms, dtype=float)
    alphas = np.broadcast_to(np.asarray(alphas), ms.shape)
    edf = np.empty(ms.shape)
    for i, (m, alpha) in enumerate(zip(ms.ravel(), alphas.ravel())):
        edf.flat[i] = _edf_one(n_phase, m, int(alpha))
    return np.maximum(edf, 1.0)


def _edf_one(N: float, m: float, alpha: int) -> float:
    if alpha >= 2:
        return (N + 1) * (N - 2 * m) / (2 * (N - m))
    if alpha >= 0:
        return (3 * (N - 1) / (2 * m) - 2 * (N - 2) / N) * 4 * m ** 2 / (4 * m ** 2 + 5)
    if alpha == -1:
        return 2 * (N - 2) / (2.3 * N - 4.9) if m == 1 else 5 * N ** 2 / (4 * m * (N + 3 * m))
    return (N - 2) / (m * (N - 3) ** 2) * ((N - 1) ** 2 - 3 * m * (N - 1) + 4 * m ** 2)


def alpha_from_slope(taus, avar) -> np.ndarray:
    """Dominant power-law exponent per cluster time from the local log-log slope of the Allan variance."""
    taus = np.asarray(taus, dtype=float)
    avar = np.maximum(np.asarray(avar, dtype=float), np.finfo(float).tiny)
    if len(taus) < 2:
        return np.zeros(avar.shape, dtype=int)
    slope = np.gradient(np.log(avar), np.log(taus), axis=0)
    # avar ~ tau^mu  <->  S_y ~ f^alpha with alpha = -mu - 1 (for -2 <= alpha <= 1)
    alpha = np.clip(np.round(-slope - 1.0), -2, 2).astype(int)
    alpha[alpha == 1] = 2  # white and flicker PM are both quantization-like here
    return alpha


def chi2_interval(avar, edf, confidence: float = 0.95):
    """Lower and upper bounds of the Allan variance from the chi-square law with ``edf`` dof."""
    tail = 0.5 * (1.0 - confidence)
    return (avar * edf / stats.chi2.ppf(1.0 - tail, edf), avar * edf / stats.chi2.ppf(tail, edf))


# ----------------------------------------------------------------------------- public


def overlapping_adev(x, rate_hz: float, taus=None, confidence: float = 0.95, alphas=None) -> AllanDeviation:
    """Maximal-overlap Allan deviation of ``x`` (rate units) at ``taus`` s (None: octave grid).

    ``alphas`` fixes the noise exponent used for the equivalent degrees of
    freedom; by default it is read from the local slope of the estimate.
    Raises :class:`AllanError` if the signal is too short for a cluster time.
    """
    x = _columns(x)
    n = len(x)
    taus = octave_taus(n, rate_hz) if taus is None else np.asarray(taus, dtype=float)
    ms = cluster_sizes(taus, n, rate_hz)
    avar = _avar_columns(x, rate_hz, ms, overlapping=True)
    alphas = alpha_from_slope(ms / rate_hz, avar) if alphas is None else np.broadcast_to(alphas, avar.shape)
    edf = np.column_stack([edf_overlapping(n, ms, alphas[:, c]) for c in range(avar.shape[1])])
    return _result(x, ms, rate_hz, avar, edf, confidence, overlapping=True)


def nonoverlapping_adev(x, rate_hz: float, taus=None, confidence: float = 0.95) -> AllanDeviation:
    """Non-overlapping Allan deviation (the paper's eqs. 8-9), disjoint clusters; edf = clusters - 1."""
    x = _columns(x)
    n = len(x)
    taus = octave_taus(n // 2 * 2, rate_hz) if taus is None else np.asarray(taus, dtype=float)
    ms = cluster_sizes(taus, n, rate_hz)
    avar = _avar_columns(x, rate_hz, ms, overlapping=False)
    edf = np.broadcast_to((n // ms - 1).astype(float)[:, None], avar.shape).copy()
    return _result(x, ms, rate_hz, avar, edf, confidence, overlapping=False)


def _result(x, ms, rate_hz, avar, edf, confidence, overlapping):
    lo, hi = chi2_interval(avar, edf, confidence)
    squeeze = (lambda a: a[:, 0]) if x.ndim == 1 else (lambda a: a)
    return AllanDeviation(ms / float(rate_hz), squeeze(np.sqrt(avar)), squeeze(np.sqrt(lo)),
                          squeeze(np.sqrt(hi)), squeeze(edf), len(x), float(rate_hz), confidence, overlapping)


@dataclass
class Psd:
    """One-sided PSD: ``freqs`` Hz, ``psd`` (unit^2/Hz), white level ``white_noise`` (unit*sqrt(s)) per axis."""

    freqs: np.ndarray
    psd: np.ndarray
    white_noise: np.ndarray


def psd(x, rate_hz: float, segment_s: float = 100.0, band=(0.25, 0.75)) -> Psd:
    """Welch PSD of ``x``; white level N = sqrt(median one-sided PSD / 2) over ``band`` (fractions of Nyquist)."""
    x = _columns(x)
    nperseg = int(min(len(x), max(16, round(segment_s * rate_hz))))
    freqs, pxx = signal.welch(x, fs=rate_hz, nperseg=nperseg, axis=0, detrend="constant")
    nyq = 0.5 * rate_hz
    sel = (freqs >= band[0] * nyq) & (freqs <= band[1] * nyq)
    # white rate noise of density N (unit*sqrt(s)) has a flat one-sided PSD of 2 N^2
    white = np.sqrt(np.median(pxx[sel], axis=0) / 2.0)
    return Psd(freqs, pxx, white)
