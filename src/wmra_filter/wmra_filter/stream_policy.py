"""What ``wmra_node`` does with a stream that is not regular: gap detection, fill, restart (no ROS).

A sample interval that is not positive, or longer than ``gap_factor / sample_rate_hz``, breaks
the stream. A break of up to ``fill_gap_samples`` whole missing samples (a dropped message) is
filled by linear interpolation (the fill samples carry tag ``None``: computed, never published);
any other break restarts the window: the pending outputs are flushed (edge-extended) first.
A sample with a non-finite stamp, rate or specific force is dropped and counted (``nonfinite``): it
never enters the window, where one NaN would spoil every output the wavelet filter draws from it
(91 denoised samples, 1.4 s at 64 Hz); the hole it leaves is filled like a dropped message.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wmra_filter.streaming import StreamingWmra


@dataclass
class PolicyStats:
    """Counts reported in the node's diagnostics."""

    received: int = 0
    restarts: int = 0
    filled_samples: int = 0
    nonfinite: int = 0
    last_restart: str = "none"


class StreamPolicy:
    """Feeds batches of (stamp, sample, tag) to a :class:`StreamingWmra`, filling short gaps, restarting on others."""

    def __init__(self, stream: StreamingWmra, sample_rate_hz: float, gap_factor: float, fill_gap_samples: int):
        self.stream = stream
        self.period_s = 1.0 / float(sample_rate_hz)
        self.max_interval_s = float(gap_factor) * self.period_s
        self.fill_gap_samples = int(fill_gap_samples)
        self.stats = PolicyStats()
        self._last_t: float | None = None
        self._last_sample = None

    def push(self, t_s, samples, tags) -> tuple[list, list]:
        """Push stamps ``t_s`` (n,) s, ``samples`` (n, k), ``tags`` (n); returns (released ``(tag, value)``,
        restart descriptions)."""
        t_s = np.asarray(t_s, dtype=float)
        if len(t_s) == 0:
            return [], []
        self.stats.received += len(t_s)
        finite = np.isfinite(t_s) & np.all(np.isfinite(samples), axis=1)
        if not finite.all():
            self.stats.nonfinite += int(np.sum(~finite))
            t_s, samples, tags = t_s[finite], np.asarray(samples)[finite], [g for g, ok in zip(tags, finite) if ok]
            if len(t_s) == 0:
                return [], []
        previous = np.concatenate([[np.nan if self._last_t is None else self._last_t], t_s[:-1]])
        interval = t_s - previous
        is_break = np.isfinite(previous) & ~((interval > 0.0) & (interval <= self.max_interval_s))
        edges = [0, *np.flatnonzero(is_break).tolist(), len(t_s)]
        released, restarts = [], []
        for a, b in zip(edges[:-1], edges[1:]):
            if a == b:
                continue
            if is_break[a]:
                before = samples[a - 1] if a else self._last_sample
                if not self._fill(previous[a], before, t_s[a], samples[a], released):
                    restarts.append(self._restart(previous[a], t_s[a], released))
            released += self.stream.push_many(samples[a:b], tags[a:b])
        self._last_t, self._last_sample = float(t_s[-1]), np.array(samples[-1], dtype=float)
        return released, restarts

    def flush(self) -> list:
        """Every pending output (shutdown)."""
        return self.stream.flush()

    def _fill(self, t0: float, sample0, t1: float, sample1, released: list) -> bool:
        """Fill a gap of a few whole missing samples by linear interpolation; False if it is not such a gap."""
        steps = int(round((t1 - t0) / self.period_s))
        missing = steps - 1
        if not 1 <= missing <= self.fill_gap_samples or abs(t1 - t0 - steps * self.period_s) > 0.25 * self.period_s:
            return False
        fillers = sample0 + (sample1 - sample0) * (np.arange(1, steps)[:, None] / steps)
        released += self.stream.push_many(fillers, [None] * missing)
        self.stats.filled_samples += missing
        return True

    def _restart(self, t0: float, t1: float, released: list) -> str:
        kind = "time jump" if t1 <= t0 else "gap"
        self.stats.restarts += 1
        self.stats.last_restart = f"{kind} of {t1 - t0:.6g} s at t={t1:.6f}"
        released += self.stream.restart()
        return f"{kind} in the input ({t1 - t0:.6g} s at t={t1:.6f} s): flushing and restarting the window"
