"""The vibration check of :class:`sensor_health.monitor.HealthMonitor`: a *new* line in a channel's whitened
spectrum against the run's own reference, confirmed over LINE_CONFIRM windows, held while it lasts, and its
frequency (Hz) and amplitude (the channel's unit) with 95 % intervals."""
from __future__ import annotations

import numpy as np

from nav_core import noise_stats
from sensor_health.events import CHANNELS, Z95, Event
from sensor_health.window_stats import detrend

LINE_WARMUP_S = 30.0
LINE_REFERENCE_S = 300.0
LINE_CONFIRM = 3
"""Consecutive windows, the first over the line gate and the next over LINE_CONFIRM_FRACTION of it within one bin
of the first, that name a vibration."""
LINE_CONFIRM_FRACTION = 0.3


class VibrationCheck:
    """Mixin of the monitor's line methods; the monitor owns the state they use (``line_*``, ``grid``, ``thr``)."""

    def _line_statistic(self, w, ws, use):
        """The largest whitened power against the run's own spectrum: power x 2 / max(reference, 2) per channel.

        The reference is the mean whitened power per bin over the run (LINE_REFERENCE_S exponential, from the first
        LINE_WARMUP_S): 2 on the model's noise, so the statistic is the plain chi-square(2) gate there, and higher
        where the vehicle itself vibrates, so only a *new* line is named. None during the warm-up."""
        p = ws.power[w]
        if self.line_ref is None:
            self.line_ref = np.zeros_like(p)
        stat = None
        warm = int(round(LINE_WARMUP_S / self.thr.window_s))
        ratio = p * 2.0 / np.maximum(self.line_ref, 2.0)
        if self.line_n >= warm:
            k = np.argmax(ratio, axis=1)
            stat = (ratio[np.arange(6), k], k, ratio)
        alpha = max(1.0 / (self.line_n + 1), self.thr.window_s / LINE_REFERENCE_S)
        # a held line stays out of the reference: it would join it and look gone while it is still there
        update = use[:, None] & ~self.line_track.reference_mask()
        self.line_ref = np.where(update, self.line_ref + alpha * (p - self.line_ref), self.line_ref)
        self.line_n += 1
        return stat

    def _line(self, w, t1, ws, use, xwin) -> list:
        th = self.thr
        stat = self._line_statistic(w, ws, use)
        if stat is None:
            return []
        line, line_k, ratio = stat
        self.line_now = line
        self._line_cleared(self.line_track.update(ratio, use, t1), t1)
        # a line persists at one frequency; the bumps of rough ground come and go and wander. The first window must
        # pass the gate; the next ones, within one bin of it, a fraction of it (a line between two bins, or
        # beating with the noise, swings from window to window)
        over = use & (line > th.line_h)
        kept = use & (self.line_run > 0) & (line > LINE_CONFIRM_FRACTION * th.line_h) \
            & (np.abs(line_k - self.line_prev_bin) <= 1)
        self.line_run = np.where(kept, self.line_run + 1, np.where(over, 1, 0))
        self.line_prev_bin = np.where(kept | over, np.where(kept, self.line_prev_bin, line_k), -10)
        hit = self.line_run >= LINE_CONFIRM
        fired = np.flatnonzero(hit & ~self.line_track.active)
        if len(fired) == 0:
            return []
        k0 = int(line_k[fired[np.argmax(line[fired])]])
        self.line_track.start(fired, k0, t1)
        return [self._line_event(t1, float(t1 - LINE_CONFIRM * th.window_s), fired, k0, ws.level[w], xwin,
                                 {"chi2": line[fired].tolist(), "threshold": th.line_h})]

    def _line_event(self, t1, onset, fired, line_k, level, xwin, statistic) -> Event:
        """The vibration event of a line near searched bin ``line_k`` on channels ``fired`` of window xwin (n, 6):
        its frequency (maximum likelihood) and amplitude per channel, with 95 % intervals."""
        wh = noise_stats.Whitener(self.grid.n, self.dt, self.grid.weights, level)
        resid = detrend(np.where(np.isfinite(xwin), xwin, 0.0))
        f0 = float(self.grid.freqs[np.flatnonzero(self.grid.line_bins)[line_k]])
        f_hat, f_lo, f_hi = noise_stats.fit_line_frequency(wh, resid * np.isin(np.arange(6), fired), f0)
        amp, sd = self._line_amplitude(resid[:, fired], f_hat, level[fired], fired)
        names = [CHANNELS[c] for c in fired]
        estimate = {"frequency_hz": f_hat, "amplitude": dict(zip(names, amp.tolist()))}
        interval = {"frequency_hz": [f_lo, f_hi],
                    "amplitude": {n: [float(a - Z95 * s), float(a + Z95 * s)] for n, a, s in zip(names, amp, sd)}}
        msg = ", ".join(f"{n} {a:.3g}" for n, a in zip(names, amp))
        return Event(t1, onset, "vibration", names, "WARN", estimate, interval,
                     f"line at {f_hat:.3g} Hz, amplitude {msg}", statistic)

    def _line_cleared(self, chans, t1) -> None:
        """Note the held lines that went away (the channel's status returns to OK with a 'cleared' message)."""
        if chans:
            self.cleared.append({"effect": "vibration", "channels": [CHANNELS[c] for c in chans], "t_s": t1,
                                 "since_s": float(np.nanmin(self.line_track.since_s[chans]))})

    def _line_amplitude(self, x, f_hz, level, chans):
        """Amplitude (k,) of a line at f_hz in x (n, k), corrected for interval means (sinc), and its sd."""
        n = len(x)
        e = np.exp(-2j * np.pi * f_hz * self.dt * np.arange(n))
        sinc = np.sinc(f_hz * self.dt)
        amp = 2 * np.abs(e @ x) / n / sinc
        sd = self.thr.sample_sigma[chans] * np.sqrt(level) * np.sqrt(2.0 / n) / sinc
        return amp, sd
