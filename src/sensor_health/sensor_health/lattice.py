"""The output's lattice (counts x lsb) per channel, as the first LATTICE_WARMUP_S of samples show it.

The model's noise is quantized (its increments are counted in lsb steps), so every healthy output sits on one lattice;
a value off it, among samples on it, is no output of the noise, whatever the count of ties: a clamp applied after
scaling (in the unit or its driver) lands between the counts, and a frozen sample repeats an output that was on it.
A scale or offset applied in float moves every sample off it, and is not read as a clip. The lattice is fixed from
the samples before t0 + LATTICE_WARMUP_S, so any split of the same samples into pushes gives the same lattice.
A channel whose warm-up samples do not all sit on one lattice (no quantization, values printed with too few digits,
a bias subtracted in float with rounding) has none, and nothing is read off it.
"""
from __future__ import annotations

import numpy as np

from sensor_health.thresholds import observed_lattice

LATTICE_WARMUP_S = 30.0
"""Seconds of samples the lattice is read from."""
LATTICE_TOL = 0.05
"""A value is on a channel's lattice when value / step is within this many steps of the lattice's phase (float32
storage of count x lsb is 0.006 of a step off at 1e5 counts)."""


def lattice_offset(x, step: float, phase: float) -> np.ndarray:
    """Distance of values x from the lattice of ``step`` through ``phase`` (a fraction of a step), in steps."""
    r = np.asarray(x, float) / step - phase
    return r - np.round(r)


class OutputLattice:
    """The lattice of a stream's six channels; ``floor`` (6,): the smallest difference read as a step (channel units)."""

    def __init__(self, floor: np.ndarray):
        self.floor = np.asarray(floor, float)
        self.ready_t = np.inf
        """Time from which the lattice is known (t0 + LATTICE_WARMUP_S), s."""
        self.step, self.phase = np.zeros(6), np.full(6, np.nan)
        self._warm = []

    def feed(self, t: np.ndarray, x: np.ndarray) -> None:
        """Samples t (m,) s, x (m, 6): gathered until the warm-up ends, where the lattice is fixed."""
        if self._warm is None or len(t) == 0:
            return
        if not np.isfinite(self.ready_t):
            self.ready_t = float(t[0]) + LATTICE_WARMUP_S
        warm = t < self.ready_t
        self._warm.append(x[warm])
        if not warm.all():
            self._fix(np.vstack(self._warm))
            self._warm = None

    def _fix(self, x: np.ndarray) -> None:
        """Channels whose every finite sample of x (m, 6) sits on the lattice of the observed step through the first
        one's phase: their step and phase."""
        seen = observed_lattice(x, self.floor)
        for c in np.flatnonzero(seen > 0):
            v = x[np.isfinite(x[:, c]), c]
            phase = float(lattice_offset(v[0], seen[c], 0.0))
            if np.all(np.abs(lattice_offset(v, seen[c], phase)) <= LATTICE_TOL):
                self.step[c], self.phase[c] = seen[c], phase

    def off(self, c: int, value: float, t_s: float, around: np.ndarray) -> bool:
        """Whether ``value`` of channel c, at t_s s, is off the channel's lattice while every other value of
        ``around`` (the samples near it) is on it (False where no lattice is known yet). A scale or offset applied
        in float moves every sample off the lattice; a clamp only the clipped ones."""
        if t_s < self.ready_t or not np.isfinite(self.phase[c]):
            return False
        if abs(float(lattice_offset(value, self.step[c], self.phase[c]))) <= LATTICE_TOL:
            return False
        rest = around[np.isfinite(around) & (around != value)]
        return bool(len(rest) and np.all(np.abs(lattice_offset(rest, self.step[c], self.phase[c])) <= LATTICE_TOL))
