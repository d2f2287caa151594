"""Checks of single samples and their stamps, exact by construction: non-finite values, the range, exact
repeats (stuck output), gaps and a changed sample interval. Streaming: the state carries across pushes, so
any split of the same samples into pushes gives the same events."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sensor_health.events import CHANNELS, Event

CLIP_LOOK_S = 2.0
"""A repeated value (a run of ``stuck_run``) that is not the extreme of this many seconds before it, or was never
hit there, is a frozen output; one that is their extreme and was hit there as often as the clip test of a window
needs (``clip_ties``: flat tops recur) is a clip (saturation below the configured range). In between it is
unsure until the run ends (a clip) or goes on UNSURE_WAIT_S longer (a freeze)."""
UNSURE_WAIT_S = 0.5
MOTION_FIT_S = 30.0
"""The other channels' samples of this many seconds before a repeat predict the repeating channel (least squares on
them: a yaw rate from the lateral acceleration, at the vehicle's speed) while it repeats."""
MOTION_SPAN = 16
"""Samples of the hold whose mean prediction is compared with the held value (a turn's rate moves on)."""
MOTION_MARGIN = 2.5
"""A repeat at an extreme whose value the motion's prediction passes by this many residual sd (median over the
run) is a clip: the true value went on beyond it. One the prediction leaves inside by as much is a frozen output."""
MOTION_HOLD_MARGIN = 1.0
"""An unsure hold past UNSURE_WAIT_S waits on (up to UNSURE_MAX_S) while the motion puts the true value beyond it by
this many sd: a long flat top in a turn is a clip until the motion comes back inside it."""
UNSURE_MAX_S = 10.0
MOTION_MODEL_ERROR = 0.02
"""Relative error of that prediction (the motion's dynamics, speed changes), as extra sd."""
RATE_CONFIRM = 8
"""Consecutive intervals at one new value that make a sample-rate change (fewer, followed by the old one:
dropouts)."""


def _names(chs) -> list:
    return [CHANNELS[c] for c in chs]


def motion_fit(context: np.ndarray, c: int):
    """Least squares of channel c on the other five over ``context`` (k, 6), the samples before a hold: (coef (6,),
    residual variance), or None with under 2 s of finite samples. A yaw rate in a turn follows the lateral
    acceleration; without motion the prediction is the context's mean."""
    ctx = context[np.isfinite(context).all(axis=1)]
    if len(ctx) < 128:
        return None
    a = np.column_stack([np.ones(len(ctx)), np.delete(ctx, c, axis=1)])
    coef, *_ = np.linalg.lstsq(a, ctx[:, c], rcond=None)
    return coef, float(np.var(ctx[:, c] - a @ coef))


def motion_margins(fit, rows: np.ndarray, c: int, value: float) -> np.ndarray:
    """After each sample of a hold (rows (r, 6)): how far beyond the held ``value`` the other channels put channel
    c's true value, mean over the last MOTION_SPAN samples of the hold, in sd (the prediction's residual sd, which
    carries c's own noise in the held value, and MOTION_MODEL_ERROR). > 0 outward (a clip), < 0 inward (a frozen
    output); 0 without a fit."""
    if fit is None or len(rows) == 0:
        return np.zeros(len(rows))
    coef, var = fit
    others = np.delete(rows, c, axis=1)
    pred = np.column_stack([np.ones(len(rows)), others]) @ coef
    excess = np.where(np.isfinite(pred), np.sign(value) * (pred - value), 0.0)
    cs = np.r_[0.0, np.cumsum(excess)]
    i = np.arange(1, len(rows) + 1)
    r = np.minimum(i, MOTION_SPAN)
    sd = np.sqrt(var * (1 + 1 / r) + (MOTION_MODEL_ERROR * value) ** 2)
    return (cs[i] - cs[i - r]) / r / sd


