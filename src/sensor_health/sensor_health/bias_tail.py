"""The bias CUSUMs' false-alarm rate measured on simulated runs of the model's noise, and thresholds read off it.

On the model's noise the bias filter (``bias_filter``) has no motion to learn (every regressor is inside its dead
zone), so it is a scalar Kalman filter of a random-walk bias on the window means; its innovation feeds the two-sided
CUSUM. The innovations are autocorrelated where the unit's slow wander (Gauss-Markov or flicker bias, rate random
walk) is not what the filter's walk assumes, and that slow excess sets the CUSUM's tail: run lengths measured on
8000 windows (2.2 h) and extended log-linearly to the 10-h budget understated it. Here the window means themselves
are simulated (the white part as the window mean's sd, each Gauss-Markov term at window resolution with its
in-window averaging, the rate random walk) in a compiled loop without the 64-Hz samples, and the alarms are
*counted* (one alarm per excursion of the CUSUM above h).

A share of 0.0125 per 10 h is one alarm per 800 h: a plain count that reads it needs ~16000 h per channel. An
exponential tail fitted to the 200 largest of 1000 h and carried 80x beyond them understated the gyros' (on the
benchmark's model, 100000 h count 0.022 and 0.030 per 10 h at its gx and gy h): the slow wander makes the far tail
heavier than the counted one. So beyond the count the tail is *split* (multilevel splitting, fixed effort): the
Markov state of the simulation (the Gauss-Markov terms, the walk, the filter's bias and variance, the CUSUM's side)
is kept where a counted excursion first passes the highest level ENTRY_EXCURSIONS of them pass, and SPLIT_RUNS
continuations from those states (drawn with replacement, fresh noise) measure the chance of passing each next
level, set where about SPLIT_P of them do; the rate at a level is the counted rate at the entry times the chances
measured since. The continuations run the same recursion as the count, so the wander's tail is carried, not
assumed; h is read off the stage whose continuations the share's fraction still leaves SPLIT_P of. The split's one
blind spot is a jump from below the entry to beyond h in one window (the count alone samples it, ~once in 1000 h
where the drift k is large and the tail light, az's): there the exponential tail of the counts reads it better, so
h is the higher of the two (``BiasTail.how``: 'split', 'extended' (the exponential tail) or 'measured' (the counts,
where MEASURED_ALARMS pass h)).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from nav_core.sensor_model import SensorModel
from sensor_health.noise_sim import FLICKER_TAUS_S

EXCURSION_FLOOR = 2.0
"""Excursion maxima (sd) below this are not kept."""
MEASURED_ALARMS = 20
"""Alarms the counted rate needs at h for h to be read off the counts."""
TAIL_EXCURSIONS = 200
"""The exponential tail is fitted to this many largest excursion maxima."""
ENTRY_EXCURSIONS = 1000
"""The first split level: the one that many counted excursions pass (fewer: the floor)."""
SPLIT_RUNS = 8000
"""Continuations per split stage (each from a state kept at the stage's level)."""
SPLIT_P = 0.1
"""Each next level is the highest that at least this fraction of a stage's continuations pass."""
SPLIT_STEPS = 40
"""Candidate next levels per stage, a quarter of the counted tail's mean excess apart."""
_SNAPSHOTS = 5000
"""States kept at each entry candidate level (the entry's pool)."""


@dataclass
class BiasTail:
    """Measured false alarms of one channel's two-sided bias CUSUM: the counted excursion maxima and the split."""

    hours: float
    maxima: np.ndarray
    """Maxima (sd) of the CUSUMs' excursions above EXCURSION_FLOOR in ``hours`` of simulated noise."""
    h: float
    """The threshold for the share (sd)."""
    how: str
    """'measured' (at least MEASURED_ALARMS counted above h), 'split' (the split stages) or 'extended' (the
    exponential tail of the counts, where higher than the split's)."""
    levels: list = field(default_factory=list)
    """(level sd, false alarms per 10 h at it) of the split's stages."""

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
def _draw(st, white_sd, levels, gm_phi, gm_sd, rw_sd):
    """One simulated window mean and its measurement variance (white_sd^2 times max(1, a level drawn from
    ``levels``)); the walk and the Gauss-Markov terms in st = [walk, filter bias, its variance, Gauss-Markov
    terms...] step in place."""
    y = white_sd * np.random.normal() + st[0]
    for j in range(len(gm_phi)):
        st[3 + j] = gm_phi[j] * st[3 + j] + gm_sd[j] * np.random.normal()
        y += st[3 + j]
    st[0] += rw_sd * np.random.normal()
    return y, white_sd**2 * max(1.0, levels[np.random.randint(len(levels))])


@numba.njit(cache=True)
def _window(st, white_sd, levels, gm_phi, gm_sd, rw_sd, q):
    """One simulated window mean (:func:`_draw`) through the scalar random-walk Kalman filter (walk variance q per
    window); st is updated in place. Returns the standardised innovation."""
    y, r = _draw(st, white_sd, levels, gm_phi, gm_sd, rw_sd)
    st[2] += q
    s = st[2] + r
    e = y - st[1]
    g = st[2] / s
    st[1] += g * e
    st[2] -= g * st[2]
    return e / np.sqrt(s)


@numba.njit(cache=True)
def _count(n, seed, white_sd, levels, gm_phi, gm_sd, rw_sd, q, k, floor, warm, entries, cap):
    """Maxima above ``floor`` of the excursions (from 0 back to 0) of the two-sided CUSUM (drift k) over n simulated
    window means (the first ``warm`` only train the filter; the first sets its bias outright), and where an excursion
    first passes each level of ``entries``, the state (side value, sign, st) -> (maxima, states (E, cap, 5 + m),
    passes (E,)).

    A threshold h gives one alarm per excursion whose maximum passes it: the monitor relearns the bias after an
    event, so the crossings a restart at 0 would add within one excursion are not events."""
    np.random.seed(seed)
    m = len(gm_phi)
    st = np.zeros(3 + m)
    for j in range(m):
        st[3 + j] = np.random.normal() * gm_sd[j] / np.sqrt(1.0 - gm_phi[j] ** 2)
    st[1], st[2] = _draw(st, white_sd, levels, gm_phi, gm_sd, rw_sd)  # the first window sets the bias outright
    out = np.zeros(n // 16 + 16)
    count = 0
    ne = len(entries)
    states = np.zeros((ne, cap, 5 + m))
    passes = np.zeros(ne, np.int64)
    side, top = np.zeros(2), np.zeros(2)
    for w in range(1, n):
        z = _window(st, white_sd, levels, gm_phi, gm_sd, rw_sd, q)
        if w < warm:
            continue
        for i in range(2):
            side[i] = max(0.0, side[i] + (z if i == 0 else -z) - k)
            if side[i] > top[i]:
                for e in range(ne):
                    if top[i] <= entries[e] < side[i]:
                        if passes[e] < cap:
                            states[e, passes[e], 0] = side[i]
                            states[e, passes[e], 1] = 1.0 - 2.0 * i
                            states[e, passes[e], 2:] = st
                        passes[e] += 1
                top[i] = side[i]
            if side[i] == 0.0 and top[i] > 0.0:
                if top[i] > floor and count < len(out):
                    out[count] = top[i]
                    count += 1
                top[i] = 0.0
    return out[:count], states, passes


@numba.njit(cache=True)
def _stage(pool, runs, seed, white_sd, levels, gm_phi, gm_sd, rw_sd, q, k, grid):
    """``runs`` continuations of excursions from states drawn from ``pool`` (rows: side value, sign, st) until they
    end (back to 0) or pass the last of ``grid``: (their maxima (runs,), the state where each first passed each
    level of grid (runs, G, width), passed (runs, G))."""
    np.random.seed(seed)
    ng = len(grid)
    mx = np.zeros(runs)
    states = np.zeros((runs, ng, pool.shape[1]))
    hit = np.zeros((runs, ng), np.bool_)
    for r in range(runs):
        row = pool[np.random.randint(len(pool))]
        st = row[2:].copy()
        s, sign = row[0], row[1]
        top = s
        nxt = 0
        while nxt < ng and grid[nxt] < top:  # levels the kept state is already beyond: passed there
            states[r, nxt] = row
            hit[r, nxt] = True
            nxt += 1
        while nxt < ng and s > 0.0:
            s = max(0.0, s + sign * _window(st, white_sd, levels, gm_phi, gm_sd, rw_sd, q) - k)
            if s > top:
                top = s
                while nxt < ng and grid[nxt] < top:
                    states[r, nxt, 0], states[r, nxt, 1] = s, sign
                    states[r, nxt, 2:] = st
                    hit[r, nxt] = True
                    nxt += 1
        mx[r] = top
    return mx, states, hit


def _excursion_maxima(n, seed, white_sd, levels, gm_phi, gm_sd, rw_sd, q, k, floor, warm):
    """The counted excursion maxima alone (see :func:`_count`)."""
    return _count(n, seed, white_sd, levels, gm_phi, gm_sd, rw_sd, q, k, floor, warm, np.zeros(0), 1)[0]


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


def _split(args, k, share_per_10h, maxima, hours, entries, states, passes, seed):
    """(h, [(level, per 10 h)]) from the split stages beyond the highest entry level ENTRY_EXCURSIONS passed."""
    e = int(np.flatnonzero(passes >= min(ENTRY_EXCURSIONS, passes.max()))[-1])
    level, rate = float(entries[e]), passes[e] * 10.0 / hours
    pool = states[e, :min(passes[e], _SNAPSHOTS)]
    top = np.sort(maxima)[::-1]
    m = min(200, len(top) - 1)
    step = max(float(np.mean(top[:m] - top[m])), 0.05) / 4.0  # the tail's mean excess: its scale
    trail = [(level, rate)]
    for stage in range(60):
        grid = level + step * np.arange(1, SPLIT_STEPS + 1)
        mx, kept, hit = _stage(pool, SPLIT_RUNS, seed * 1009 + stage + 1, *args, k, grid)
        need = share_per_10h / rate  # the fraction of this stage's continuations the share allows beyond h
        if need >= SPLIT_P:
            return float(np.quantile(mx, 1.0 - need)), trail
        frac = hit.mean(axis=0)
        j = int(np.flatnonzero(frac >= SPLIT_P)[-1]) if frac[0] >= SPLIT_P else 0
        pool, rate, level = kept[hit[:, j], j], rate * frac[j], float(grid[j])
        trail.append((level, rate))
    raise RuntimeError("bias_tail: the split did not reach the share")


def bias_tail(model: SensorModel, c: int, window_s: float, white_sd: float, levels: np.ndarray, q: float, k: float,
              share_per_10h: float, hours: float, warm: int, seed: int = 0, split: bool = True) -> BiasTail:
    """Channel c's bias CUSUM (drift k, filter walk q per window) counted over ``hours`` of the model's simulated
    window means (the window's noise level factor drawn from ``levels``), and its threshold for ``share_per_10h``
    (:func:`counted_tail`)."""
    phi, sd, rw = slow_terms(model, c, window_s)
    args = (float(white_sd), np.asarray(levels, float), phi, sd, rw, float(q))
    return counted_tail(args, float(k), share_per_10h, hours, warm, int(seed) * 7 + c,
                        split, window_s)


def counted_tail(args, k: float, share_per_10h: float, hours: float, warm: int, seed: int, split: bool = True,
                 window_s: float = 1.0) -> BiasTail:
    """The CUSUM (drift k) on ``hours`` of window means simulated from ``args`` = (white_sd, levels, gm_phi, gm_sd,
    rw_sd, q) (see :func:`_count`) and its threshold for ``share_per_10h``: read off the counts where
    MEASURED_ALARMS pass it, else the higher of the split's and the counts' exponential tail's (``split`` False: the
    counts and their tail alone)."""
    n = int(round(hours * 3600.0 / window_s))
    entries = 0.5 * np.arange(1, 28) if split else np.zeros(0)
    maxima, states, passes = _count(n + warm, seed, *args, k, EXCURSION_FLOOR, warm, entries,
                                    _SNAPSHOTS if split else 1)
    h, how = threshold_for(maxima, hours, share_per_10h)
    if how == "measured" or not split or passes.max(initial=0) == 0:
        return BiasTail(hours, maxima, h, how)
    h_split, trail = _split(args, k, share_per_10h, maxima, hours, entries, states, passes, seed)
    return BiasTail(hours, maxima, max(h, h_split), "split" if h_split >= h else how, trail)
