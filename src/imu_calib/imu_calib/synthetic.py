"""Synthetic IMU noise with known Allan coefficients, for tests and benchmarks.

Rate-type output (rad/s or m/s^2) with the five IEEE terms (SI, per axis):
quantization Q (rad; the integrated angle is rounded to the LSB ``Q*sqrt(12)``
with the remainder carried), white noise N (rad/sqrt(s)), bias instability B
(rad/s; flicker noise by spectral shaping of white noise, or one Gauss-Markov
process of correlation time ``tau_c`` s and sigma B), rate
random walk K (rad/s/sqrt(s)) and rate ramp R (rad/s^2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel

FLICKER_LEVEL = 2.0 * np.log(2.0) / np.pi
"""Allan variance of flicker rate noise divided by B^2 (IEEE Std 952: sigma = 0.664 B)."""


@dataclass(frozen=True)
class NoiseTerms:
    """The five Allan coefficients of one axis (SI) and the Gauss-Markov correlation time (0 = flicker)."""

    Q: float = 0.0
    N: float = 0.0
    B: float = 0.0
    K: float = 0.0
    R: float = 0.0
    tau_c: float = 0.0


def gauss_markov(n: int, rate_hz: float, sigma: float, tau_c: float, rng) -> np.ndarray:
    """Stationary first-order Gauss-Markov sequence: steady-state sigma, correlation time tau_c s."""
    phi = np.exp(-1.0 / (rate_hz * tau_c))
    drive = rng.standard_normal(n) * sigma * np.sqrt(1.0 - phi * phi)
    x0 = rng.standard_normal() * sigma
    out, _ = signal.lfilter([1.0], [1.0, -phi], drive, zi=[phi * x0])
    return out


def gm_avar(taus, sigma, tau_c):
    """Allan variance of a Gauss-Markov rate of steady-state ``sigma`` and correlation time ``tau_c`` s."""
    x = np.asarray(taus, dtype=float) / tau_c
    return 2.0 * sigma ** 2 / x ** 2 * (x - 1.5 + 2.0 * np.exp(-x) - 0.5 * np.exp(-2.0 * x))


def flicker(n: int, rate_hz: float, B: float, rng) -> np.ndarray:
    """Flicker (1/f) rate noise of bias-instability coefficient B, by spectral shaping of white noise.

    One-sided PSD ``B^2 / (pi f)`` from 1/(2 n dt) to Nyquist, so the Allan
    variance is flat at ``(2 ln 2 / pi) B^2``. Twice the length is synthesised
    and the first half kept, so the FFT's circularity does not show.
    """
    size = 2 * n
    freqs = np.fft.rfftfreq(size, 1.0 / rate_hz)
    gain = np.zeros_like(freqs)
    # unit white noise has one-sided PSD 2/fs; |H|^2 = S(f) fs / 2
    # the sinc is the average over each sample interval: samples are increments / dt, as the BP3010 gives
    gain[1:] = np.sqrt(B ** 2 / (np.pi * freqs[1:]) * rate_hz / 2.0) * np.sinc(freqs[1:] / rate_hz)
    return np.fft.irfft(np.fft.rfft(rng.standard_normal(size)) * gain, size)[:n]


def quantize_rate(rate, rate_hz: float, lsb: float) -> np.ndarray:
    """Round the integrated signal to ``lsb`` (remainder carried) and differentiate back to a rate."""
    angle = np.concatenate(([0.0], np.cumsum(rate) / rate_hz))
    return np.diff(np.round(angle / lsb)) * lsb * rate_hz


def noise(n: int, rate_hz: float, terms: NoiseTerms, rng) -> np.ndarray:
    """One axis of rate noise (n,) with the given terms; zero mean apart from the ramp and random walk."""
    dt = 1.0 / rate_hz
    out = rng.standard_normal(n) * terms.N / np.sqrt(dt)
    if terms.B > 0:
        out += (gauss_markov(n, rate_hz, terms.B, terms.tau_c, rng) if terms.tau_c > 0
                else flicker(n, rate_hz, terms.B, rng))
    if terms.K > 0:
        out += np.cumsum(rng.standard_normal(n)) * terms.K * np.sqrt(dt)
    if terms.R > 0:
        out += terms.R * np.arange(n) * dt
    if terms.Q > 0:
        out = quantize_rate(out, rate_hz, terms.Q * np.sqrt(12.0))
    return out


def true_avar(taus, terms: NoiseTerms) -> np.ndarray:
    """Nominal Allan variance of :func:`noise` at ``taus`` s (quantization and flicker are nominal laws)."""
    taus = np.asarray(taus, dtype=float)
    out = 3 * terms.Q ** 2 / taus ** 2 + terms.N ** 2 / taus + terms.K ** 2 * taus / 3 + terms.R ** 2 * taus ** 2 / 2
    if terms.B > 0 and terms.tau_c > 0:
        out = out + gm_avar(taus, terms.B, terms.tau_c)
    elif terms.B > 0:
        out = out + FLICKER_LEVEL * terms.B ** 2
    return out


def terms_of(model: SensorModel, triad: str, axis: int) -> NoiseTerms:
    """The noise terms of one axis of a sensor model."""
    tri = model.triad(triad)
    return NoiseTerms(tri.quantization[axis], tri.white_noise[axis], tri.bias_instability[axis],
                      tri.rate_random_walk[axis], tri.rate_ramp[axis], tri.bias_correlation_time[axis])


def static_recording(model: SensorModel, duration_s: float, rng, gyro_true=(0.0, 0.0, 0.0),
                     accel_true=(0.0, 0.0, 9.80665), t0: float = 0.0) -> ImuRecording:
    """A static recording: constant true rate (rad/s) and specific force (m/s^2) through ``model`` plus noise."""
    rate = model.sample_rate_hz
    n = int(round(duration_s * rate))
    t = t0 + np.arange(n) / rate
    out = {}
    for name, true in (("gyro", gyro_true), ("accel", accel_true)):
        tri = model.triad(name)
        clean = tri.apply(np.asarray(true, dtype=float)[None, :])
        out[name] = clean + np.column_stack([noise(n, rate, terms_of(model, name, i), rng) for i in range(3)])
    return ImuRecording(t, out["gyro"], out["accel"], source="synthetic")
