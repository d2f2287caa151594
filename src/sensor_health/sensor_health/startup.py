"""Faults present from the first sample, against the sensor model (there is no healthy stretch of the run to compare
with): the first ``STARTUP_S`` of windows are tested against the model's own noise.

* noise: the mean standardised log noise level of the first k windows (k >= 2), with each of the last 2 windows'
  variance factor at least ``NOISE_IGNORED_RATIO`` (3: below it a vehicle's own level is taken as healthy, as the
  running test does) -> ``white_noise_increase``;
* spectrum: per bin, the least whitened power of the last 3 of the first k windows (k >= 3: a line lasts, a knock
  in one window does not), its largest *narrow* bin (``NARROW_RATIO`` over the median of the bins 3 to 6 away: a
  line, not the broad hump of a vehicle's own motion) with an amplitude of at least ``LINE_FLOOR_SD`` x the model's
  per-sample sd (below it a line present from the start is taken as the vehicle's or the bench's own, as the
  noise test takes a level below 3x) -> ``vibration``; the line is then held
  (:mod:`sensor_health.line_track`) and kept out of the run's reference spectrum;
* turn-on bias, where the motion allows it (an **unaccelerated start**: standing, or a constant-velocity
  straight, every channel's window means steady) and **the model states a turn-on repeatability**
  (``info: {turn_on_bias_repeatability: [..]}`` in a triad of model.yaml, 1 sd, SI; the calibrated ``bias`` and
  its ``interval_95`` are the centre and add their uncertainty): each gyro axis' mean minus the model's bias
  (allowing the Earth's rate), and the accelerometer's specific force along gravity minus normal gravity
  (allowing 9.78-9.83 m/s^2 for an unknown site) -> ``turn_on_bias``.

Thresholds: Monte Carlo of ``MC_RUNS`` starts of the model's noise (:mod:`sensor_health.noise_sim`, the same window
statistics as the monitor), an exponential tail per look and channel for the stated ``FALSE_ALARMS_PER_START``
(split over the tests and looks); the turn-on gate is the Gaussian quantile on the simulated sd of a start's mean
plus the stated bounds. Cached per model (the Monte Carlo is seeded: the CLI and the node get the same).

No ROS. SI units; times s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from nav_core.sensor_model import SensorModel
from sensor_health import noise_sim
from sensor_health.events import CHANNELS, Z95, Event
from sensor_health.thresholds import NOISE_IGNORED_RATIO, exp_tail_threshold
from sensor_health.window_stats import WindowGrid, detrend, window_stats

STARTUP_S = 5.0
FALSE_ALARMS_PER_START = 1e-3
"""Budget of false start-up events per start of a healthy unit, all start-up tests together."""
N_STARTUP_TESTS = 6 + 6 + 4
"""Noise and spectrum on every channel, turn-on bias on gx gy gz and the specific force along gravity."""
NOISE_LOOK_MIN, LINE_LOOK_MIN = 2, 3
"""A one-window burst (a knock) is not a noise increase; a line lasts (the running detector confirms over 3)."""
NARROW_RATIO, NARROW_SIDE, NARROW_NEAR = 10.0, 6, 2
"""A start-up line's bin has NARROW_RATIO x the median of the bins NARROW_NEAR + 1 .. NARROW_SIDE either side (a
Hann-tapered sinusoid leaks into NARROW_NEAR bins either side; the model's noise gives a median of ~0.5 there):
the 2-5 Hz humps of a car's and a rover's body motion at the start of the real drives are not lines."""
LINE_FLOOR_SD = 2.0
"""A start-up line carries at least twice the model's white-noise variance (amplitude 2 sd: a^2 / 2 = 2 sd^2). The
real recordings' own lines at the start sit below it: the ADIS16405's ~21-Hz gz line at ~1 sd, the Katwijk rover's
46-Hz line and the NaveGo Canada rover's body motion at 1-2 sd of their models."""
MC_RUNS = 1500
REPEATABILITY_KEY = "turn_on_bias_repeatability"
EARTH_RATE_RAD_S = 7.292115e-5
G_NORMAL_M_S2, G_ALLOWANCE_M_S2 = 9.806, 0.03
"""Normal gravity 9.780 (equator) to 9.832 (poles) at sea level, less 3e-6 per m of height: an unknown site."""
STEADY_P, STEADY_MARGIN = 1e-3, 2.0
"""The start counts as unaccelerated when every channel's window means scatter less than STEADY_MARGIN x their
simulated 1 - STEADY_P quantile (normalised by the window's noise level)."""
_CACHE = {}


