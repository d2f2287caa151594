"""Tests that are not a linear regression on the truth: vibration line, quantization lattice, GM and RW bias.

* vibration: the largest line of the whitened periodogram (above 10 cycles per run),
  chi-square(2) per bin under the null; the frequency is the maximum of the joint (all channels) whitened DTFT
  power, its interval the profile-likelihood one.
* quantization: raw recorded values lie on a lattice: Rayleigh statistic
  z = n |mean exp(2 pi i x / q)|^2 at the lattice step q found from the gaps between
  distinct values (z ~ Exp(1) for continuous values).
* bias_random_walk / gauss_markov_bias: exact likelihood of the block means under the model's
  noise plus the term (:mod:`local_level`, a Kalman filter; the model's noise level free), the
  term's level and (GM) correlation time profiled; :func:`walk_backgrounds` gives the filter the
  model's own noise.
* the same two when the model's noise has flicker (which no finite filter holds) or a
  Gauss-Markov bias of its own: Whittle likelihood of the detrended block means under the model
  PSD (level free) against the PSD plus the extra term.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nav_core.noise_stats import block_means, fit_line_frequency, line_lr, vibration_scan  # noqa: F401 (API)
from nav_core.sensor_model import SensorModel

from imu_sim.diagnose import local_level
from imu_sim.diagnose.case import effective_model
from imu_sim.diagnose.spectral import noise_psd

MAX_BLOCKS = 4096
"""Block-averaged series length for the Whittle tests."""


@dataclass
class NoiseFinding:
    """Statistic, per-channel statistics, parameters with intervals and the physics entry."""

    lr: float
    lr_channels: np.ndarray
    params: dict = field(default_factory=dict)
    intervals: dict = field(default_factory=dict)
    physics: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)


def _mean_sin(t, dt, f, phase=0.0):
    w = 2 * np.pi * f
    return (np.cos(w * (t - dt) + phase) - np.cos(w * t + phase)) / (w * dt)


def _mean_cos(t, dt, f, phase=0.0):
    w = 2 * np.pi * f
    return (np.sin(w * t + phase) - np.sin(w * (t - dt) + phase)) / (w * dt)


def vibration_fit(wh, resid: np.ndarray, t_abs: np.ndarray, freq: float, ch_peak: int, gls_fn):
    """Per-channel interval-mean sinusoid at ``freq`` with a common phase; amplitudes signed, SI units."""
    dt = wh.dt
    s, c = _mean_sin(t_abs, dt, freq), _mean_cos(t_abs, dt, freq)
    resid_f = np.fft.rfft(resid, axis=0)
    per = []
    for ch in range(6):
        per.append(gls_fn(wh, resid_f, {ch: np.column_stack([s, c])}, 2))
    a, b = per[ch_peak].theta
    phase = float(np.arctan2(b, a))
    u = np.array([np.cos(phase), np.sin(phase)])
    amps = np.array([p.theta @ u for p in per])
    sds = np.array([np.sqrt(u @ p.cov @ u) for p in per])
    lrs = np.array([p.lr for p in per])
    return amps, sds, lrs, phase


def lattice(x: np.ndarray):
    """Lattice step q, its standard error and Rayleigh z of values x (n,); q = 0 if no step is found."""
    u = np.unique(x)
    n = len(x)
    if len(u) < 3:
        return 0.0, 0.0, 0.0, len(u) / n
    d = np.diff(u)
    d = d[d > 1e-12 * max(np.max(np.abs(u)), 1e-300)]
    if len(d) == 0:
        return 0.0, 0.0, 0.0, len(u) / n
    q0 = np.min(d)
    k = np.round(d / q0)
    q = float(np.sum(d * k) / np.sum(k * k))
    phase = 2 * np.pi * (x - u[0]) / q
    z = float(n * np.abs(np.mean(np.exp(1j * phase))) ** 2)
    idx = np.round((u - u[0]) / q)
    if len(u) > 2 and np.ptp(idx) > 0:
        coef = np.polyfit(idx, u, 1)
        fit = np.polyval(coef, idx)
        s2 = np.sum((u - fit) ** 2) / max(len(u) - 2, 1)
        se = float(np.sqrt(s2 / np.sum((idx - idx.mean()) ** 2)))
        q = float(coef[0])
    else:
        se = 0.0
    return q, se, z, len(u) / n


def print_digits(x: np.ndarray, sample: int = 2000) -> int | None:
    """Fewest significant decimal digits that reproduce every value of x (a sample of them), None above 15."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x) & (x != 0)][:: max(1, len(x) // sample)]
    for digits in range(1, 16):
        if all(float(f"{v:.{digits}g}") == v for v in x):
            return digits
    return None


def print_step(x: np.ndarray, digits: int) -> float:
    """Largest step of a decimal print lattice of ``digits`` significant digits over the values x."""
    top = float(np.max(np.abs(x)))
    return 10.0 ** (np.floor(np.log10(top)) - digits + 1) if top > 0 else 0.0


