"""The health monitor: raw IMU samples in, named events out. Streaming and deterministic: the CLI pushes a whole
recording at once, the node pushes what each intake brings, and both get the same events at the same stamps.

Sample-level checks (:mod:`sensor_health.sample_checks`) run on every sample. Window statistics
(:mod:`sensor_health.window_stats`) run on consecutive windows of ``window_s`` s (counted in samples) and feed:

* a CUSUM per channel on the standardised log noise level over the run's starting level (the first 30 s,
  floored at the model's) (``white_noise_increase``);
* a chi-square gate per channel on the largest whitened line, against the run's own spectrum after a 30-s
  warm-up (``vibration``: a *new* line; the vehicle's own vibration is not a fault;
  :mod:`sensor_health.vibration_check`);
* a two-sided CUSUM per channel on the standardised innovation of a Kalman filter of the window mean (bias plus
  the vehicle's motion: :mod:`sensor_health.bias_filter`), through turns (``bias_shift``, gx gy az);
* a count of samples at the extreme of the last 10 windows, every 8 samples (``saturation`` below the configured
  range; :mod:`sensor_health.clip_check`).

With GNSS fixes, the yaw scale factor, gz's and ax's bias against the track and ay's on the straights at speed
(:mod:`sensor_health.yaw_scale`, ``cross_track``, ``along_track``, ``lateral_track``).

Thresholds come from :func:`sensor_health.thresholds.monte_carlo`. A channel touched by a deterministic fault
in a window is left out of the statistics of that window (its CUSUMs restart).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from nav_core.sensor_model import SensorModel
from sensor_health import thresholds as thr
from sensor_health.along_track import AlongTrackMonitor
from sensor_health.bias_filter import BiasFilter, motion_regressors
from sensor_health.clip_check import ClipCheck
from sensor_health.lattice import OutputLattice
from sensor_health.cross_track import CrossTrackMonitor
from sensor_health.lateral_track import LateralTrackMonitor
from sensor_health.config import UNMONITORED, HealthConfig, Trace
from sensor_health.events import CHANNELS, Z95, Event, bias_shift_event
from sensor_health.line_track import LineTrack
from sensor_health.vibration_check import LINE_WARMUP_S, VibrationCheck
from sensor_health.sample_checks import SampleChecks
from sensor_health.startup import StartupCheck, StartupThresholds, startup_thresholds
from sensor_health.threshold_cache import cached
from sensor_health.yaw_scale import YawScaleMonitor
from sensor_health.window_stats import WindowGrid, window_stats

NOISE_CONFIRM = 2
"""Consecutive windows the noise CUSUM must stay over its threshold: a noise increase lasts; a one-window burst on
several channels (a knock on the mount) is not one."""
BIAS_FAST_WINDOWS = 3
BIAS_CONFIRM_WINDOWS = 2
BIAS_CONFIRM_BEFORE_S = 20.0
"""A bias CUSUM that crossed within BIAS_FAST_WINDOWS windows of its start waits this many more: a lasting step
keeps half its size in them, a pulse (the unit turned and came back: ADIS imu4 at 3957 s, gx and gy for 2 s while
ax and ay tilt) does not. A slow crossing has already shown that the change lasts."""
ONSET_NEAR_START_S = 2.0
"""A bias step's change point is sought within this many seconds of where its CUSUM last left zero (the change point
of the step the CUSUM is tuned to; the samples refine it): over the whole span, one noisy window at its end pulled
the unknown-step maximum likelihood there (benchmark seed 9504: 27 s late)."""


class HealthMonitor(VibrationCheck):
    """Streaming monitor of one IMU: :meth:`push` samples, get :class:`Event` s."""

    def __init__(self, model: SensorModel, config: HealthConfig | None = None, sample_rate_hz: float = 0.0,
                 keep_trace: bool = True, thresholds: thr.Thresholds | None = None):
        """``thresholds``: those of an earlier monitor of the same model and config (skips the Monte Carlo)."""
        self.config = cfg = config or HealthConfig()
        self.model = model
        fs = sample_rate_hz or model.sample_rate_hz
        self.dt = 1.0 / fs
        n = max(16, int(round(cfg.window_s * fs)))
        self.grid = WindowGrid.for_model(model, n, self.dt, cfg.f_min_hz)
        mc = (model, self.grid, n * self.dt, cfg.false_alarms_per_10h, cfg.baseline_s, cfg.mc_windows, cfg.seed,
              cfg.gyro_bias_per_10h, cfg.clip_per_10h, cfg.bias_mc_hours)
        self.thr = thresholds or cached("thresholds", mc, lambda: thr.monte_carlo(*mc), thr.Thresholds)
        ranges = np.r_[[cfg.gyro_range_rad_s] * 3, [cfg.accel_range_m_s2] * 3]
        self.samples = SampleChecks(self.dt, ranges, self.thr.stuck_run, cfg.gap_factor, cfg.rate_tolerance,
                                    cfg.clear_s, self.thr.clip_ties)
        self.lattice = OutputLattice(1e-4 * self.thr.sample_sigma)
        self.samples.lattice = self.lattice
        self.trace = Trace() if keep_trace else None
        self._pending_t, self._pending_x, self._pending_f = np.zeros(0), np.zeros((0, 6)), np.zeros((0, 6), bool)
        self._hist_t, self._hist_x = np.zeros(0), np.zeros((0, 6))
        self.noise_s = np.zeros(6)
        self.noise_start = np.full(6, np.nan)
        self.noise_active = np.zeros(6, bool)
        self.noise_quiet = np.zeros(6, int)
        self.noise_over = np.zeros(6, int)
        self.noise_warm, self.noise_ref = [], np.zeros(6)
        self.clip = ClipCheck(self)
        self.line_ref, self.line_n, self.line_now = None, 0, np.zeros(6)
        self.line_run, self.line_prev_bin = np.zeros(6, int), np.full(6, -10)
        self.line_track = LineTrack(int(self.grid.line_bins.sum()))
        self.cleared = []
        """Faults that went away: {"effect", "channels", "t_s" (cleared), "since_s" (named)}."""
        chans = list(thr.BIAS_CHANNELS)
        self.bias_filter = BiasFilter(chans, self.thr.bias_sd[chans], self.thr.bias_q[chans])
        self.bias_hist = []
        """(t0, t1, motion (C,), used (C,), mean - motion (C,)) of the recent windows: the motion part is taken out
        of the samples before the change point is looked for."""
        self.bias_pos, self.bias_neg = np.zeros(6), np.zeros(6)
        self.bias_start = np.full((2, 6), np.nan)
        self.bias_windows = 0
        self.bias_pending = {}
        """channel -> a fast crossing waiting for BIAS_CONFIRM_WINDOWS more windows."""
        self.yaw_scale = YawScaleMonitor(model, self.thr.budget_per_10h / thr.N_TESTS)
        track = cfg.track_bias_per_10h or self.thr.budget_per_10h / thr.N_TESTS
        acc = model.accel
        self.along_track = AlongTrackMonitor(track, float(acc.bias_instability[0]), float(acc.white_noise[0]),
                                             float(acc.rate_random_walk[0]), float(acc.bias_correlation_time[0]))
        self.cross_track = CrossTrackMonitor(float(model.gyro.white_noise[2]), track,
                                             float(model.gyro.bias_instability[2]))
        self.lateral_track = LateralTrackMonitor(float(model.accel.white_noise[1]), float(model.gyro.white_noise[2]),
                                                 float(model.accel.bias_instability[1]), track)
        start = (model, self.grid, self.thr.noise_mu, self.thr.noise_sd, self.thr.bias_sd, self.thr.window_s)
        self.startup = StartupCheck(self, cached("startup", start + (cfg.seed,),
                                                 lambda: startup_thresholds(*start, seed=cfg.seed), StartupThresholds))
        self.checked_s = [None, None]
        self.windows = 0
        self.active = {}
        """(effect, channel) -> latest event, for the diagnostics."""

    # ------------------------------------------------------------------ input

    def push(self, t, gyro, accel) -> list:
        """Samples t (m,) s, gyro (m, 3) rad/s, accel (m, 3) m/s^2 -> events detected among them, in time order."""
        t = np.asarray(t, float).reshape(-1)
        if len(t) == 0:
            return []
        x = np.hstack([np.asarray(gyro, float).reshape(-1, 3), np.asarray(accel, float).reshape(-1, 3)])
        if self.checked_s[0] is None:
            self.checked_s[0] = float(t[0])
        self.checked_s[1] = float(t[-1])
        self.lattice.feed(t, x)
        events, flags = self.samples.push(t, x)
        events += self.yaw_scale.push_imu(t, x[:, 2])
        events += self.along_track.push_imu(t, x[:, 3], x[:, 2], x[:, 4]) + self.cross_track.push_imu(t, x[:, 2])
        events += self.lateral_track.push_imu(t, x[:, 2], x[:, 4])
        self._remember(t, x)
        events += self.clip.push(t, x, flags)
        self._pending_t = np.concatenate([self._pending_t, t])
        self._pending_x = np.vstack([self._pending_x, x])
        self._pending_f = np.vstack([self._pending_f, flags])
        n = self.grid.n
        nw = len(self._pending_t) // n
        if nw:
            events += self._windows(self._pending_t[:nw * n].reshape(nw, n), self._pending_x[:nw * n].reshape(nw, n, 6),
                                    self._pending_f[:nw * n].reshape(nw, n, 6).any(axis=1))
            self._pending_t, self._pending_x = self._pending_t[nw * n:], self._pending_x[nw * n:]
            self._pending_f = self._pending_f[nw * n:]
        return self._report(events)

    def push_gnss(self, t, lat_rad, lon_rad, h_m=None) -> list:
        """GNSS fixes t (m,) s, lat, lon (m,) rad, height h (m,) m or None -> events they complete (the yaw scale
        factor in turns, a gz bias against the track, an ax bias against the track where the fixes carry a height)."""
        return self._report(self.yaw_scale.push_gnss(t, lat_rad, lon_rad)
                            + self.cross_track.push_gnss(t, lat_rad, lon_rad)
                            + self.along_track.push_gnss(t, lat_rad, lon_rad, h_m)
                            + self.lateral_track.push_gnss(t, lat_rad, lon_rad))

    def observability(self) -> dict:
        """Effect and channel -> whether this record's motion made it observable (scale factor so far)."""
        return {"scale_factor_change gz": self.yaw_scale.observability(), "turn_on_bias": self.startup.bias_note,
                "bias_shift ax": self.along_track.observability(), "bias_shift gz": self.cross_track.observability(),
                "bias_shift ay": self.lateral_track.observability(),
                **UNMONITORED}

    def _report(self, events) -> list:
        """Events in time order, each fault once (two detectors can name the same fault)."""
        events.sort(key=lambda e: e.t_s)
        kept = []
        for e in events:
            # two detectors can name the same fault (a clip by its flat tops and by a long run): report it once
            if all(e.t_s - self.active[(e.effect, ch)].t_s <= self.config.clear_s
                   for ch in e.channels if (e.effect, ch) in self.active) and \
                    all((e.effect, ch) in self.active for ch in e.channels):
                continue
            kept.append(e)
            for ch in e.channels:
                self.active[(e.effect, ch)] = e
        return kept

    def _remember(self, t, x):
        keep = self.config.history_s
        self._hist_t = np.concatenate([self._hist_t, t])
        self._hist_x = np.vstack([self._hist_x, x])
        cut = np.searchsorted(self._hist_t, self._hist_t[-1] - keep)
        if cut > 4 * len(t):  # trim in steps, not every push
            self._hist_t, self._hist_x = self._hist_t[cut:], self._hist_x[cut:]

    # ------------------------------------------------------------------ windows

    def _windows(self, tw, xw, faulty) -> list:
        ws = window_stats(self.grid, xw)
        phi = motion_regressors(np.where(np.isfinite(xw), xw, 0.0))
        use = ws.finite & ~faulty
        th = self.thr
        y = (np.log(ws.level) - th.noise_mu) / th.noise_sd
        events = []
        for w in range(len(tw)):
            self.windows += 1
            t0, t1 = float(tw[w, 0]), float(tw[w, -1])
            events += self.startup.window(t1, y[w], ws, w, use[w], xw[w])
            events += self._noise(w, t0, t1, y[w], ws, use[w])
            events += self._line(w, t1, ws, use[w], xw[w])
            events += self._bias(t0, t1, ws.mean[w], ws.level[w], use[w], phi[w])
            if self.trace is not None:
                self.trace.t.append(t1)
                self.trace.level.append(ws.level[w].copy())
                self.trace.line.append(self.line_now.copy())
                self.trace.noise_cusum.append(self.noise_s.copy())
                self.trace.bias_cusum.append(np.maximum(self.bias_pos, self.bias_neg))
        return events

    def _noise_reference(self, y, use):
        """The run's own starting level (standardised log level, floored at the model's 0): a vehicle whose
        vibration lifts the level from the start has that as its healthy floor. None during the warm-up."""
        warm = int(round(LINE_WARMUP_S / self.thr.window_s))
        if len(self.noise_warm) < warm:
            self.noise_warm.append(np.where(use, y, np.nan))
            if len(self.noise_warm) < warm:
                return None
            with np.errstate(all="ignore"):
                med = np.nanmedian(np.array(self.noise_warm), axis=0)
            self.noise_ref = np.maximum(np.nan_to_num(med, nan=0.0), 0.0)
            return None
        return self.noise_ref

    def _noise(self, w, t0, t1, y, ws, use) -> list:
        th = self.thr
        ref = self._noise_reference(y, use)
        if ref is None:
            return []
        s = np.where(use, np.maximum(0.0, self.noise_s + y - ref - th.noise_k), 0.0)
        self.noise_start = np.where((self.noise_s == 0) & (s > 0), t0, self.noise_start)
        self.noise_s = s
        self.noise_quiet = np.where(s == 0, self.noise_quiet + 1, 0)
        clear = self.noise_active & (self.noise_quiet * th.window_s >= self.config.clear_s)
        self.noise_active &= ~clear
        self.noise_over = np.where(s > th.noise_h, self.noise_over + 1, 0)
        fired = np.flatnonzero((self.noise_over >= NOISE_CONFIRM) & ~self.noise_active)
        if len(fired) == 0:
            return []
        self.noise_active[fired] = True
        onsets = [self._variance_onset(c, self.noise_start[c], t1) for c in fired]
        onset = float(np.median(onsets))
        factor, lo, hi = self._noise_factor(fired, onset, t1)
        names = [CHANNELS[c] for c in fired]
        msg = ", ".join(f"{n} x{f:.3g}" for n, f in zip(names, factor))
        return [Event(t1, onset, "white_noise_increase", names, "WARN", factor.tolist(),
                      np.column_stack([lo, hi]).tolist(), f"noise sd up: {msg} of the model's",
                      {"cusum": s[fired].tolist(), "threshold": th.noise_h})]

    def _noise_factor(self, chans, onset, t1):
        """sd factor over the model (high-passed: first differences) since ``onset`` with a 95 % interval."""
        sel = (self._hist_t >= onset) & (self._hist_t <= t1)
        d = np.diff(self._hist_x[sel][:, chans], axis=0)
        var0 = 2 * self.thr.sample_sigma[chans] ** 2
        k = max(len(d), 2)
        ratio = np.mean(d**2, axis=0) / var0 if len(d) else np.full(len(chans), np.nan)
        # first differences of white noise are MA(1): 2/3 of the samples' worth of chi-square dof
        half = Z95 * np.sqrt(2.0 / (k * 2 / 3))
        return np.sqrt(ratio), np.sqrt(ratio * np.exp(-half)), np.sqrt(ratio * np.exp(half))

    def _variance_onset(self, c, start, t1) -> float:
        """Change point of the variance of first differences in [start - window, t1] (maximum likelihood)."""
        lo = (start if np.isfinite(start) else t1) - 2 * self.thr.window_s
        sel = (self._hist_t >= lo) & (self._hist_t <= t1)
        d2 = np.diff(self._hist_x[sel, c]) ** 2
        ts = self._hist_t[sel][1:]
        if len(d2) < 8:
            return float(lo)
        cs = np.cumsum(d2)
        k = np.arange(2, len(d2) - 1)
        v1 = cs[k - 1] / k
        v2 = (cs[-1] - cs[k - 1]) / (len(d2) - k)
        nll = k * np.log(np.maximum(v1, 1e-300)) + (len(d2) - k) * np.log(np.maximum(v2, 1e-300))
        return float(ts[k[np.argmin(nll)]])

    def _bias(self, t0, t1, mean, level, use, phi) -> list:
        """One window through the bias filter (the motion's part of gx, gy, az taken out) and its CUSUMs.

        A tested channel counts when it and the motion channels it is predicted from (gz, ax, ay) are usable."""
        th = self.thr
        chans = np.array(thr.BIAS_CHANNELS)
        on = use[chans] & use[[2, 3, 4]].all()
        z, motion = self.bias_filter.step(mean, phi, level, on)
        self.bias_hist.append((t0, t1, motion, on, mean[chans] - motion))
        while self.bias_hist and self.bias_hist[0][1] < t1 - self.config.history_s:
            self.bias_hist.pop(0)
        self.bias_windows += 1
        if self.bias_windows <= thr.bias_warmup_windows(th.window_s):
            return []
        zz = np.zeros(6)
        zz[chans] = z
        on6 = np.zeros(6, bool)
        on6[chans] = on
        events = self._bias_confirm(t1, on6)
        on6 &= ~np.isin(np.arange(6), list(self.bias_pending))
        pos = np.where(on6, np.maximum(0.0, self.bias_pos + zz - th.bias_k), self.bias_pos)
        neg = np.where(on6, np.maximum(0.0, self.bias_neg - zz - th.bias_k), self.bias_neg)
        self.bias_start[0] = np.where((self.bias_pos == 0) & (pos > 0), t0, self.bias_start[0])
        self.bias_start[1] = np.where((self.bias_neg == 0) & (neg > 0), t0, self.bias_start[1])
        self.bias_pos, self.bias_neg = pos, neg
        fired = np.flatnonzero(np.maximum(pos, neg) > th.bias_h)
        for c in fired:
            i = int(np.flatnonzero(chans == c)[0])
            start = self.bias_start[0 if pos[c] > neg[c] else 1, c]
            onset, step, sd = self._mean_onset(i, c, start, t1, level[c])
            event = bias_shift_event(t1, onset, CHANNELS[c], step, sd,
                                     f"{CHANNELS[c]} mean stepped by {step:.3g} ({abs(step) / sd:.1f} sd)",
                                     {"cusum": float(max(pos[c], neg[c])), "threshold": float(th.bias_h[c])})
            self.bias_pos[c] = self.bias_neg[c] = 0.0
            if np.isfinite(step) and t1 - start <= BIAS_FAST_WINDOWS * th.window_s:
                # crossed in a few windows: a large step, or a pulse (the mount turned and came back); the next
                # windows tell them apart
                self.bias_pending[c] = {"event": event, "i": i, "step": step, "n": 0}
                continue
            events.append(event)
            self._bias_restart(i, step)
        return events

    def _bias_confirm(self, t1, on) -> list:
        """Pending fast crossings: a step when the mean of the next BIAS_CONFIRM_WINDOWS windows (motion taken out)
        keeps half the step over the BIAS_CONFIRM_BEFORE_S before the onset; else a pulse, not a bias shift (the
        bias is relearned)."""
        events = []
        for c in list(self.bias_pending):
            p = self.bias_pending[c]
            p["n"] += int(on[c])
            if p["n"] < BIAS_CONFIRM_WINDOWS:
                continue
            del self.bias_pending[c]
            e, i = p["event"], p["i"]
            before = [r[4][i] for r in self.bias_hist if r[3][i] and e.onset_s - BIAS_CONFIRM_BEFORE_S <= r[0]
                      and r[1] <= e.onset_s]
            after = [r[4][i] for r in self.bias_hist[-BIAS_CONFIRM_WINDOWS:] if r[3][i]]
            held = (np.mean(after) - np.mean(before)) * np.sign(p["step"]) if before and after else np.inf
            if held >= 0.5 * abs(p["step"]):
                events.append(replace(e, t_s=t1, statistic=dict(e.statistic, crossed_s=e.t_s)))
                self._bias_restart(i, p["step"])
            else:
                self._bias_restart(i, 0.0)
        return events

    def _bias_restart(self, i, step):
        """The new mean is the bias from here on, relearned from the windows that follow: one event per step."""
        self.bias_filter.restart_bias(i, step if np.isfinite(step) else 0.0)

    def _mean_onset(self, i, c, start, t1, level):
        """Change point of channel c's mean, the motion's part taken out, in [min(start - 10 s, t1 - 60 s), t1]:
        (onset s, step, sd). Maximum likelihood over the samples of the windows the filter used, the change point
        within ONSET_NEAR_START_S of the CUSUM's last zero ``start`` where it is known.

        The CUSUM's last zero can fall after the onset (noise pulled it back once), hence the 10 s before; a long
        stretch before the step sharpens the change point of a weak one."""
        lo = min((start if np.isfinite(start) else t1) - max(10.0, 2 * self.thr.window_s), t1 - 60.0)
        sigma = self.thr.sample_sigma[c] * np.sqrt(max(level, 1.0))
        spans = [(a, b, m[i]) for a, b, m, u, _ in self.bias_hist if u[i] and b >= lo]
        if not spans:
            return float(lo), float("nan"), float("nan")
        sp = np.array(spans)
        sel = (self._hist_t >= max(lo, sp[0, 0])) & (self._hist_t <= t1)
        ts = self._hist_t[sel]
        k = np.searchsorted(sp[:, 0], ts, side="right") - 1
        inside = (k >= 0) & (ts <= sp[np.maximum(k, 0), 1])
        x = self._hist_x[sel, c][inside] - sp[k[inside], 2]
        ts = ts[inside]
        x, ts = x[np.isfinite(x)], ts[np.isfinite(x)]
        if len(x) < 8:
            return float(lo), float("nan"), float("nan")
        cs = np.cumsum(x - x.mean())
        k = np.arange(2, len(x) - 1)
        score = cs[k - 1] ** 2 / (k * (len(x) - k))
        near = np.abs(ts[k] - start) <= ONSET_NEAR_START_S if np.isfinite(start) else np.zeros(len(k), bool)
        if near.any():
            k, score = k[near], score[near]
        j = int(k[np.argmax(score)])
        step = float(x[j:].mean() - x[:j].mean())
        return float(ts[j]), step, float(sigma * np.sqrt(1 / j + 1 / (len(x) - j)))

    # ------------------------------------------------------------------ status

    def channel_status(self, now_s: float) -> dict:
        """Channel -> (level, latest event or None): an event older than clear_s without a repeat is history."""
        out = {}
        for c in CHANNELS:
            evs = [e for (eff, ch), e in self.active.items() if ch == c]
            latest = max(evs, key=lambda e: e.t_s) if evs else None
            tracked = latest is not None and latest.effect == "vibration"  # held while the line lasts
            # a fault whose cleared note came after it (its OK event is out) is history at once, not after clear_s
            gone = latest is not None and any(n["effect"] == latest.effect and c in n["channels"]
                                              and n["t_s"] >= latest.t_s for n in self.cleared)
            live = latest is not None and (self._still_active(latest, c, now_s)
                                           or (not tracked and not gone and now_s - latest.t_s <= self.config.clear_s))
            out[c] = (latest.level if live else "OK", latest)
        return out

    def _still_active(self, e: Event, ch: str, now_s: float) -> bool:
        c = CHANNELS.index(ch)
        if e.effect == "vibration":  # the line's power still holds (LineTrack)
            return bool(self.line_track.active[c])
        if e.effect == "white_noise_increase":
            return bool(self.noise_active[c] or self.startup.noise_held[c])
        if e.effect == "stuck_output":
            return bool(self.samples.run[c] >= self.thr.stuck_run[c])
        return False