@dataclass
class StartupThresholds:
    """Gates of the start-up tests; (looks, 6) arrays are per look k = 1..looks and channel."""

    looks: int
    noise_h: np.ndarray
    line_h: np.ndarray
    mean_sd: np.ndarray
    """(6,) sd of the mean of the first ``looks`` windows of the model's noise (GM, random walk, quantization)."""
    steady_h: np.ndarray
    """(6,) largest scatter of window means (sum of squares over level x window-mean variance) of a steady start."""
    p_look: float


def startup_thresholds(model: SensorModel, grid: WindowGrid, noise_mu, noise_sd, window_mean_sd, window_s: float,
                       runs: int = MC_RUNS, seed: int = 0) -> StartupThresholds:
    """Monte Carlo of ``runs`` starts (seeded; cached per model and grid)."""
    looks = max(LINE_LOOK_MIN, int(round(STARTUP_S / window_s)))
    key = (_model_key(model), grid.n, grid.dt, looks, runs, seed, np.asarray(noise_mu).tobytes())
    if key in _CACHE:
        return _CACHE[key]
    rng = np.random.default_rng(seed + 7919)
    x = np.stack([noise_sim.model_noise(model, looks * grid.n, grid.dt, rng) for _ in range(runs)])
    ws = window_stats(grid, x.reshape(runs * looks, grid.n, 6))
    y = ((np.log(ws.level) - noise_mu) / noise_sd).reshape(runs, looks, 6)
    power = ws.power.reshape(runs, looks, 6, -1)
    p_look = FALSE_ALARMS_PER_START / N_STARTUP_TESTS / looks
    k = np.arange(1, looks + 1)[None, :, None]
    noise_stat = np.cumsum(y, axis=1) / np.sqrt(k)
    line_stat = np.zeros((runs, looks, 6))
    for j in range(LINE_LOOK_MIN - 1, looks):
        # the gate on the largest bin: the monitor's narrowness and amplitude conditions only remove candidates
        line_stat[:, j] = power[:, j - LINE_LOOK_MIN + 1:j + 1].min(axis=1).max(axis=-1)
    noise_h = np.array([[exp_tail_threshold(noise_stat[:, j, c], p_look) for c in range(6)] for j in range(looks)])
    line_h = np.array([[exp_tail_threshold(line_stat[:, j, c], p_look) if j >= LINE_LOOK_MIN - 1 else np.inf
                        for c in range(6)] for j in range(looks)])
    means = ws.mean.reshape(runs, looks, 6)
    mean_sd = means.mean(axis=1).std(axis=0)
    scatter = _scatter(means, ws.level.reshape(runs, looks, 6), window_mean_sd)
    steady_h = STEADY_MARGIN * np.quantile(scatter, 1 - STEADY_P, axis=0)
    out = StartupThresholds(looks, noise_h, line_h, mean_sd, steady_h, p_look)
    _CACHE[key] = out
    return out


def narrow_peak(lasting: np.ndarray) -> tuple:
    """The largest narrow bin of ``lasting`` (..., 6, nb): (its value (..., 6), its index (..., 6)); 0 and -1 where
    no bin is narrow."""
    nb = lasting.shape[-1]
    pad = np.full(lasting.shape[:-1] + (NARROW_SIDE,), np.nan)
    wide = np.concatenate([pad, lasting, pad], axis=-1)
    offsets = [d for d in range(-NARROW_SIDE, NARROW_SIDE + 1) if abs(d) > NARROW_NEAR]
    side = np.stack([wide[..., NARROW_SIDE + d:NARROW_SIDE + d + nb] for d in offsets], axis=-1)
    with np.errstate(all="ignore"):
        base = np.nanmedian(side, axis=-1)
    narrow = lasting >= NARROW_RATIO * np.maximum(np.nan_to_num(base, nan=0.0), 1.0)
    masked = np.where(narrow, lasting, 0.0)
    k = np.argmax(masked, axis=-1)
    value = np.take_along_axis(masked, k[..., None], axis=-1)[..., 0]
    return value, np.where(value > 0, k, -1)


def _model_key(model: SensorModel) -> bytes:
    parts = [getattr(tri, f) for tri in (model.gyro, model.accel) for f in
             ("white_noise", "bias_instability", "bias_correlation_time", "rate_random_walk", "quantization")]
    return np.concatenate([np.asarray(p, float).ravel() for p in parts]).tobytes()


def _scatter(means, levels, window_mean_sd):
    """Sum over windows of (window mean - their mean)^2 / (level x window-mean variance): (..., 6)."""
    d = means - means.mean(axis=-2, keepdims=True)
    return np.sum(d**2 / (np.maximum(levels, 1.0) * window_mean_sd**2), axis=-2)


