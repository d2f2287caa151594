"""The bias CUSUMs' false-alarm rate measured on long simulated runs of the model's noise, and thresholds read off it.

On the model's noise the bias filter (``bias_filter``) has no motion to learn (every regressor is inside its dead
zone), so it is a scalar Kalman filter of a random-walk bias on the window means; its innovation feeds the two-sided
CUSUM. The innovations are autocorrelated where the unit's slow wander (Gauss-Markov or flicker bias, rate random
walk) is not what the filter's walk assumes, and that slow excess sets the CUSUM's tail: run lengths measured on
8000 windows (2.2 h) and extended log-linearly to the 10-h budget understated it (a scalar replica gave 0.3-0.7
false crossings per 10 h per channel where 0.0125 was budgeted). Here the window means themselves are simulated (the
white part as the window mean's sd, each Gauss-Markov term at window resolution with its in-window averaging, the
rate random walk), thousands of hours in a compiled loop without the 64-Hz samples, and the alarms are *counted* on
every threshold at once (one alarm per excursion of the CUSUM above it): h is where the counted rate meets the
channel's share where the run holds enough such alarms, else an exponential tail of the largest excursions extended
to it (said so in ``BiasTail.how``; ``bench_sensor_health.py --bias-tail`` counts the rate at h on a longer run).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from nav_core.sensor_model import SensorModel
from sensor_health.noise_sim import FLICKER_TAUS_S

EXCURSION_FLOOR = 2.0
"""Excursion maxima (sd) below this are not kept."""
MEASURED_ALARMS = 20
"""Alarms the counted rate needs at h for h to be read off the counts ('measured')."""
TAIL_EXCURSIONS = 200
"""Beyond that, an exponential tail fitted to this many largest excursion maxima ('extended')."""


@dataclass
class BiasTail:
    """Measured false alarms of one channel's two-sided bias CUSUM: the maxima of its excursions."""

    hours: float
    maxima: np.ndarray
    """Maxima (sd) of the CUSUMs' excursions above EXCURSION_FLOOR in ``hours`` of simulated noise."""
    h: float
    """The threshold for the share (sd)."""
    how: str
    """'measured' (at least MEASURED_ALARMS counted above h) or 'extended' (an exponential tail beyond them)."""

    def per_10h(self, h) -> np.ndarray:
        """Counted false alarms per 10 h at thresholds h."""
        return np.array([np.count_nonzero(self.maxima > v) for v in np.atleast_1d(h)]) * 10.0 / self.hours


def slow_terms(model: SensorModel, c: int, window_s: float):
    """(phi (m,), innovation sd (m,)) of channel c's Gauss-Markov terms at window resolution, their sd scaled by the
    in-window average, and the rate random walk's sd per window."""
    tri, i = model.triad(("gyro", "accel")[c // 3]), c % 3
    b, tc = float(tri.bias_instability[i]), float(tri.bias_correlation_time[i])
    taus = (tc,) if tc > 0 else FLICKER_TAUS_S
    phi, sd = [], []
    for tau in taus if b > 0 else ():
        u = window_s / tau
        avg = np.sqrt(2.0 * (u - 1.0 + np.exp(-u)) / u**2)  # sd of a window's average over a point value's
        p = np.exp(-u)
        phi.append(p)
        sd.append(b / np.sqrt(len(taus)) * avg * np.sqrt(1.0 - p**2))
    return np.array(phi), np.array(sd), float(tri.rate_random_walk[i]) * np.sqrt(window_s)


@numba.njit(cache=True)
def _excursion_maxima(n, seed, white_sd, levels, gm_phi, gm_sd, rw_sd, q, k, floor, warm):
    """Maxima above ``floor`` of the excursions (from 0 back to 0) of the two-sided CUSUM (drift k) on the
    standardised innovations of a scalar random-walk Kalman filter (walk variance q per window, measurement variance
    white_sd^2 times max(1, a level drawn from ``levels``)) over n simulated window means; the first ``warm``
    windows only train the filter.

    A threshold h gives one alarm per excursion whose maximum passes it: the monitor relearns the bias after an
    event, so the crossings a restart at 0 would add within one excursion are not events."""
    np.random.seed(seed)
    m = len(gm_phi)
    gm = np.zeros(m)
    for j in range(m):
        gm[j] = np.random.normal() * gm_sd[j] / np.sqrt(1.0 - gm_phi[j] ** 2)
    rw = 0.0
    out = np.zeros(n // 16 + 16)
    count = 0
    side = np.zeros(2)
    top = np.zeros(2)
    b, p = 0.0, 0.0
    for w in range(n):
        y = white_sd * np.random.normal() + rw
        for j in range(m):
            gm[j] = gm_phi[j] * gm[j] + gm_sd[j] * np.random.normal()
            y += gm[j]
        rw += rw_sd * np.random.normal()
        r = white_sd**2 * max(1.0, levels[np.random.randint(len(levels))])
        if w == 0:
            b, p = y, r
            continue
        p += q
        s = p + r
        e = y - b
        z = e / np.sqrt(s)
        g = p / s
        b += g * e
        p -= g * p
        if w < warm:
            continue
        for i in range(2):
            side[i] = max(0.0, side[i] + (z if i == 0 else -z) - k)
            top[i] = max(top[i], side[i])
            if side[i] == 0.0 and top[i] > 0.0:
                if top[i] > floor and count < len(out):
                    out[count] = top[i]
                    count += 1
                top[i] = 0.0
    return out[:count]


def threshold_for(maxima: np.ndarray, hours: float, share_per_10h: float):
    """(h, how) where the alarms per 10 h (excursion maxima above h) meet ``share_per_10h``: read off the counts
    where at least MEASURED_ALARMS pass it ('measured'); else an exponential tail of the TAIL_EXCURSIONS largest
    maxima (maximum likelihood) extended to it ('extended')."""
    top = np.sort(maxima)[::-1]
    want = share_per_10h * hours / 10.0  # alarms the share allows in this run
    if want >= MEASURED_ALARMS and len(top) > want:
        return float(top[int(np.floor(want))]), "measured"
    m = min(TAIL_EXCURSIONS, len(top) - 1)
    if m < 10:
        return float(top[0]) if len(top) else EXCURSION_FLOOR, "extended"
    u = top[m]
    scale = float(np.mean(top[:m] - u))
    return float(u + scale * np.log(m / want)), "extended"


def bias_tail(model: SensorModel, c: int, window_s: float, white_sd: float, levels: np.ndarray, q: float, k: float,
              share_per_10h: float, hours: float, warm: int, seed: int = 0) -> BiasTail:
    """Channel c's bias CUSUM (drift k, filter walk q per window) counted over ``hours`` of the model's simulated
    window means (the window's noise level factor drawn from ``levels``), and its threshold for ``share_per_10h``."""
    phi, sd, rw = slow_terms(model, c, window_s)
    n = int(round(hours * 3600.0 / window_s))
    maxima = _excursion_maxima(n + warm, int(seed) * 7 + c, float(white_sd), np.asarray(levels, float), phi, sd, rw,
                               float(q), float(k), EXCURSION_FLOOR, warm)
    h, how = threshold_for(maxima, hours, share_per_10h)
    return BiasTail(hours, maxima, h, how)