@dataclass
class Episodes:
    """Per channel the time of the last flagged sample: a flagged sample after ``clear_s`` of none opens a new
    episode (one event each)."""

    clear_s: float
    last: np.ndarray = field(default_factory=lambda: np.full(6, -np.inf))

    def starts(self, t: np.ndarray, flags: np.ndarray):
        """(sample index, channel) of each new episode among flags (m, 6), in time order; updates the state."""
        out = []
        for c in range(6):
            idx = np.flatnonzero(flags[:, c])
            if len(idx) == 0:
                continue
            prev = np.concatenate([[self.last[c]], t[idx[:-1]]])
            out += [(int(i), c) for i in idx[t[idx] - prev > self.clear_s]]
            self.last[c] = t[idx[-1]]
        return sorted(out)


class SampleChecks:
    """Sample-level detectors; :meth:`push` returns events and per-sample fault flags (m, 6)."""

    def __init__(self, dt_s: float, ranges: np.ndarray, stuck_run: np.ndarray, gap_factor: float,
                 rate_tolerance: float, clear_s: float, clip_ties: np.ndarray):
        self.dt_s, self.ranges, self.stuck_run = dt_s, np.asarray(ranges, float), np.asarray(stuck_run, int)
        self.clip_ties = np.asarray(clip_ties, int)
        self.recent = np.zeros((0, 6))
        """The samples before this push (MOTION_FIT_S), for telling a clip from a freeze."""
        self.gap_factor, self.rate_tolerance, self.clear_s = gap_factor, rate_tolerance, clear_s
        self.nonfinite = Episodes(clear_s)
        self.saturated = Episodes(clear_s)
        self.last_t = None
        self.last_x = np.full(6, np.nan)
        self.run = np.zeros(6, int)
        self.run_start_t = np.full(6, np.nan)
        self.unsure = [None] * 6
        self.pending = None
        self.last_dropout_t = -np.inf
        self.dropouts = 0
        self.lattice = None
        """The stream's ``lattice.OutputLattice`` (set by the monitor; None: none known)."""

    def push(self, t: np.ndarray, x: np.ndarray):
        """Events among samples t (m,) s, x (m, 6) and the flags of samples a deterministic fault touches."""
        events = self._timing(t)
        finite = np.isfinite(x)
        sat = finite & (np.abs(np.where(finite, x, 0.0)) >= 0.999 * self.ranges) & (self.ranges > 0)
        for i, c in self.nonfinite.starts(t, ~finite):
            events.append(Event(float(t[i]), float(t[i]), "non_finite", [CHANNELS[c]], "ERROR",
                                int((~finite[i:, c]).sum()), None, f"{CHANNELS[c]}: {x[i, c]} sample",
                                {"samples": int((~finite[i:, c]).sum())}))
        for i, c in self.saturated.starts(t, sat):
            events.append(Event(float(t[i]), float(t[i]), "saturation", [CHANNELS[c]], "ERROR", float(x[i, c]),
                                [float(x[i, c]), float(x[i, c])],
                                f"{CHANNELS[c]} at its range {self.ranges[c]:.6g} (|{x[i, c]:.6g}|)",
                                {"range": float(self.ranges[c])}))
        stuck_events, stuck = self._stuck(t, x)
        events += stuck_events
        flags = ~finite | sat | stuck
        keep = int(round(MOTION_FIT_S / self.dt_s))
        self.recent = np.vstack([self.recent, x])[-keep:]
        return sorted(events, key=lambda e: e.t_s), flags

    def _stuck(self, t, x):
        """Exact repeats: a run reaching ``stuck_run`` samples is one event; flags mark its samples."""
        m = len(t)
        events, flags = [], np.zeros((m, 6), bool)
        idx = np.arange(m)
        for c in range(6):
            v = np.concatenate([[self.last_x[c]], x[:, c]])
            eq = v[1:] == v[:-1]
            last_break = np.maximum.accumulate(np.where(~eq, idx, -1))
            run = np.where(last_break >= 0, idx - last_break + 1, self.run[c] + idx + 1)
            flags[:, c] = run >= self.stuck_run[c]
            events += self._resolve_pending(c, t, x, run, 0)
            for i in np.flatnonzero(run == self.stuck_run[c]):
                start = i - self.stuck_run[c] + 1
                onset = float(t[start]) if start >= 0 else float(self.run_start_t[c])
                kind, fit, rows = self._repeat_kind(c, float(x[i, c]), x[:max(start, 0)], x[max(start, 0):i + 1],
                                                    max(-start, 0), float(t[i]))
                if kind == "unsure":
                    self.unsure[c] = {"onset": onset, "value": float(x[i, c]), "fit": fit, "rows": rows}
                    events += self._resolve_pending(c, t, x, run, i + 1)
                else:
                    events.append(self._repeat_event(c, kind, float(t[i]), onset, float(x[i, c])))
            if m:
                if last_break[-1] >= 0:
                    self.run_start_t[c] = t[last_break[-1]]
                self.run[c] = run[-1]
                self.last_x[c] = x[-1, c]
        return events, flags

    def _resolve_pending(self, c, t, x, run, j0):
        """An unsure repeat, sample by sample: a clip if it ends, or the other channels put the true value beyond it
        (MOTION_MARGIN); a freeze if they put it inside, or the run goes on UNSURE_WAIT_S longer without them
        putting it beyond (MOTION_HOLD_MARGIN), or UNSURE_MAX_S longer in any case."""
        p = self.unsure[c]
        if p is None:
            return []
        rest = run[j0:]
        ends = np.flatnonzero(rest == 1)
        held = np.arange(j0, j0 + (int(ends[0]) if len(ends) else len(rest)))
        rows = np.vstack([p["rows"], x[held]])
        m = motion_margins(p["fit"], rows, c, p["value"])[len(p["rows"]):]
        p["rows"] = rows
        longer = self.stuck_run[c] + int(round(UNSURE_WAIT_S / self.dt_s))
        cap = self.stuck_run[c] + int(round(UNSURE_MAX_S / self.dt_s))
        r = run[held]
        clip = m >= MOTION_MARGIN
        freeze = (m <= -MOTION_MARGIN) | ((r >= longer) & (m < MOTION_HOLD_MARGIN)) | (r >= cap)
        decided = np.flatnonzero(clip | freeze)
        if len(decided):
            j = int(decided[0])
            kind = "saturation" if clip[j] else "stuck_output"
            self.unsure[c] = None
            return [self._repeat_event(c, kind, float(t[held[j]]), p["onset"], p["value"])]
        if len(ends):
            self.unsure[c] = None
            return [self._repeat_event(c, "saturation", float(t[j0 + ends[0]]), p["onset"], p["value"])]
        return []

    def _repeat_kind(self, c, value, before, run_rows, run_before, t_s):
        """saturation, stuck_output or unsure: see CLIP_LOOK_S and MOTION_MARGIN. ``before`` (k, 6): this push's
        samples before the run; ``run_rows`` (r, 6): the run's samples in this push, ``run_before`` more of it at
        the end of ``before`` / the previous pushes; t_s the run's latest sample, s. A held value off the output's
        lattice is a clip."""
        context = np.vstack([self.recent, before])
        if run_before:
            run_rows = np.vstack([context[-run_before:], run_rows])
            context = context[:-run_before]
        look = context[-int(round(CLIP_LOOK_S / self.dt_s)):, c]
        look = look[np.isfinite(look)]
        extreme = len(look) > 0 and (value >= look.max() or value <= look.min())
        fit = motion_fit(context, c)
        if self.lattice is not None and self.lattice.off(c, value, t_s, look):
            return "saturation", fit, run_rows  # a frozen sample repeats an output; a clamp lands between the counts
        margin = motion_margins(fit, run_rows, c, value)[-1]
        if margin >= MOTION_MARGIN:  # the motion went on beyond the held value: a clip, also where it set in mid-turn
            return "saturation", fit, run_rows
        if not extreme or margin <= -MOTION_MARGIN:
            return "stuck_output", fit, run_rows
        kind = "saturation" if np.count_nonzero(look == value) >= self.clip_ties[c] else "unsure"
        return kind, fit, run_rows

    def _repeat_event(self, c, kind, t_s, onset, value):
        name = CHANNELS[c]
        if kind == "saturation":
            return Event(t_s, onset, "saturation", [name], "ERROR", value, [value, value],
                         f"{name} clips at {value:.6g} (flat top, below the range {self.ranges[c]:.6g})",
                         {"run_samples": int(self.stuck_run[c])})
        return Event(t_s, onset, "stuck_output", [name], "ERROR", value, [value, value],
                     f"{name} repeats {value:.9g} for {self.stuck_run[c]} samples or more",
                     {"run_samples": int(self.stuck_run[c])})

    def _timing(self, t):
        """Gaps (dropout) and a changed interval (sample_rate_change), confirmed over RATE_CONFIRM intervals."""
        if len(t) == 0:
            return []
        prev = np.concatenate([[t[0] if self.last_t is None else self.last_t], t[:-1]])
        dts = t - prev
        self.last_t = float(t[-1])
        odd = np.flatnonzero(np.abs(dts / self.dt_s - 1) > self.rate_tolerance)
        if self.pending is None and len(odd) == 0:
            return []
        events = []
        # only odd intervals and the one after each can open or resolve a pending interval
        look = np.union1d(odd, odd + 1)
        look = look[look < len(t)]
        if self.pending is not None:
            look = np.union1d([0], look)
        for i in look:
            dt = dts[i]
            is_odd = abs(dt / self.dt_s - 1) > self.rate_tolerance and dt > 0
            if self.pending is None:
                if is_odd:
                    self.pending = {"t": float(t[i]), "onset": float(prev[i] + self.dt_s), "dt": float(dt), "run": 1}
                continue
            same = is_odd and abs(dt / self.pending["dt"] - 1) <= self.rate_tolerance
            if same:
                self.pending["run"] += 1
                if self.pending["run"] >= RATE_CONFIRM:
                    events.append(self._rate_event(float(t[i]), float(dt)))
            else:
                events += self._resolve_gap(float(t[i]))
                if is_odd:
                    self.pending = {"t": float(t[i]), "onset": float(prev[i] + self.dt_s), "dt": float(dt), "run": 1}
        return events

    def _rate_event(self, t_s, dt):
        old = self.dt_s
        onset = self.pending["onset"]
        self.dt_s, self.pending = dt, None
        return Event(t_s, onset, "sample_rate_change", list(CHANNELS), "WARN", 1.0 / dt,
                     [1.0 / (dt * (1 + self.rate_tolerance)), 1.0 / (dt * (1 - self.rate_tolerance))],
                     f"sample interval {dt * 1e3:.4g} ms (was {old * 1e3:.4g} ms)", {"confirm": RATE_CONFIRM})

    def _resolve_gap(self, t_s):
        """A pending odd interval followed by a normal one: a dropout if it was a gap (jitter is dropped)."""
        p, self.pending = self.pending, None
        if p["dt"] <= self.gap_factor * self.dt_s:
            return []
        self.dropouts += 1
        if t_s - self.last_dropout_t <= self.clear_s:
            self.last_dropout_t = t_s
            return []
        self.last_dropout_t = t_s
        missing = p["dt"] / self.dt_s - 1
        return [Event(t_s, p["onset"], "dropout", list(CHANNELS), "WARN", p["dt"] - self.dt_s,
                      [p["dt"] - self.dt_s, p["dt"] - self.dt_s],
                      f"{missing:.3g} sample intervals missing before t = {p['t']:.6f} s",
                      {"gap_s": p["dt"], "gap_factor": self.gap_factor})]