def turn_on_bounds(model: SensorModel) -> tuple:
    """(centre (6,), stated sd (6,) or NaN where the model states no repeatability) of the turn-on bias, SI."""
    centre, sd = np.zeros(6), np.full(6, np.nan)
    for k, tri in enumerate((model.gyro, model.accel)):
        centre[3 * k:3 * k + 3] = tri.bias
        rep = tri.info.get(REPEATABILITY_KEY)
        if rep is None:
            continue
        rep = np.broadcast_to(np.asarray(rep, float), (3,))
        interval = np.asarray(tri.intervals.get("bias", np.column_stack([tri.bias, tri.bias])), float)
        cal_sd = (interval[:, 1] - interval[:, 0]) / (2 * Z95)
        sd[3 * k:3 * k + 3] = np.sqrt(rep**2 + cal_sd**2 + tri.bias_instability**2)
    return centre, sd


class StartupCheck:
    """The start-up tests of one monitor; :meth:`window` is called with each window until the first STARTUP_S."""

    def __init__(self, monitor, sth: StartupThresholds):
        self.mon, self.sth = monitor, sth
        self.n = np.zeros(6, int)
        self.windows = 0
        self.sum_y = np.zeros(6)
        self.powers = []
        self.levels, self.means, self.ys = [], [], []
        self.noise_done = np.zeros(6, bool)
        self.line_done = np.zeros(6, bool)
        self.noise_held = np.zeros(6, bool)
        self.centre, self.bound_sd = turn_on_bounds(monitor.model)
        self.bias_note = ("not tested: the model states no turn-on repeatability (info: "
                          f"{REPEATABILITY_KEY} in model.yaml)") if np.isnan(self.bound_sd).all() else "pending"

    def window(self, t1, y, ws, w, use, xwin) -> list:
        """One window: its standardised log level y (6,), statistics ``ws`` row w, usable channels -> events."""
        self._hold_noise(t1, ws.level[w])
        self.windows += 1
        if self.windows > 4 * self.sth.looks:  # a channel unusable at the start is not tested from the start
            return []
        events = []
        fresh = use & (self.n < self.sth.looks)
        self.n += fresh
        self.sum_y += np.where(fresh, y, 0.0)
        self.powers = (self.powers + [np.where(use[:, None], ws.power[w], 0.0)])[-LINE_LOOK_MIN:]
        self.levels.append(np.where(use, ws.level[w], np.nan))
        self.means.append(np.where(use, ws.mean[w], np.nan))
        events += self._noise(t1, fresh)
        events += self._line(t1, fresh, ws, w, xwin)
        if len(self.means) == self.sth.looks:
            events += self._turn_on(t1)
        return events

    def _noise(self, t1, fresh) -> list:
        k = np.maximum(self.n, 1) - 1
        stat = self.sum_y / np.sqrt(np.maximum(self.n, 1))
        recent = np.array(self.levels[-NOISE_LOOK_MIN:])
        high = (len(recent) >= NOISE_LOOK_MIN) & np.all(recent >= NOISE_IGNORED_RATIO, axis=0)
        gate = self.sth.noise_h[k, np.arange(6)]
        fired = np.flatnonzero(fresh & ~self.noise_done & (self.n >= NOISE_LOOK_MIN) & (stat > gate) & high)
        if len(fired) == 0:
            return []
        self.noise_done[fired] = self.noise_held[fired] = True
        onset = float(self.mon.checked_s[0])
        factor, lo, hi = self.mon._noise_factor(fired, onset, t1)
        names = [CHANNELS[c] for c in fired]
        msg = ", ".join(f"{n} x{f:.3g}" for n, f in zip(names, factor))
        return [Event(t1, onset, "white_noise_increase", names, "WARN", factor.tolist(),
                      np.column_stack([lo, hi]).tolist(), f"noise sd from the start: {msg} of the model's",
                      {"startup_stat": stat[fired].tolist(), "threshold": gate[fired].tolist()})]

    def _hold_noise(self, t1, level) -> None:
        """A start-up noise increase is held while the window's variance factor stays over NOISE_IGNORED_RATIO
        (the running test takes the start's level as the run's own and would not see it go)."""
        quiet = self.noise_held & (level < NOISE_IGNORED_RATIO)
        if quiet.any():
            self.noise_held &= ~quiet
            self.mon.cleared.append({"effect": "white_noise_increase", "channels": [CHANNELS[c] for c in
                                                                                    np.flatnonzero(quiet)],
                                     "t_s": t1, "since_s": float(self.mon.checked_s[0])})

    def _line(self, t1, fresh, ws, w, xwin) -> list:
        k = np.maximum(self.n, 1) - 1
        stat, best = narrow_peak(np.min(self.powers, axis=0))  # a line lasts, a knock is in one window
        gate = self.sth.line_h[k, np.arange(6)]
        fired = np.flatnonzero(fresh & ~self.line_done & (self.n >= LINE_LOOK_MIN) & (stat > gate))
        fired = np.array([c for c in fired if self._amplitude(c, int(best[c]), xwin) >= LINE_FLOOR_SD
                          * self.mon.thr.sample_sigma[c]], int)
        if len(fired) == 0:
            return []
        self.line_done[fired] = True
        c0 = fired[np.argmax(stat[fired] / gate[fired])]
        line_k = int(best[c0])
        self.mon.line_track.start(fired, line_k, t1)
        # the windows so far went into the run's reference spectrum: at the held line's bins it is the model's
        mask = self.mon.line_track.reference_mask()
        if self.mon.line_ref is not None:
            self.mon.line_ref[mask] = np.minimum(self.mon.line_ref[mask], 2.0)
        return [self.mon._line_event(t1, float(self.mon.checked_s[0]), fired, line_k, ws.level[w], xwin,
                                     {"startup_least_chi2": stat[fired].tolist(), "threshold": gate[fired].tolist(),
                                      "windows": self.n[fired].tolist()})]

    def _amplitude(self, c, line_k, xwin) -> float:
        """Largest amplitude of a sinusoid within half a bin of searched bin ``line_k`` in channel c of the window."""
        grid = self.mon.grid
        df = 1.0 / (grid.n * grid.dt)
        f0 = float(grid.freqs[np.flatnonzero(grid.line_bins)[line_k]])
        x = detrend(np.where(np.isfinite(xwin), xwin, 0.0))[:, [c]]
        return max(float(self.mon._line_amplitude(x, f0 + d * df, np.ones(1), [c])[0][0])
                   for d in (-0.5, -0.25, 0.0, 0.25, 0.5))

    def _turn_on(self, t1) -> list:
        """At the end of the first STARTUP_S: the turn-on bias against the model's stated bounds, if the start was
        unaccelerated."""
        if np.isnan(self.bound_sd).all():
            return []
        means, levels = np.array(self.means), np.array(self.levels)
        if np.isnan(means).any():
            self.bias_note = "not tested: a channel was unusable at the start"
            return []
        scatter = _scatter(means, levels, self.mon.thr.bias_sd)
        if np.any(scatter > self.sth.steady_h):
            worst = CHANNELS[int(np.argmax(scatter / self.sth.steady_h))]
            self.bias_note = f"not observable on this record: the start was not unaccelerated ({worst} moved)"
            return []
        self.bias_note = f"tested at an unaccelerated start ({len(means)} windows)"
        mean = means.mean(axis=0)
        noise_sd = self.sth.mean_sd * np.sqrt(np.maximum(levels.mean(axis=0), 1.0))
        z = stats.norm.isf(self.sth.p_look * self.sth.looks / 2)
        events = []
        for c in range(3):
            if np.isnan(self.bound_sd[c]):
                continue
            est = float(mean[c] - self.centre[c])
            sd = float(np.hypot(self.bound_sd[c], noise_sd[c]))
            gate = z * sd + EARTH_RATE_RAD_S
            if abs(est) > gate:
                events.append(self._event(t1, [c], est, float(noise_sd[c]), EARTH_RATE_RAD_S, gate,
                                          f"{CHANNELS[c]} turn-on bias {est:.3g} rad/s = {abs(est) / sd:.1f} sd of "
                                          f"the model's stated repeatability"))
        if not np.isnan(self.bound_sd[3:]).all():
            events += self._turn_on_accel(t1, mean, noise_sd, z)
        return events

    def _turn_on_accel(self, t1, mean, noise_sd, z) -> list:
        """The specific force along gravity minus normal gravity (the bias across gravity is the tilt's)."""
        f = mean[3:] - self.centre[3:]
        u = f / np.linalg.norm(f)
        est = float(np.linalg.norm(f) - G_NORMAL_M_S2)
        sd = float(np.sqrt(np.sum(u**2 * (np.nan_to_num(self.bound_sd[3:]) ** 2 + noise_sd[3:] ** 2))))
        gate = z * sd + G_ALLOWANCE_M_S2
        if abs(est) <= gate:
            return []
        c = 3 + int(np.argmax(np.abs(u)))
        return [self._event(t1, [c], est, float(np.sqrt(np.sum(u**2 * noise_sd[3:] ** 2))), G_ALLOWANCE_M_S2, gate,
                            f"{CHANNELS[c]} turn-on bias {est:.3g} m/s^2 along gravity = {abs(est) / sd:.1f} sd of "
                            f"the model's stated repeatability (normal gravity {G_NORMAL_M_S2} "
                            f"+/- {G_ALLOWANCE_M_S2} m/s^2)")]

    def _event(self, t1, chans, est, noise_sd, allowance, gate, msg) -> Event:
        half = Z95 * noise_sd + allowance
        return Event(t1, float(self.mon.checked_s[0]), "turn_on_bias", [CHANNELS[c] for c in chans], "WARN", est,
                     [est - half, est + half], msg, {"estimate": est, "threshold": gate})
