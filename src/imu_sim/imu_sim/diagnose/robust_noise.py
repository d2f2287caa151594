"""A slow noise term must explain more than a misstated noise model does: the robust gate of the noise candidates.

A user states the model's noise levels only to within about 10 %, and a real sensor's bias instability is flicker
(1/f) noise that a Gauss-Markov or random-walk term can partly stand for. So a bias random walk or Gauss-Markov
bias is tested against a null in which (per channel, Whittle likelihood of the detrended block means)

* the white level is free (the model's white noise only sets its order),
* the model's own Gauss-Markov and random-walk levels are free within ``(1 +- NOISE_TOLERANCE)^2`` in power,
* where the model states a bias instability B (flicker or Gauss-Markov), a flicker (1/f) level up to
  ``(1 + NOISE_TOLERANCE)^2 B^2`` and its Gauss-Markov level from 0 (a real bias instability is flicker noise
  whatever form the model gives it; a model stating none gets no flicker, so a missing one is still found),

and the term's statistic is the likelihood ratio of that null plus the term's extra PSD against the null alone.
"""
from __future__ import annotations

import numpy as np
from scipy import optimize

from imu_sim.diagnose.case import effective_model

BAND_RATIO = 1.1
"""Width of the Whittle likelihood's frequency bands (ratio of their edges): the PSDs compared are smooth over
10 %, and a few hundred bands instead of thousands of bins make the profile fast."""
NOISE_TOLERANCE = 0.25
"""How far (relative, in amplitude) the model's stated Gauss-Markov and random-walk levels may be from the truth:
a user states noise to about 10 %; 25 % leaves room for the scatter of a level estimated from one record."""
LEVEL_MAX = 1e6
"""Largest free level, in units of the low-frequency periodogram median (a bound for the optimiser only)."""


def components(model, channel: int, freqs: np.ndarray) -> tuple[list, list]:
    """The null's PSD components (two-sided, unit^2/Hz) of ``channel`` at ``freqs`` and their level bounds
    (relative to the stated level; None: free, >= 0)."""
    tri = effective_model(model).triad(("gyro", "accel")[channel // 3])
    i = channel % 3
    w = 2 * np.pi * freqs
    comps = [np.full_like(freqs, max(tri.white_noise[i] ** 2, 1e-300))]
    bounds = [None]
    lo, hi = (1 - NOISE_TOLERANCE) ** 2, (1 + NOISE_TOLERANCE) ** 2
    b, tc = tri.bias_instability[i], tri.bias_correlation_time[i]
    if b > 0:
        comps.append(b**2 / w)
        bounds.append((0.0, hi))
    if b > 0 and tc > 0:
        comps.append(2 * b**2 * tc / (1 + (w * tc) ** 2))
        bounds.append((0.0, hi))
    k = tri.rate_random_walk[i]
    if k > 0:
        comps.append(k**2 / w**2)
        bounds.append((lo, hi))
    return comps, bounds


def bands(freqs: np.ndarray) -> np.ndarray:
    """Band index of each frequency: log-spaced bands BAND_RATIO wide (one bin each at the lowest frequencies)."""
    return np.unique(np.floor(np.log(freqs / freqs[0]) / np.log(BAND_RATIO)).astype(int), return_inverse=True)[1]


def _banded(x: np.ndarray, idx: np.ndarray):
    """Band means of x (..., nf) over the bands ``idx`` and the bins per band."""
    count = np.bincount(idx).astype(float)
    sums = np.stack([np.bincount(idx, weights=row) for row in np.atleast_2d(x)])
    return sums / count, count


def _fit(i_f: np.ndarray, mat: np.ndarray, box: list, starts: list, count: np.ndarray):
    """Maximum Whittle log-likelihood of band-mean periodogram I (nb,) with ``count`` bins per band under
    sum_j x_j mat_j (a PSD smooth within a band), x in ``box``: (loglik, x)."""
    def negll(x):
        s = np.maximum(x @ mat, 1e-300)
        r = i_f / s
        grad = -(count * (r - 1.0) / s) @ mat.T
        return float(np.sum(count * (np.log(s) + r))), grad

    best = None
    for start in starts:
        res = optimize.minimize(negll, np.clip(start, [b[0] for b in box], [b[1] for b in box]), jac=True,
                                method="L-BFGS-B", bounds=box)
        if best is None or res.fun < best.fun:
            best = res
    return -float(best.fun), best.x


def _design(comps: list, bounds: list, ref: float):
    """Components scaled so a free level of 1 explains the low-frequency periodogram median alone; their box."""
    low = max(8, len(comps[0]) // 64)
    mat = np.array([c * (ref / max(float(np.median(c[:low])), 1e-300) if bd is None else 1.0)
                    for c, bd in zip(comps, bounds)])
    box = [(0.0, LEVEL_MAX) if bd is None else bd for bd in bounds]
    box[0] = (1e-6, LEVEL_MAX)  # the white level: strictly positive
    return mat, box


def extra_lr(i_f: np.ndarray, freqs: np.ndarray, model, channel: int, extras: list) -> tuple[float, int]:
    """Largest likelihood ratio over ``extras`` (PSD shapes, level free) of the robust null plus it against the
    robust null alone, and the index of that extra."""
    comps, bounds = components(model, channel, freqs)
    ref = float(np.median(i_f[: max(8, len(i_f) // 64)]))
    idx = bands(freqs)
    i_b, count = _banded(i_f, idx)
    i_b = i_b[0]
    mat, box = _design(comps, bounds, ref)
    white = float(np.median(i_f) / max(float(np.median(mat[0])), 1e-300))
    mat = _banded(mat, idx)[0]
    x0 = np.array([white] + [1.0 for _ in bounds[1:]])
    null, xn = _fit(i_b, mat, box, [x0], count)
    best, arg = 0.0, 0
    for j, extra in enumerate(extras):
        mat_a, box_a = _design(comps + [extra], bounds + [None], ref)
        starts = [np.r_[xn, 0.0], np.r_[xn, 1.0]]
        alt, _ = _fit(i_b, _banded(mat_a, idx)[0], box_a, starts, count)
        if 2.0 * (alt - null) > best:
            best, arg = 2.0 * (alt - null), j
    return float(best), arg