def detrended(xb: np.ndarray) -> np.ndarray:
    """xb minus its least-squares line (per column).

    A random walk's periodogram is about twice its spectrum, half of it one random ramp (the end-to-end
    drift) shared by every bin; removing the fitted line leaves close to the spectrum. A least-squares line
    is a projection, so on white noise it only removes power (a line through the noisy end points would
    add a ramp, i.e. a random-walk signature).
    """
    t = np.arange(len(xb)) - (len(xb) - 1) / 2.0
    centred = xb - xb.mean(axis=0)
    slope = (t @ centred) / (t @ t)
    return centred - np.multiply.outer(t, slope)


def block_interval(n: int) -> int:
    """Samples per block so that a run of n samples gives at most MAX_BLOCKS block means."""
    return max(1, int(np.ceil(n / MAX_BLOCKS)))


def walk_backgrounds(model: SensorModel, tb: float, yb: np.ndarray):
    """Per channel the model's noise for :func:`local_level.fit` at block interval tb s; None if it has flicker.

    The filter's unit is the white level of the block means yb (nb, 6), estimated from them (median absolute
    difference): the model's walk and Gauss-Markov terms keep their physical size whatever its white level says
    (a fitted term's size is physical too, so a term found and added comes back as the same ratio).
    """
    mdl = effective_model(model)
    out = []
    for c in range(6):
        tri, i = mdl.triad(("gyro", "accel")[c // 3]), c % 3
        b, tc = tri.bias_instability[i], tri.bias_correlation_time[i]
        if b > 0 and tc <= 0:
            return None
        white = max((np.median(np.abs(np.diff(yb[:, c]))) / 0.6745) ** 2 / 2, 1e-300)
        bg = local_level.Background(rw_ratio=tri.rate_random_walk[i] ** 2 * tb / white)
        if b > 0:
            bg.gm_var, bg.phi = b**2 * local_level.block_gm_variance(tc, tb) / white, float(np.exp(-tb / tc))
        out.append(bg)
    return out


def periodogram(xb: np.ndarray, tb: float):
    """Two-sided periodogram (unit^2/Hz) per column without DC: freqs (nf,), I (nf, k)."""
    nb = len(xb)
    spec = np.fft.rfft(xb - xb.mean(axis=0), axis=0)[1:]
    return np.fft.rfftfreq(nb, tb)[1:], np.abs(spec) ** 2 * tb / nb


def _whittle_profile(i_f, s0, extra, ratios):
    """Whittle log-likelihood (level profiled) for S = a (s0 + r extra), each r; shape (len(ratios),)."""
    s = s0[None, :] + ratios[:, None] * extra[None, :]
    a = np.mean(i_f[None, :] / s, axis=1)
    return -np.sum(np.log(a[:, None] * s), axis=1) - len(i_f), a


def whittle_extra(i_f: np.ndarray, s0: np.ndarray, extra: np.ndarray):
    """Best level c of ``extra`` added to a free-level ``s0``: (lr, c, c interval 95 %, loglik by c)."""
    ref = np.median(s0[:8]) / max(np.median(extra[:8]), 1e-300)
    # 20 points per decade: the interval ends are read off this grid
    ratios = np.concatenate([[0.0], ref * np.logspace(-5, 4, 181)])
    ll, a = _whittle_profile(i_f, s0, extra, ratios)
    best = int(np.argmax(ll))
    lr = 2 * (ll[best] - ll[0])
    c = a * ratios
    inside = 2 * (ll[best] - ll) <= 3.84
    return float(max(lr, 0.0)), float(c[best]), (float(c[inside].min()), float(c[inside].max())), ll, c


def noise_model_psd(model: SensorModel, freqs: np.ndarray, tb: float) -> np.ndarray:
    """The model's two-sided PSD at block level (6, nf)."""
    return noise_psd(model, np.concatenate([[0.0], freqs]), tb)[:, 1:]


def rw_extra(freqs: np.ndarray) -> np.ndarray:
    """Two-sided PSD of a rate random walk with K = 1: 1 / (2 pi f)^2."""
    return 1.0 / (2 * np.pi * freqs) ** 2


def gm_extra(freqs: np.ndarray, tc: float) -> np.ndarray:
    """Two-sided PSD of a Gauss-Markov process with sigma = 1, correlation time tc s."""
    return 2 * tc / (1 + (2 * np.pi * freqs * tc) ** 2)


def predicted_avar(psd_fn, taus: np.ndarray) -> np.ndarray:
    """Allan variance of a two-sided PSD: 4 int_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df."""
    f = np.logspace(-7, 3, 6000)
    s = psd_fn(f)
    out = []
    for tau in taus:
        kern = np.sin(np.pi * f * tau) ** 4 / (np.pi * f * tau) ** 2
        out.append(4 * np.trapezoid(s * kern, f))
    return np.array(out)
