"""A named vibration line followed while it lasts: its bins stay out of the run's reference spectrum (a line that
joined the reference would look gone ~10 s after the event while it is still there), the channel stays WARN while
the line's power holds, and the line is *cleared* once the median of its last HOLD_WINDOWS windows is below the hold
level (5 windows after it goes).

No ROS. Frequencies are bins of the monitor's window grid; times s.
"""
from __future__ import annotations

import numpy as np

HOLD_CHI2 = 10.0
"""The line holds while its whitened power against the reference (chi-square(2) on the model's noise), the largest
of the bins next to it, has a median over the last HOLD_WINDOWS windows above this. On noise alone one window's
largest of 5 bins passes it with probability 0.03, a median of 9 windows with 5e-6: a line that went is cleared
within 5 windows. A median and a level well under the gate: a weak line named near the gate (the ADIS16405's
~21-Hz gz line, 15-25 in 1-s windows) dips below the gate's fraction in single windows, and that one beats: 1 to 3
windows near zero every ~10 s."""
HOLD_WINDOWS = 9
TRACK_BINS = 2
"""The held line is looked for this many bins either side of where it was (a line between two bins, one that follows
the speed, or a weak one whose largest neighbouring bin was noise for a window)."""
EXCLUDE_BINS = 2
"""Bins either side of a held line left out of the reference update."""


class LineTrack:
    """Per channel: the bin of the held line (or -1), when it was last seen, when it was cleared."""

    def __init__(self, n_bins: int, hold: float = HOLD_CHI2):
        self.bin = np.full(6, -1)
        self.recent = np.zeros((0, 6))
        self.since_s = np.full(6, np.nan)
        self.cleared_s = np.full(6, np.nan)
        self.n_bins = n_bins
        self.hold = hold

    @property
    def active(self) -> np.ndarray:
        """(6,) a line is held on the channel."""
        return self.bin >= 0

    def start(self, channels, line_bin: int, t_s: float) -> None:
        """Hold a line just named on ``channels`` at searched-bin index ``line_bin`` (of the line bins)."""
        for c in channels:
            self.bin[c], self.since_s[c] = line_bin, t_s
            self.recent[:, c] = np.inf  # the windows that named it held it

    def reference_mask(self) -> np.ndarray:
        """(6, nb) True where the reference spectrum is not updated (bins of a held line)."""
        k = np.arange(self.n_bins)[None, :]
        return self.active[:, None] & (np.abs(k - self.bin[:, None]) <= EXCLUDE_BINS)

    def update(self, ratio: np.ndarray, use: np.ndarray, t_s: float) -> list:
        """One window's whitened power against the reference (6, nb), usable channels (6,) -> channels cleared."""
        power = np.full(6, np.nan)
        for c in np.flatnonzero(self.active & use):
            lo, hi = max(0, self.bin[c] - TRACK_BINS), min(self.n_bins, self.bin[c] + TRACK_BINS + 1)
            j = lo + int(np.argmax(ratio[c, lo:hi]))
            power[c] = ratio[c, j]
            if power[c] > self.hold:
                self.bin[c] = j
        self.recent = np.vstack([self.recent, power])[-HOLD_WINDOWS:]
        with np.errstate(invalid="ignore"):
            held = np.nanmedian(np.where(np.isnan(self.recent), np.inf, self.recent), axis=0)
        gone = np.flatnonzero(self.active & use & (held <= self.hold))
        self.bin[gone], self.cleared_s[gone] = -1, t_s
        return gone.tolist()
