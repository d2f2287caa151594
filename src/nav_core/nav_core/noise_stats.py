"""Noise statistics shared by the sim-versus-real diagnosis (``imu_sim.diagnose``) and the live health monitor
(``sensor_health``): one implementation of each test. No ROS.

* :func:`noise_psd`: the two-sided PSD of a sensor model's noise per channel (white, bias instability as
  Gauss-Markov or flicker, rate random walk), unit^2/Hz.
* :class:`Whitener`: DFT weights 1/S(f) of that PSD (the Whittle approximation: weighting each DFT bin by
  1/S is generalised least squares); the DC bin is dropped, so a constant bias is a nuisance parameter. The
  level is rescaled per channel by a robust estimate (median of the whitened periodogram): a noise level off
  by a factor shows in ``scale2``, not as lines.
* :func:`whitened_power`: the whitened periodogram in chi-square(2) units under the model (what both the
  diagnosis' vibration scan and the health monitor's line gate threshold).
* :func:`vibration_scan`, :func:`line_lr`, :func:`fit_line_frequency`: the largest line, its likelihood ratio
  off the bins, and its maximum-likelihood frequency with the profile-likelihood interval.
* :func:`block_means`.

Channels are ``gx gy gz ax ay az`` (rad/s, m/s^2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from nav_core.sensor_model import SensorModel

LN2 = np.log(2.0)
Z95 = 1.959964


def noise_psd(model: SensorModel, freqs: np.ndarray) -> np.ndarray:
    """Two-sided PSD (unit^2/Hz) of ``model``'s noise per channel at ``freqs`` Hz, shape (6, nf).

    The model is used as given (the diagnosis applies its physics overrides first). DC is evaluated at the
    first non-zero frequency."""
    f = np.maximum(np.abs(freqs), freqs[1] if len(freqs) > 1 else 1.0)
    out = []
    for name in ("gyro", "accel"):
        tri = model.triad(name)
        for i in range(3):
            s = np.full_like(f, tri.white_noise[i] ** 2)
            b, tc = tri.bias_instability[i], tri.bias_correlation_time[i]
            if b > 0 and tc > 0:
                s = s + 2 * b**2 * tc / (1 + (2 * np.pi * f * tc) ** 2)
            elif b > 0:
                s = s + b**2 / (2 * np.pi * f)
            s = s + tri.rate_random_walk[i] ** 2 / (2 * np.pi * f) ** 2
            out.append(s if np.any(s > 0) else np.ones_like(f))
    return np.array(out)


def bin_multiplicity(n: int) -> np.ndarray:
    """How many two-sided DFT bins each rfft bin of an n-sample series stands for (0 at DC)."""
    mult = np.full(n // 2 + 1, 2.0)
    mult[0] = 0.0
    if n % 2 == 0:
        mult[-1] = 1.0
    return mult


def whitened_power(spec: np.ndarray, weights: np.ndarray, n: int, scale2: np.ndarray) -> np.ndarray:
    """|X|^2 w / (n s^2): the whitened periodogram, chi-square(2) per interior bin under the model.

    ``spec`` (..., 6, nf) rfft of n samples per channel; ``weights`` (6, nf) = multiplicity / S(f) (any common
    factor is absorbed by ``scale2``); ``scale2`` (..., 6) the level of the model PSD in the data."""
    return np.abs(spec) ** 2 * weights / (n * np.asarray(scale2)[..., None])


def robust_scale2(spec: np.ndarray, weights: np.ndarray, n: int) -> np.ndarray:
    """Level of the model PSD in the data per channel (..., 6): median of the whitened periodogram / ln 2.

    The median of an exponential variable is ln 2 times its mean, and a median is blind to a few lines."""
    mult = bin_multiplicity(n)
    u = (np.abs(spec) ** 2 * weights / mult.clip(min=1))[..., 1:] / n
    return np.maximum(np.median(u, axis=-1) / LN2, 1e-300)


@dataclass
class Whitener:
    """Per-channel DFT weights (1/S, DC dropped, interior bins counted twice) and noise scales."""

    n: int
    dt: float
    weights: np.ndarray
    """(6, nf) = multiplicity / S(f), 0 at DC."""
    scale2: np.ndarray
    """(6,) variance multiplier of the model PSD estimated from the residual."""

    @classmethod
    def from_psd(cls, psd: np.ndarray, resid: np.ndarray, dt: float) -> Whitener:
        """Weights from a PSD (6, nf) on the rfft grid of ``resid`` (n, 6); scales from its median periodogram."""
        n = len(resid)
        w = bin_multiplicity(n) / (psd / psd.max(axis=1, keepdims=True))
        scale2 = robust_scale2(np.fft.rfft(resid, axis=0).T, w, n)
        return cls(n, dt, w, scale2)

    @classmethod
    def from_model(cls, model: SensorModel, resid: np.ndarray, dt: float) -> Whitener:
        """Weights from ``model``'s PSD; scales from the median whitened periodogram of ``resid`` (n, 6)."""
        return cls.from_psd(noise_psd(model, np.fft.rfftfreq(len(resid), dt)), resid, dt)

    def spectrum(self, x: np.ndarray) -> np.ndarray:
        """rfft along time of x (n,) or (n, k)."""
        return np.fft.rfft(x, axis=0)

    def gram(self, ch: int, xf: np.ndarray, yf: np.ndarray) -> np.ndarray:
        """Whitened inner products Re(X^H W Y) / (n s^2) for channel ch; xf (nf, k), yf (nf,) or (nf, m)."""
        w = self.weights[ch] / (self.n * self.scale2[ch])
        if yf.ndim == 1:
            return np.real(np.conj(xf).T @ (w * yf))
        return np.real(np.conj(xf).T @ (w[:, None] * yf))


