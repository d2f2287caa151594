"""Timestamp checks of a recording: time going backwards, duplicate stamps, gaps; reusable by every tool.

Use it as ``nav_core.recording.check_timestamps(t, source)``: a :class:`TimeCheck` that names
each problem (source, sample index, time); ``raise_if(...)`` turns the chosen kinds into a
:class:`~nav_core.recording.RecordingError`, ``runs()`` gives the clean stretches between
problems for tools that can work per segment. (A leaf module: it imports nothing of nav_core.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("backwards", "duplicates", "gaps", "non_finite")
DEFAULT_GAP_FACTOR = 10.0
"""Without ``max_gap_s``, a step longer than this many nominal (median) intervals is a gap."""


@dataclass
class TimeCheck:
    """Problems of one time series ``t`` (s); each array holds indices ``i`` where step ``t[i-1] -> t[i]`` is bad."""

    source: str
    t: np.ndarray
    backwards: np.ndarray
    duplicates: np.ndarray
    gaps: np.ndarray
    non_finite: np.ndarray
    """Indices of samples whose time is NaN or infinite."""
    nominal_dt_s: float
    max_gap_s: float
    error: type = ValueError
    """The exception :meth:`raise_if` raises (``RecordingError`` through ``nav_core.recording``)."""

    @property
    def ok(self) -> bool:
        """Whether nothing was found."""
        return not any(len(getattr(self, k)) for k in KINDS)

    def messages(self, kinds=KINDS, limit: int = 3) -> list:
        """One line per kind found, naming the source, count, first sample indices and times."""
        out = []
        for kind in kinds:
            idx = getattr(self, kind)
            if not len(idx):
                continue
            if kind == "non_finite":
                where = ", ".join(f"sample {i}" for i in idx[:limit])
            else:
                where = ", ".join(f"sample {i}: {self.t[i - 1]:.6f} -> {self.t[i]:.6f} s" for i in idx[:limit])
            more = " ..." if len(idx) > limit else ""
            label = {"backwards": "time going backwards", "duplicates": "duplicate stamps",
                     "gaps": f"gaps longer than {self.max_gap_s:.6g} s", "non_finite": "non-finite times"}[kind]
            out.append(f"{self.source}: {len(idx)} {label} ({where}{more})")
        return out

    def summary(self, kinds=KINDS) -> str:
        """All messages on one line ('' when nothing was found)."""
        return "; ".join(self.messages(kinds))

    def raise_if(self, kinds=KINDS) -> TimeCheck:
        """Raise RecordingError naming the problems of the given kinds; returns self when there are none."""
        text = self.summary(kinds)
        if text:
            raise self.error(text)
        return self

    def runs(self, kinds=("backwards", "duplicates", "gaps", "non_finite")) -> list:
        """Slices of the stretches between problems of ``kinds`` (each monotonic and gap-free), longest first.

        A sample with a non-finite time is left out of every stretch.
        """
        bad_samples = self.non_finite if "non_finite" in kinds else np.zeros(0, int)
        steps = [getattr(self, k) for k in kinds if k != "non_finite"]
        cuts = np.unique(np.concatenate(steps + [bad_samples, bad_samples + 1, np.array([0, len(self.t)])]))
        spans = [slice(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:])
                 if b > a and not (b - a == 1 and a in set(bad_samples.tolist()))]
        return sorted(spans, key=lambda s: s.start - s.stop)


def check_timestamps(t, source: str = "recording", max_gap_s: float | None = None,
                     gap_factor: float = DEFAULT_GAP_FACTOR, error: type = ValueError) -> TimeCheck:
    """Check sample times ``t`` (s): backwards steps, duplicates, gaps over ``max_gap_s``
    (default ``gap_factor`` x the median interval), non-finite values."""
    t = np.asarray(t, dtype=float).reshape(-1)
    finite = np.isfinite(t)
    non_finite = np.flatnonzero(~finite)
    dt = np.diff(t)
    good = np.isfinite(dt)
    positive = dt[good & (dt > 0)]
    nominal = float(np.median(positive)) if len(positive) else float("nan")
    if max_gap_s is None:
        max_gap_s = gap_factor * nominal if np.isfinite(nominal) else float("inf")
    with np.errstate(invalid="ignore"):
        backwards = np.flatnonzero(good & (dt < 0)) + 1
        duplicates = np.flatnonzero(good & (dt == 0)) + 1
        gaps = np.flatnonzero(good & (dt > max_gap_s)) + 1
    return TimeCheck(source, t, backwards, duplicates, gaps, non_finite, nominal, float(max_gap_s), error)
