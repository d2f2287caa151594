"""Clipping below the configured range by its flat tops (``saturation``), for
:class:`sensor_health.monitor.HealthMonitor`: more samples of the last CLIP_SPAN_WINDOWS windows exactly at their
extreme, reached in the latest block of CLIP_BLOCK samples, than the model's noise gives on the output's lattice for
the budget.

The count is tested every CLIP_BLOCK samples (0.125 s at 64 Hz), not at window ends: a clip that shows its flat tops
at once is named within a block of them, not up to a window later. The blocks are counted from the first sample, so
any split of the same samples into pushes tests the same spans. The rate of such events on noise is that of the
window test the Monte Carlo threshold is set for: the count of ties at the running extreme of the span rises when a
new tie arrives, whichever evaluation grid sees it (``thresholds.clip_threshold``).

Off the lattice (``lattice``): a value off the output's lattice that the span's extreme repeats, every other sample
of the span on it, is a clip at OFF_LATTICE_TIES samples, no count of ties needed: the model's noise never leaves its
lattice. A clip at a count of
the lattice still needs the tie count.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from sensor_health import thresholds as thr
from sensor_health.events import CHANNELS, Event
from sensor_health.vibration_check import LINE_WARMUP_S
from sensor_health.window_stats import CLIP_SPAN_WINDOWS, span_ties

CLIP_BLOCK = 8
"""Samples between two evaluations of the flat-top count."""
CLIP_ONSET_LOOK_S = 60.0
"""The clip's onset: its first flat top within this many seconds before the event."""
OFF_LATTICE_TIES = 2
"""Samples at one value off the output's lattice, at the span's extreme, that make a clip."""


class ClipCheck:
    """The flat-top count of one monitor (its ``thr``, ``config``, history and ``checked_s``)."""

    def __init__(self, monitor):
        self.mon = monitor
        self.span = max(2, CLIP_SPAN_WINDOWS * monitor.grid.n // CLIP_BLOCK)
        self.buf = np.full((self.span - 1, CLIP_BLOCK, 6), np.nan)
        """The blocks before the next one (NaN before the first: ignored by the count)."""
        self.pending_t, self.pending_x, self.pending_f = np.zeros(0), np.zeros((0, 6)), np.zeros((0, 6), bool)
        self.last = np.full(6, -np.inf)
        self.lattice_done = False

    def push(self, t, x, flags) -> list:
        """Samples t (m,) s, x (m, 6) and their deterministic-fault flags (m, 6) -> saturation events."""
        self.pending_t = np.concatenate([self.pending_t, t])
        self.pending_x = np.vstack([self.pending_x, x])
        self.pending_f = np.vstack([self.pending_f, flags])
        nb = len(self.pending_t) // CLIP_BLOCK
        if nb == 0:
            return []
        m = nb * CLIP_BLOCK
        tb = self.pending_t[:m].reshape(nb, CLIP_BLOCK)
        xb = self.pending_x[:m].reshape(nb, CLIP_BLOCK, 6)
        use = np.isfinite(xb).all(axis=1) & ~self.pending_f[:m].reshape(nb, CLIP_BLOCK, 6).any(axis=1)
        self.pending_t, self.pending_x, self.pending_f = self.pending_t[m:], self.pending_x[m:], self.pending_f[m:]
        span = np.concatenate([self.buf, xb])
        ties = span_ties(span, self.span)
        self.buf = span[-(self.span - 1):]
        events = []
        for b in self._candidates(tb, ties, use):
            events += self._block(tb[b], ties[b], span[b:b + self.span], use[b])
        return events

    def _candidates(self, tb, ties, use):
        """Blocks that may fire (their count reaches the lowest threshold it can have) and the block that ends the
        lattice warm-up (the threshold can change there)."""
        low = np.minimum(self.mon.thr.clip_span_ties, 3)
        low = np.where(np.isfinite(self.mon.lattice.phase), OFF_LATTICE_TIES, low)
        out = set(np.flatnonzero((use & (ties >= low)).any(axis=1)).tolist())
        if not self.lattice_done and self.mon.checked_s[0] is not None:
            warm = np.flatnonzero(tb[:, -1] - self.mon.checked_s[0] >= LINE_WARMUP_S)
            if len(warm):
                out.add(int(warm[0]))
        return sorted(out)

    def _block(self, tb, ties, span, use) -> list:
        """One block: the channels whose count reaches the threshold (once per clear_s)."""
        t1 = float(tb[-1])
        self._lattice(t1)
        th = self.mon.thr
        off = np.array([bool(use[c]) and ties[c] >= OFF_LATTICE_TIES
                        and self.mon.lattice.off(c, _extreme(span, c), t1, span[..., c].ravel()) for c in range(6)])
        hit = use & ((ties >= th.clip_span_ties) | off)
        fired = np.flatnonzero(hit & (t1 - self.last > self.mon.config.clear_s))
        self.last = np.where(hit, t1, self.last)
        return [self._event(c, t1, int(ties[c]), span, bool(off[c])) for c in fired]

    def _event(self, c, t1, ties, span, off) -> Event:
        value = _extreme(span, c)
        flat = span.reshape(-1, 6)
        # the clip began at its first flat top, often well before enough of them gathered
        ht, hx = self.mon._hist_t, self.mon._hist_x
        recent = (ht > t1 - CLIP_ONSET_LOOK_S) & (ht <= t1)
        hits = ht[recent][hx[recent, c] == value]
        onset = float(hits[0]) if len(hits) else t1
        seconds = len(flat) * self.mon.dt
        why = f", off the output's lattice of {self.mon.lattice.step[c]:.3g}" if off else ""
        return Event(t1, onset, "saturation", [CHANNELS[c]], "ERROR", value, [value, value],
                     f"{CHANNELS[c]} clips at {value:.6g} ({ties} samples of the last {seconds:.3g} s at it{why})",
                     {"ties": ties, "threshold": OFF_LATTICE_TIES if off else int(self.mon.thr.clip_span_ties[c]),
                      "off_lattice": off})

    def _lattice(self, t1) -> None:
        """Once, after LINE_WARMUP_S: the threshold again on the lattice the output shows, if finer than the
        model's (the model's quantization is often only an upper bound, and a coarse lattice ties often)."""
        mon = self.mon
        if self.lattice_done or t1 - mon.checked_s[0] < LINE_WARMUP_S:
            return
        self.lattice_done = True
        model = thr.model_lattice(mon.model, mon.dt)
        seen = thr.observed_lattice(mon._hist_x[mon._hist_t <= t1], 1e-4 * mon.thr.sample_sigma)
        lattice = np.where(seen > 0, np.minimum(seen, model), model)
        if np.array_equal(lattice, model):
            return
        ties = thr.clip_threshold(mon.thr.sample_sigma, lattice, mon.grid.n, mon.thr.clip_p_window(),
                                  seed=mon.config.seed)
        mon.thr = replace(mon.thr, clip_span_ties=ties)


def _extreme(span, c) -> float:
    """Channel c's extreme in the span (nb, CLIP_BLOCK, 6): the largest or smallest value, whichever more samples sit
    at (the side ``span_ties`` counts)."""
    flat = span.reshape(-1, 6)
    v = flat[np.isfinite(flat[:, c]), c]
    hi = np.count_nonzero(v == v.max()) >= np.count_nonzero(v == v.min())
    return float(v.max() if hi else v.min())