def vibration_scan(wh: Whitener, resid_f: np.ndarray, f_min_hz: float, exclude=None):
    """Largest whitened periodogram ordinate: (lr, channel, bin frequency Hz, number of bins searched).

    ``resid_f`` (nf, 6); ``exclude``: mask of bins not searched (e.g. harmonics of the trajectory)."""
    freqs = np.fft.rfftfreq(wh.n, wh.dt)
    sel = (freqs >= f_min_hz) & (freqs < 0.5 / wh.dt)
    if exclude is not None:
        sel &= ~exclude
    power = whitened_power(resid_f.T, wh.weights, wh.n, wh.scale2)
    power[:, ~sel] = 0.0
    ch, k = np.unravel_index(np.argmax(power), power.shape)
    return float(power[ch, k]), int(ch), float(freqs[k]), int(sel.sum()) * 6


def line_lr(wh: Whitener, x: np.ndarray, f_hz: float, k: int) -> float:
    """Joint whitened periodogram of the columns x (n, 6) at f_hz (off the bins too): the likelihood ratio of a line
    with its own amplitude and phase per channel (chi-square 2 per channel under the null); weights of bin k."""
    e = np.exp(-2j * np.pi * f_hz * wh.dt * np.arange(wh.n))
    return float(np.sum(np.abs(e @ x) ** 2 * wh.weights[:, k] / (wh.n * wh.scale2)))


def fit_line_frequency(wh: Whitener, resid: np.ndarray, f0: float, z: float = Z95, grid: int = 20):
    """Maximum-likelihood frequency (Hz) of one line common to all channels near bin f0, and its 95 %
    profile-likelihood interval: (f, lo, hi).

    The interval is where the joint likelihood ratio stays within z^2 (chi-square 1) of its top, searched within
    one bin either side (a line too weak to lose z^2 within a bin gets that bin's edges). Its half-width is z times
    the Cramer-Rao sd(f) = sqrt(6) / (pi T sqrt(n sum_c A_c^2 / sigma_c^2)), T = n dt s, from the sampled amplitudes
    A_c (interval means: the line's amplitude times sinc(f dt)) over the noise sigma_c per sample at f (whitened).
    """
    x = resid - resid.mean(axis=0)
    df = 1.0 / (wh.n * wh.dt)
    k = int(round(f0 / df))
    f_grid = f0 + np.linspace(-1.0, 1.0, 2 * grid + 1) * df
    lr_grid = [line_lr(wh, x, f, k) for f in f_grid]
    i = int(np.argmax(lr_grid))
    res = optimize.minimize_scalar(lambda f: -line_lr(wh, x, f, k), bounds=(f_grid[max(i - 1, 0)],
                                   f_grid[min(i + 1, len(f_grid) - 1)]), method="bounded",
                                   options={"xatol": df * 1e-6})
    f_hat, top = (float(res.x), -float(res.fun)) if -res.fun >= lr_grid[i] else (float(f_grid[i]), lr_grid[i])

    def drop(f):
        return top - line_lr(wh, x, f, k) - z * z
    ends = []
    for edge in (f_hat - df, f_hat + df):
        ends.append(float(optimize.brentq(drop, f_hat, edge, xtol=df * 1e-6)) if drop(edge) > 0 else edge)
    return f_hat, min(ends), max(ends)


def block_means(x: np.ndarray, m: int) -> np.ndarray:
    """Means of consecutive blocks of m rows (the tail that does not fill a block is dropped)."""
    nb = len(x) // m
    return x[:nb * m].reshape(nb, m, *x.shape[1:]).mean(axis=1)
