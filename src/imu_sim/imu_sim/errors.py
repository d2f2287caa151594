"""IMU error terms of the sensor-model YAML, each switchable: deterministic and stochastic.

Every stochastic term draws from its own generator, seeded from (seed, triad, term),
so switching one term off leaves the realisations of the others unchanged (the
diagnosis can add or remove one term at a time). Rates are the mean rate over
each sample interval (increment / dt), rad/s or m/s^2.

Allan-deviation signatures (sigma(tau)) these generate:
white noise N -> N/sqrt(tau); bias instability B (flicker, one-sided PSD B^2/(pi f)) ->
plateau B*sqrt(2 ln2/pi) = 0.664 B; Gauss-Markov (sigma B, time constant T) -> the
GM curve peaking near tau = 1.89 T; rate random walk K -> K sqrt(tau/3); rate ramp R
-> R tau/sqrt(2); quantization Q -> sqrt(3) Q/tau, made by rounding the cumulative
increments to an LSB of Q*sqrt(12) (the remainder is carried, as the real unit does).
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from nav_core.sensor_model import TriadModel

TERMS = ("bias", "scale_factor", "misalignment", "quantization", "white_noise", "bias_instability",
         "rate_random_walk", "rate_ramp")
"""Switchable sensor-model terms (names of nav_core.sensor_model fields)."""
_TRIAD_INDEX = {"gyro": 0, "accel": 1}


def term_rng(seed: int, triad: str, term: str) -> np.random.Generator:
    """The generator of one (triad, term): independent of which other terms are on."""
    key = sum(ord(c) * 31**i for i, c in enumerate(term)) % (2**31)
    return np.random.default_rng([int(seed), _TRIAD_INDEX.get(triad, 7), key])


def white_rate(n: int, dt: float, density, rng) -> np.ndarray:
    """Mean rate over each interval of white noise with density N (unit/sqrt(s)), shape (n, 3)."""
    return rng.standard_normal((n, 3)) * (np.asarray(density, float) / np.sqrt(dt))


def flicker(n: int, dt: float, coeff, rng) -> np.ndarray:
    """Flicker (1/f) noise, one-sided PSD B^2/(pi f) (Allan plateau 0.664 B), shape (n, 3); O(N log N) by FFT."""
    coeff = np.asarray(coeff, float)
    m = 2 * n  # twice as long, then cut: avoids circular wrap-around of the slowest components
    freqs = np.fft.rfftfreq(m, dt)
    scale = np.zeros_like(freqs)
    scale[1:] = np.sqrt(1.0 / (np.pi * freqs[1:]) / (2.0 * dt))
    spectrum = np.fft.rfft(rng.standard_normal((3, m)), axis=1) * scale
    return (np.fft.irfft(spectrum, n=m, axis=1)[:, :n] * coeff[:, None]).T


def gauss_markov(n: int, dt: float, sigma, tau, rng) -> np.ndarray:
    """First-order Gauss-Markov process, steady-state sigma, correlation time tau (s), shape (n, 3); O(N)."""
    out = np.zeros((n, 3))
    for axis in range(3):
        s, T = float(np.ravel(sigma)[axis]), float(np.ravel(tau)[axis])
        if s <= 0 or T <= 0:
            continue
        phi = np.exp(-dt / T)
        drive = rng.standard_normal(n) * s * np.sqrt(1 - phi**2)
        drive[0] = rng.standard_normal() * s
        out[:, axis] = lfilter([1.0], [1.0, -phi], drive)
    return out


def random_walk(n: int, dt: float, coeff, rng) -> np.ndarray:
    """Rate random walk with coefficient K (unit/s/sqrt(s)), starting at 0, shape (n, 3)."""
    return np.cumsum(rng.standard_normal((n, 3)) * (np.asarray(coeff, float) * np.sqrt(dt)), axis=0)


def bias_instability(n: int, dt: float, triad: TriadModel, rng) -> np.ndarray:
    """Bias instability: Gauss-Markov on axes with a correlation time > 0, flicker on the others."""
    b = np.asarray(triad.bias_instability, float)
    tau = np.asarray(triad.bias_correlation_time, float)
    is_gm = tau > 0
    out = np.zeros((n, 3))
    if np.any(b[~is_gm] > 0):
        out += flicker(n, dt, np.where(is_gm, 0.0, b), rng)
    if np.any(b[is_gm] > 0):
        out += gauss_markov(n, dt, np.where(is_gm, b, 0.0), tau, rng)
    return out


def stochastic_rate(triad_name: str, triad: TriadModel, t: np.ndarray, dt: float, seed: int,
                    terms=TERMS) -> np.ndarray:
    """Sum of the enabled stochastic terms and the rate ramp, mean rate per interval, shape (n, 3)."""
    n = len(t)
    out = np.zeros((n, 3))
    if "white_noise" in terms and np.any(triad.white_noise > 0):
        out += white_rate(n, dt, triad.white_noise, term_rng(seed, triad_name, "white_noise"))
    if "bias_instability" in terms and np.any(triad.bias_instability > 0):
        out += bias_instability(n, dt, triad, term_rng(seed, triad_name, "bias_instability"))
    if "rate_random_walk" in terms and np.any(triad.rate_random_walk > 0):
        out += random_walk(n, dt, triad.rate_random_walk, term_rng(seed, triad_name, "rate_random_walk"))
    if "rate_ramp" in terms and np.any(triad.rate_ramp != 0):
        out += np.outer(t - t[0] + 0.5 * dt, triad.rate_ramp)
    return out


def deterministic_matrix(triad: TriadModel, terms=TERMS) -> np.ndarray:
    """I + diag(scale_factor) + misalignment, with only the enabled terms."""
    mat = np.eye(3)
    if "scale_factor" in terms:
        mat = mat + np.diag(triad.scale_factor)
    if "misalignment" in terms:
        mat = mat + triad.misalignment
    return mat


def quantization_lsb(triad: TriadModel) -> np.ndarray:
    """Increment LSB (rad or m/s) whose rounding gives Allan quantization Q: LSB = Q sqrt(12)."""
    return np.asarray(triad.quantization, float) * np.sqrt(12.0)


def quantize_carry(increments: np.ndarray, lsb) -> np.ndarray:
    """Round increments (n, 3) to multiples of ``lsb`` (3,) carrying the remainder (cumulative rounding)."""
    lsb = np.asarray(lsb, float)
    out = np.array(increments, dtype=float)
    for axis in np.flatnonzero(lsb > 0):
        counts = np.round(np.cumsum(increments[:, axis]) / lsb[axis])
        out[:, axis] = np.diff(counts, prepend=0.0) * lsb[axis]
    return out
