"""A named vibration line followed while it lasts: its bins stay out of the run's reference spectrum (a line that
joined the reference would look gone ~10 s after the event while it is still there), the channel stays WARN while
the line's power holds, and the line is *cleared* once it has been below the hold level for LINE_CLEAR_S.

No ROS. Frequencies are bins of the monitor's window grid; times s.
"""
from __future__ import annotations

import numpy as np

HOLD_FRACTION = 0.3
"""The line holds while its whitened power, against the reference, stays over this fraction of the line gate in
one of the bins next to it (the detector's confirmation fraction: at the test model's gate of 56, 17, which the
model's noise passes in one of 3 bins with probability 7e-4 per window)."""
TRACK_BINS = 1
"""The line may move this many bins per window (a line between two bins, or one that follows the speed)."""
EXCLUDE_BINS = 2
"""Bins either side of a held line left out of the reference update."""
LINE_CLEAR_S = 3.0
"""Below the hold level this long: the line is gone (a 3-s gap is not a line beating with the noise)."""


class LineTrack:
    """Per channel: the bin of the held line (or -1), when it was last seen, when it was cleared."""

    def __init__(self, n_bins: int, window_s: float, gate: float):
        self.bin = np.full(6, -1)
        self.quiet = np.zeros(6, int)
        self.since_s = np.full(6, np.nan)
        self.cleared_s = np.full(6, np.nan)
        self.n_bins = n_bins
        self.clear_windows = max(1, int(round(LINE_CLEAR_S / window_s)))
        self.gate = gate

    @property
    def active(self) -> np.ndarray:
        """(6,) a line is held on the channel."""
        return self.bin >= 0

    def start(self, channels, line_bin: int, t_s: float) -> None:
        """Hold a line just named on ``channels`` at searched-bin index ``line_bin`` (of the line bins)."""
        for c in channels:
            self.bin[c], self.quiet[c], self.since_s[c] = line_bin, 0, t_s

    def reference_mask(self) -> np.ndarray:
        """(6, nb) True where the reference spectrum is not updated (bins of a held line)."""
        k = np.arange(self.n_bins)[None, :]
        return self.active[:, None] & (np.abs(k - self.bin[:, None]) <= EXCLUDE_BINS)

    def update(self, ratio: np.ndarray, use: np.ndarray, t_s: float) -> list:
        """One window's whitened power against the reference (6, nb), usable channels (6,) -> channels cleared."""
        cleared = []
        for c in np.flatnonzero(self.active & use):
            lo, hi = max(0, self.bin[c] - TRACK_BINS), min(self.n_bins, self.bin[c] + TRACK_BINS + 1)
            j = lo + int(np.argmax(ratio[c, lo:hi]))
            if ratio[c, j] > HOLD_FRACTION * self.gate:
                self.bin[c], self.quiet[c] = j, 0
                continue
            self.quiet[c] += 1
            if self.quiet[c] >= self.clear_windows:
                self.bin[c], self.cleared_s[c] = -1, t_s
                cleared.append(int(c))
        return cleared
