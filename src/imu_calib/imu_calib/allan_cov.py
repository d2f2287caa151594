"""Correlation between overlapping Allan-variance estimates at different cluster times, from a noise spectrum.

Each overlapping Allan-variance point is the mean square of the rate filtered
by the Allan (Haar) filter of its cluster size m (samples)::

    |H_m(f)|^2 = 2 sin^4(pi f m) / (m^2 sin^2(pi f)),   f in cycles per sample

For Gaussian noise of two-sided discrete spectrum S(f), two such mean squares
over a long record have covariance proportional to
``sum_f |H_i(f)|^2 |H_j(f)|^2 S(f)^2`` (Isserlis, Parseval), the same constant
for every pair; so the correlation between points follows from the fitted
spectrum without a Monte Carlo factor. The variances themselves come from the
equivalent degrees of freedom (NIST SP 1065), which are right for short
records too; only the correlation comes from here.
"""
from __future__ import annotations

import numba
import numpy as np

MAX_GRID = 2 ** 21
"""Frequency points at most (the record's own Fourier grid up to this length)."""


def term_spectra(f, rate_hz: float, tau_c: float = 0.0) -> dict:
    """Two-sided discrete spectrum per unit squared coefficient of each term at ``f`` (cycles/sample), rate units^2."""
    s = np.sin(np.pi * f)
    out = {"Q": 4.0 * rate_hz ** 2 * s ** 2,  # angle rounding error (variance Q^2) differentiated
           "N": np.full_like(f, rate_hz),  # white rate of density N: per-sample variance N^2 fs
           "K": 1.0 / (4.0 * rate_hz * s ** 2),  # random walk with increments of variance K^2 dt
           "R": np.zeros_like(f)}  # a ramp is deterministic: no spread
    if tau_c > 0:  # Gauss-Markov of unit variance
        phi = np.exp(-1.0 / (rate_hz * tau_c))
        out["B"] = (1.0 - phi ** 2) / (1.0 - 2.0 * phi * np.cos(2.0 * np.pi * f) + phi ** 2)
    else:  # flicker: one-sided B^2/(pi F) sinc^2 in Hz, as imu_calib.synthetic generates it
        out["B"] = np.sinc(f) ** 2 / (2.0 * np.pi * f)
    return out


@numba.njit(cache=True)
def _haar_sums(ms, spectrum, size, gram):
    """Sum over f = k/size (k = 1..len(spectrum)) of W_i = |H_{m_i}(f)|^2 S(f): into gram[i, j] += W_i W_j, or
    (``gram`` of one row) gram[0, i] += W_i. One pass, no temporaries (the arrays would be taus x 10^6)."""
    k_count = len(ms)
    w = np.empty(k_count)
    for k in range(len(spectrum)):
        f = (k + 1.0) / size
        sin_f = np.sin(np.pi * f)
        for i in range(k_count):
            s = np.sin(np.pi * f * ms[i])
            s *= s
            w[i] = 2.0 * s * s / (ms[i] * ms[i] * sin_f * sin_f) * spectrum[k]
        if gram.shape[0] == 1:
            for i in range(k_count):
                gram[0, i] += w[i]
        else:
            for i in range(k_count):
                for j in range(i + 1):
                    gram[i, j] += w[i] * w[j]


def allan_correlation(taus, n_samples: int, rate_hz: float, coefficients_sq: dict, tau_c: float = 0.0) -> np.ndarray:
    """(k, k) correlation of overlapping Allan-variance estimates at ``taus`` s for a noise of squared
    coefficients ``coefficients_sq`` (term -> c, SI, as in the Allan fit)."""
    ms = np.round(np.asarray(taus, dtype=float) * rate_hz)
    size = int(min(max(n_samples, 4 * ms.max()), MAX_GRID))
    freqs = np.arange(1, size // 2 + 1) / size
    spectra = term_spectra(freqs, rate_hz, tau_c)
    s = sum(c * spectra[t] for t, c in coefficients_sq.items() if c > 0)
    if np.isscalar(s):
        return np.eye(len(ms))
    gram = np.zeros((len(ms), len(ms)))
    _haar_sums(ms, np.asarray(s, dtype=float), float(size), gram)
    gram = np.tril(gram) + np.tril(gram, -1).T
    d = np.sqrt(np.diag(gram))
    if not np.all(d > 0):
        return np.eye(len(ms))
    return np.clip(gram / np.outer(d, d), -1.0, 1.0)


def flicker_avar(taus, n_samples: int, rate_hz: float) -> np.ndarray:
    """Allan variance per unit B^2 of sampled flicker rate noise (one-sided B^2/(pi F) sinc^2, from 1/(2T)).

    The flat law (2 ln 2 / pi) B^2 holds only between the shortest and the longest cluster times: the
    sample averaging lowers the first points and the record's lowest frequency the last. Summed on the
    record's own grid f = k / 2n (the grid imu_calib.synthetic shapes flicker on).
    """
    ms = np.round(np.asarray(taus, dtype=float) * rate_hz)
    size = int(min(2 * n_samples, 2 * MAX_GRID))
    f = np.arange(1, size // 2 + 1) / size
    out = np.zeros((1, len(ms)))
    _haar_sums(ms, np.sinc(f) ** 2 / (2.0 * np.pi * f), float(size), out)
    return 2.0 * out[0] / size
