"""Per-level, per-axis thresholds of the SWT details, and the three shrinkage rules.

Shrinkage of a detail coefficient ``d`` with threshold ``lam`` (PyWavelets' ``pywt.threshold``):

* ``hard``:      ``d`` if ``|d| >= lam`` else 0 (keeps edges, leaves noise on them);
* ``soft``:      ``sign(d) * max(|d| - lam, 0)`` (smooth, but shrinks every edge by ``lam``);
* ``hard_soft``: the paper's "hard then soft", defined here as hard thresholding at
  ``lam`` followed by soft thresholding of the survivors at ``soft_ratio * lam``:
  ``0`` if ``|d| < lam`` else ``sign(d) * (|d| - soft_ratio * lam)``. The hard stage
  decides *which* coefficients are motion (noise-only ones are removed outright);
  the soft stage removes the noise riding on the kept ones at a fraction of the bias
  of plain soft. ``soft_ratio = 0`` is ``hard``; ``soft_ratio = 1`` is ``soft``.

Noise level per level: white noise of density ``N`` (rad/sqrt(s) or m/s/sqrt(s),
the sensor-model ``white_noise``) has per-sample sigma ``N * sqrt(fs)``; the level-j
detail sigma is that times the norm of the level-j analysis filter (1 for the
orthonormal db8 with the un-normalised SWT, computed rather than assumed). Or it is
estimated from the data by the median absolute deviation of each level's details.
Threshold rules: ``universal`` ``sigma_j * sqrt(2 ln n)`` (n = window length) and
``sure`` (Stein's unbiased risk estimate for soft shrinkage, capped at universal).
"""
from __future__ import annotations

import functools

import numpy as np
import pywt

MODES = ("hard", "soft", "hard_soft")
RULES = ("universal", "sure")
NOISE_SOURCES = ("model", "mad")
MAD_TO_SIGMA = 1.0 / 0.6744897501960817
"""sigma of a Gaussian per median absolute deviation."""


def shrink(detail: np.ndarray, lam, mode: str, soft_ratio: float = 0.5) -> np.ndarray:
    """Shrink detail coefficients (n, k) with thresholds ``lam`` (k,) by ``mode`` (see module doc)."""
    if mode == "hard":
        return pywt.threshold(detail, lam, "hard")
    if mode == "soft":
        return _soft(detail, lam)
    if mode == "hard_soft":
        # = _soft(pywt.threshold(detail, lam, "hard"), soft_ratio * lam) in one pass (the streaming hot path)
        lam = np.asarray(lam, dtype=float)
        return np.where(np.abs(detail) >= lam, detail - np.sign(detail) * (soft_ratio * lam), 0.0)
    raise ValueError(f"threshold mode {mode!r} is not one of {MODES}")


def _soft(detail: np.ndarray, lam) -> np.ndarray:
    # pywt's soft rule gives 0/0 = nan for a zero coefficient at a zero threshold; the answer is 0
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(pywt.threshold(detail, lam, "soft"), nan=0.0)


@functools.lru_cache(maxsize=64)
def level_gains(wavelet: str, level: int) -> tuple:
    """Norm of each level's (1..level) detail analysis filter: detail sigma per unit white-noise sigma."""
    length = 2 ** level * (pywt.Wavelet(wavelet).dec_len + 2) * 2
    impulse = np.zeros(length)
    impulse[length // 2] = 1.0
    details = pywt.swt(impulse, wavelet, level=level, trim_approx=True)[1:]
    return tuple(float(np.linalg.norm(d)) for d in reversed(details))


def white_noise_sigma(white_noise_density, sample_rate_hz: float) -> np.ndarray:
    """Per-sample sigma (rad/s or m/s^2) of white noise with density N (rad/sqrt(s) or m/s/sqrt(s))."""
    return np.asarray(white_noise_density, dtype=float) * np.sqrt(sample_rate_hz)


def model_level_sigmas(sample_sigma, wavelet: str, level: int) -> np.ndarray:
    """Detail sigma per level and axis, shape (level, k), from per-sample sigma (k,) of white noise."""
    return np.outer(level_gains(wavelet, level), np.asarray(sample_sigma, dtype=float))


def mad_level_sigmas(details) -> np.ndarray:
    """Detail sigma per level and axis, shape (level, k), by the median absolute deviation of each level."""
    return np.stack([np.median(np.abs(d - np.median(d, axis=0)), axis=0) * MAD_TO_SIGMA for d in details])


def universal(sigmas: np.ndarray, n: int) -> np.ndarray:
    """Donoho-Johnstone universal threshold ``sigma * sqrt(2 ln n)``."""
    return np.asarray(sigmas) * np.sqrt(2.0 * np.log(max(int(n), 2)))


def sure_threshold(coeffs: np.ndarray, sigma: float) -> float:
    """SURE-minimising soft threshold for one level and axis (same unit as ``coeffs``), capped at universal."""
    n = len(coeffs)
    cap = np.sqrt(2.0 * np.log(max(n, 2)))
    if not sigma > 0:
        return 0.0
    x2 = np.sort((np.asarray(coeffs) / sigma) ** 2)
    # SURE(t) = n - 2 #{|x| <= t} + sum min(x^2, t^2), evaluated at t^2 = each x^2
    risk = n - 2.0 * np.arange(1, n + 1) + np.cumsum(x2) + x2 * np.arange(n - 1, -1, -1)
    best = np.sqrt(x2[int(np.argmin(risk))])
    return float(sigma * min(best, cap))


def sure(details, sigmas: np.ndarray) -> np.ndarray:
    """SURE thresholds, shape (level, k), for details (list of (n, k), level 1 first) and sigmas (level, k)."""
    return np.array([[sure_threshold(d[:, i], s[i]) for i in range(d.shape[1])]
                     for d, s in zip(details, sigmas)])
