"""Per-window statistics of the raw signal against the sensor model's noise (vectorised over windows).

A window is ``n`` consecutive samples of the six channels. Its least-squares line is removed (the vehicle's
motion is slow next to the sample rate), and its DFT is tapered (Hann) and whitened by the model's noise PSD
(:mod:`nav_core.noise_stats`, the diagnosis' implementation) plus the quantization term:

* ``level``: the robust noise level (median whitened periodogram / ln 2), the variance factor over the
  model's; 1 on a healthy sensor whatever the motion's few low bins do;
* ``line``: the largest whitened periodogram ordinate above ``f_min_hz``, chi-square(2) under the model
  after dividing out ``level`` (so a rise of the whole noise floor is not a line);
* ``mean``: the window mean (for the bias CUSUM);
* ``ties``: how many samples sit exactly at the window's extreme (a clip's flat tops);
* ``span_ties`` (separately, it needs the windows before): how many samples of the last ``CLIP_SPAN_WINDOWS``
  windows sit exactly at the extreme of the span, when this window holds it (a clip touched a few samples at a
  time, turn after turn, on a lattice the noise almost never repeats at its extreme).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter1d

from nav_core import noise_stats
from nav_core.sensor_model import SensorModel

CLIP_SPAN_WINDOWS = 10


def quantization_psd(model: SensorModel, freqs: np.ndarray, dt: float) -> np.ndarray:
    """Two-sided PSD (unit^2/Hz) of quantization noise per channel (6, nf).

    A sensor that counts increments in steps and carries the remainder e_k (variance Q^2, the Allan Q) outputs
    the rate error (e_k - e_{k-1}) / dt: PSD 4 Q^2 sin^2(pi f dt) / dt."""
    q = np.concatenate([model.gyro.quantization, model.accel.quantization])
    return 4 * q[:, None] ** 2 * np.sin(np.pi * freqs * dt)[None, :] ** 2 / dt


def sample_sigma(model: SensorModel, dt: float) -> np.ndarray:
    """Per-sample sd (6,) of white and quantization noise at interval dt s (rad/s, m/s^2)."""
    n = np.concatenate([model.gyro.white_noise, model.accel.white_noise])
    q = np.concatenate([model.gyro.quantization, model.accel.quantization])
    return np.sqrt(n**2 / dt + 2 * q**2 / dt**2)


@dataclass
class WindowGrid:
    """The DFT grid of an ``n``-sample window at interval ``dt`` s and the model's whitening weights on it."""

    n: int
    dt: float
    weights: np.ndarray
    """(6, nf) multiplicity dt / S(f), S the model's PSD plus quantization: the level is 1 under the model."""
    line_bins: np.ndarray
    """Bins searched for a line: f_min_hz <= f < Nyquist."""

    @classmethod
    def for_model(cls, model: SensorModel, n: int, dt: float, f_min_hz: float) -> WindowGrid:
        """The grid of ``model`` for n-sample windows."""
        freqs = np.fft.rfftfreq(n, dt)
        psd = noise_stats.noise_psd(model, freqs) + quantization_psd(model, freqs, dt)
        weights = noise_stats.bin_multiplicity(n) * dt / psd  # dt: periodogram |X|^2 dt / n in PSD units
        line_bins = (freqs >= f_min_hz) & (freqs < 0.5 / dt - 1e-9)
        if not line_bins.any():
            raise ValueError(f"no frequency bin between f_min_hz {f_min_hz:g} and Nyquist {0.5 / dt:g} Hz "
                             f"in a {n}-sample window")
        return cls(n, dt, weights, line_bins)

    @property
    def freqs(self) -> np.ndarray:
        """Bin frequencies, Hz."""
        return np.fft.rfftfreq(self.n, self.dt)


def detrend(x: np.ndarray) -> np.ndarray:
    """x (..., n, 6) minus its least-squares line along the window axis."""
    n = x.shape[-2]
    t = np.arange(n) - (n - 1) / 2.0
    centred = x - x.mean(axis=-2, keepdims=True)
    slope = np.einsum("i,...ic->...c", t, centred) / (t @ t)
    return centred - t[:, None] * slope[..., None, :]


