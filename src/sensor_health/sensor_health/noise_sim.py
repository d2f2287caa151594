"""The sensor model's own noise, simulated for the Monte Carlo thresholds (white, quantization, Gauss-Markov or
flicker bias instability, rate random walk). Not a simulator of motion: the health monitor must stay silent on
exactly this, so its thresholds are set on it."""
from __future__ import annotations

import numpy as np
from scipy import signal

from nav_core.sensor_model import SensorModel

FLICKER_TAUS_S = (3.0, 30.0, 300.0)
"""Flicker (1/f) bias instability is approximated by equal Gauss-Markov terms at these correlation times."""


def _gauss_markov(rng, n: int, dt: float, sigma: float, tau_s: float) -> np.ndarray:
    """Stationary first-order Gauss-Markov series (n,), sd sigma, correlation time tau_s."""
    phi = np.exp(-dt / tau_s)
    e = rng.normal(0.0, sigma * np.sqrt(1 - phi**2), n)
    e[0] = rng.normal(0.0, sigma)
    return signal.lfilter([1.0], [1.0, -phi], e)


def channel_noise(rng, n: int, dt: float, white: float, bias_instability: float = 0.0, correlation_time_s: float = 0.0,
                  walk: float = 0.0, quantization: float = 0.0) -> np.ndarray:
    """n samples (n,) of one channel's noise at interval dt s from its model terms (white per sqrt(s), bias
    instability, its correlation time s (0: flicker), rate random walk per sqrt(s), quantization), zero turn-on bias."""
    x = rng.normal(0.0, white / np.sqrt(dt), n)
    if bias_instability > 0:
        taus = (correlation_time_s,) if correlation_time_s > 0 else FLICKER_TAUS_S
        for tau in taus:
            x += _gauss_markov(rng, n, dt, bias_instability / np.sqrt(len(taus)), tau)
    if walk > 0:
        x += np.cumsum(rng.normal(0.0, walk * np.sqrt(dt), n))
    if quantization > 0:  # counted increments of lsb = Q sqrt(12) with the remainder carried: outputs on a lattice
        lsb = quantization * np.sqrt(12.0)
        counts = np.round(np.cumsum(x) * dt / lsb + rng.uniform())
        x = np.diff(np.concatenate([[np.round(x[0] * dt / lsb)], counts])) * lsb / dt
    return x


def model_noise(model: SensorModel, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
    """n samples (n, 6) of the model's noise at interval dt s (rad/s, m/s^2), zero turn-on bias."""
    out = np.zeros((n, 6))
    for c in range(6):
        tri, i = model.triad(("gyro", "accel")[c // 3]), c % 3
        out[:, c] = channel_noise(rng, n, dt, tri.white_noise[i], tri.bias_instability[i],
                                  tri.bias_correlation_time[i], tri.rate_random_walk[i], tri.quantization[i])
    return out
