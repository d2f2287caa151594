"""Streaming WMRA: a sliding SWT window with a hop, one output per input at a fixed delay.

Schedule (samples counted from the last restart, ``left, right`` = support, ``H`` =
hop, ``L = right + H - 1`` = delay): whenever ``H`` more outputs can be made exact
(newest index ``m`` with ``m - right >= k0 + H - 1``), the denoiser runs on the span
``k0 - left .. m`` (edge-extended before the first sample) and yields outputs
``k0 .. k0 + H - 1``; each push then releases the output of sample ``m - L``. So
from the ``L+1``-th input on, every input releases exactly one output, ``L``
samples old. :meth:`StreamingWmra.flush` finishes the last ``L`` samples with the
record's last sample repeated, as the batch denoiser does.

Equality claim (tested): for any hop and window, the concatenated outputs of
``push`` and ``flush`` over a record equal ``wmra.denoise`` of that record with the
same thresholds, sample for sample, to floating-point round-off (~1e-15 relative),
*including* the edge regions. With ``noise="model"`` and ``rule="universal"`` the
thresholds are data-free and identical by construction; with data-estimated
thresholds (``mad`` or ``sure``) the stream estimates them once, from the
``L + 1`` samples it holds at its first step after a (re)start, and freezes them
(``thresholds`` attribute); the batch run must be given those thresholds.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from wmra_filter.wmra import WmraConfig, denoise_span, estimate_thresholds


class StreamingWmra:
    """Sliding-window WMRA over (k,) samples: ``push`` one sample, get 0 or 1 ``(tag, value)`` back."""

    def __init__(self, cfg: WmraConfig, n_axes: int, thresholds=None, sample_sigma=None):
        self.cfg = cfg
        self.n_axes = int(n_axes)
        self.left, self.right = cfg.support
        self.window = cfg.window_samples
        self._fixed_thresholds = None if thresholds is None else np.broadcast_to(
            np.asarray(thresholds, dtype=float), (cfg.level, self.n_axes)).copy()
        self._sample_sigma = sample_sigma
        self._buf = np.empty((2 * self.window, self.n_axes))
        self.restarts = 0
        self.reset()

    @property
    def delay_samples(self) -> int:
        """Samples between an input and the release of its output."""
        return self.cfg.delay_samples

    def reset(self) -> None:
        """Forget the stream (pending outputs are dropped: call :meth:`flush` first to keep them)."""
        self._fill = 0            # rows of _buf in use
        self._count = 0           # samples pushed since the restart
        self._next = 0            # index of the next output to compute
        self._first = None        # first sample: the left edge extension
        self._tags = deque()      # tags of samples not yet computed
        self._ready = deque()     # computed, not yet released (tag, value)
        self.thresholds = self._fixed_thresholds
        if self._fixed_thresholds is None and self.cfg.noise == "model" and self.cfg.rule == "universal":
            self.thresholds = estimate_thresholds(self.cfg, self._sample_sigma)

    def restart(self) -> list:
        """Flush, then reset: what a gap or time jump calls. Returns the flushed outputs."""
        out = self.flush()
        self.reset()
        self.restarts += 1
        return out

    def push(self, sample, tag=None) -> list:
        """Add one sample (k,); returns ``[(tag, value)]`` of the sample ``delay_samples`` older, or ``[]``."""
        self._append(np.asarray(sample, dtype=float))
        self._tags.append(tag)
        newest = self._count - 1
        if newest - self.right >= self._next + self.cfg.hop - 1:
            self._compute(self.cfg.hop, right_pad=0)
        if newest >= self.delay_samples:
            return [self._ready.popleft()]
        return []

    def push_many(self, samples, tags=None) -> list:
        """Push rows of ``samples`` (n, k) in order; returns all released ``(tag, value)``.

        Same outputs as calling :meth:`push` row by row (the SWT runs at the same sample
        counts), with the copying done in blocks: what a node taking batches calls.
        """
        samples = np.asarray(samples, dtype=float).reshape(-1, self.n_axes)
        tags = list(range(len(samples)) if tags is None else tags)
        released_before = max(0, self._count - self.delay_samples)
        i = 0
        while i < len(samples):
            due = self._next + self.cfg.hop + self.right  # sample count at which push() would compute
            take = max(1, min(len(samples) - i, due - self._count, self.window))
            self._append_block(samples[i:i + take])
            self._tags.extend(tags[i:i + take])
            i += take
            if self._count >= due:
                self._compute(self.cfg.hop, right_pad=0)
        released = max(0, self._count - self.delay_samples) - released_before
        return [self._ready.popleft() for _ in range(released)]

    def flush(self) -> list:
        """Release every pending output, the last ones computed with the last sample repeated."""
        pending = self._count - self._next
        if pending > 0:
            self._compute(pending, right_pad=self.right)
        out = list(self._ready)
        self._ready.clear()
        return out

    def _append(self, sample: np.ndarray) -> None:
        if self._first is None:
            self._first = sample.copy()
        if self._fill == len(self._buf):  # keep the newest window; amortised O(1)
            self._buf[:self.window - 1] = self._buf[self._fill - self.window + 1:self._fill]
            self._fill = self.window - 1
        self._buf[self._fill] = sample
        self._fill += 1
        self._count += 1

    def _append_block(self, block: np.ndarray) -> None:
        """Append rows (at most ``window`` of them) as :meth:`_append` would one by one."""
        if self._first is None:
            self._first = block[0].copy()
        if self._fill + len(block) > len(self._buf):
            keep = self.window - 1
            self._buf[:keep] = self._buf[self._fill - keep:self._fill]
            self._fill = keep
        self._buf[self._fill:self._fill + len(block)] = block
        self._fill += len(block)
        self._count += len(block)

    def _span(self, start: int) -> np.ndarray:
        """Samples ``start .. newest`` (absolute indices), edge-extended to the left of sample 0."""
        oldest = self._count - self._fill
        have = self._buf[max(start, oldest) - oldest:self._fill]
        if start < 0:
            have = np.vstack([np.repeat(self._first[None, :], -start, axis=0), have])
        return have

    def _compute(self, count: int, right_pad: int) -> None:
        """Denoise outputs ``_next .. _next + count - 1`` and queue them for release."""
        if self.thresholds is None:
            self.thresholds = estimate_thresholds(self.cfg, self._sample_sigma, self._buf[:self._fill])
        start = self._next - self.left
        if not right_pad:
            # the configured window (older samples are outside every output's support: same result)
            start = min(start, self._count - self.window)
        span = self._span(start)
        if right_pad:
            span = np.vstack([span, np.repeat(span[-1:], right_pad, axis=0)])
        offset = self._next - start
        values = denoise_span(span, self.cfg, self.thresholds)[offset:offset + count]
        for value in values:
            self._ready.append((self._tags.popleft(), value))
        self._next += count