@dataclass
class WindowStats:
    """Statistics of ``nw`` windows: each field (nw, 6)."""

    level: np.ndarray
    line: np.ndarray
    line_bin: np.ndarray
    power: np.ndarray
    """(nw, 6, nb) whitened power of the searched bins (chi-square(2) each under the model)."""
    mean: np.ndarray
    finite: np.ndarray
    ties: np.ndarray
    """Samples exactly at the window's largest or smallest value, whichever has more (flat tops of a clip)."""


def window_stats(grid: WindowGrid, x: np.ndarray) -> WindowStats:
    """Statistics of windows x (nw, n, 6); a channel with a non-finite sample in a window gets neutral values."""
    finite = np.all(np.isfinite(x), axis=1)
    xs = np.where(np.isfinite(x), x, 0.0)
    # a Hann taper keeps an off-bin line's leakage out of the median (the noise level) and out of far bins
    taper = np.hanning(grid.n + 2)[1:-1]
    taper = taper / np.sqrt(np.mean(taper**2))
    spec = np.swapaxes(np.fft.rfft(detrend(xs) * taper[:, None], axis=1), 1, 2)  # (nw, 6, nf)
    level = noise_stats.robust_scale2(spec, grid.weights, grid.n)
    power = noise_stats.whitened_power(spec, grid.weights, grid.n, level)[..., grid.line_bins]
    k = np.argmax(power, axis=-1)
    line = np.take_along_axis(power, k[..., None], axis=-1)[..., 0]
    bins = np.flatnonzero(grid.line_bins)[k]
    level = np.where(finite, level, 1.0)
    line = np.where(finite, line, 0.0)
    ties = np.maximum((xs == xs.max(axis=1, keepdims=True)).sum(axis=1),
                      (xs == xs.min(axis=1, keepdims=True)).sum(axis=1))
    ties = np.where(finite & (np.ptp(xs, axis=1) > 0), ties, 0)
    power = np.where(finite[..., None], power, 0.0)
    return WindowStats(level, line, bins, power, xs.mean(axis=1), finite, ties)


def span_ties(x: np.ndarray, span: int = CLIP_SPAN_WINDOWS) -> np.ndarray:
    """(nw - span + 1, 6) for contiguous windows x (nw, n, 6) (non-finite samples are ignored): for each window from
    the span-th on, the samples of it and the span - 1 before exactly at the span's largest (smallest) value when
    this window reaches it, the larger of the two counts; 0 on a constant span.

    The span's extreme is the extreme of its windows' extremes, so only the windows holding it add their counts at
    it: per-window extremes and their tie counts carry everything (windows of 8 samples, every 8 samples, cost no
    more than windows of 64)."""
    nw = x.shape[0] - span + 1
    if nw <= 0:
        return np.zeros((0, 6), int)
    xs = np.where(np.isfinite(x), x, np.nan)
    out = np.zeros((nw, 6), int)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows (before the first) stay NaN
        wmax, wmin = np.nanmax(xs, axis=1), np.nanmin(xs, axis=1)
    tops = []
    for sign, ext in ((1, wmax), (-1, wmin)):
        # the span's extreme: a trailing running maximum (NaN windows never hold it)
        top = maximum_filter1d(np.nan_to_num(ext * sign, nan=-np.inf), span, axis=0,
                               origin=(span - 1) // 2)[span - 1:] * sign
        tops.append(top)
        w, c = np.nonzero(ext[span - 1:] == top)  # this window reaches it
        if len(w) == 0:
            continue
        rows = w[:, None] + np.arange(span)
        count = (xs == ext[:, None, :]).sum(axis=1)
        total = ((ext[rows, c[:, None]] == top[w, c][:, None]) * count[rows, c[:, None]]).sum(axis=1)
        out[w, c] = np.maximum(out[w, c], total)
    return np.where(tops[0] == tops[1], 0, out)
