"""The time line of a static recording before an Allan analysis: uniform rate, breaks, segments.

The Allan variance assumes one uninterrupted, uniformly sampled record. A stamp
that goes backwards, a stamp repeated with different values, a gap (missing
samples) or a sample with a NaN or infinite value breaks that: the clusters
spanning it mix data from different times (or carry the NaN into every sum), and
the record's duration is not ``samples / rate``. :func:`timeline` finds every
break; the caller either refuses the recording (the default of ``imu-calib
allan``) or, with ``split``, analyses the longest unbroken segment and records
what was skipped. An exact duplicate row (same stamp and values, a logging
artefact) is not a break: it is dropped and counted (:mod:`imu_calib.screen`).

Sample indices in every message and report are those of the recording as read.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from imu_calib import screen
from imu_calib.allan import AllanError
from nav_core.recording import ImuRecording, check_timestamps

GAP_FACTOR = 1.5
"""A sample interval longer than this many median intervals is a gap (at least one sample is missing)."""
JITTER_TOLERANCE = 0.05
"""Share of intervals that may be irregular (off the median by more than half, but positive and no gap)."""
MAX_LISTED = 20
"""Breaks listed by position in the report (all are counted)."""


@dataclass
class Timeline:
    """Sample rate (Hz), the breaks found and the segments between them (index ranges, end exclusive)."""

    rate_hz: float
    segments: list
    backward_steps: list = field(default_factory=list)
    """(sample index, stamp before s, stamp s) where the stamp goes back."""
    gaps: list = field(default_factory=list)
    """(sample index, stamp before s, stamp s) where samples are missing."""
    repeated: list = field(default_factory=list)
    """(sample index, stamp before s, stamp s) where the stamp repeats with different values."""
    non_finite: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Mask of samples with a NaN or infinite stamp or value (each cuts the record)."""
    duplicates: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Mask of exact duplicate rows (dropped, not a break)."""

    @property
    def broken(self) -> bool:
        return bool(self.backward_steps or self.gaps or self.repeated or self.non_finite.any())

    def longest(self) -> tuple:
        """Index range (start, stop) of the segment with the most samples."""
        return max(self.segments, key=self.size)

    def size(self, seg: tuple) -> int:
        """Samples of segment ``seg`` once exact duplicates are dropped."""
        return int(seg[1] - seg[0] - self.duplicates[seg[0]:seg[1]].sum())

    def select(self, rec: ImuRecording, seg: tuple) -> ImuRecording:
        """The samples of ``seg`` without the exact duplicates."""
        idx = np.arange(seg[0], seg[1])
        return rec.select(idx[~self.duplicates[seg[0]:seg[1]]])

    def describe(self, rec: ImuRecording) -> str:
        """One line naming the file and the first breaks of each kind."""
        source = rec.source or "recording"
        parts = []
        if self.non_finite.any():
            parts.append(screen.describe_non_finite(rec, self.non_finite, named=False))
        if self.repeated:
            i, _, b = self.repeated[0]
            parts.append(f"a stamp repeated with different values {len(self.repeated)} time(s), first at "
                         f"{screen.where(rec, i)}")
        if self.backward_steps:
            i, a, b = self.backward_steps[0]
            parts.append(f"time goes backwards {len(self.backward_steps)} time(s), first at sample {i} "
                         f"(t = {screen.stamp_text(b)} s after {screen.stamp_text(a)} s)")
        if self.gaps:
            i, a, b = max(self.gaps, key=lambda g: g[2] - g[1])
            parts.append(f"{len(self.gaps)} gap(s) in the stamps, the longest {b - a:.6g} s at sample {i} "
                         f"(from {screen.stamp_text(a)} s to {screen.stamp_text(b)} s)")
            if rec.skipped_rows:  # the reader's skipped rows are gaps too: say where they came from
                parts.append(f"the reader skipped line(s) {_lines(rec.skipped_rows)} of the file")
        return f"{source}: " + "; ".join(parts)

    def report(self, used: tuple, rec: ImuRecording) -> dict:
        """What the analysis used, dropped and skipped, for the sensor model's provenance (s, samples)."""
        t = rec.t
        skipped = [s for s in self.segments if s != used]
        listed = lambda items: [{"sample": int(i), "from_s": float(a), "to_s": float(b)} for i, a, b in items[:MAX_LISTED]]
        bad = np.flatnonzero(self.non_finite)
        dup = np.flatnonzero(self.duplicates)
        return {"segments": len(self.segments),
                "used": {"first_sample": int(used[0]), "samples": self.size(used),
                         "from_s": float(t[used[0]]), "to_s": float(t[used[1] - 1])},
                "skipped_samples": int(len(rec) - self.size(used) - len(dup)),
                "skipped_segments": [{"first_sample": int(a), "samples": self.size((a, b)), "from_s": float(t[a]),
                                      "to_s": float(t[b - 1])} for a, b in skipped[:MAX_LISTED]],
                "backward_steps": len(self.backward_steps), "backward_steps_first": listed(self.backward_steps),
                "repeated_stamps": len(self.repeated), "repeated_stamps_first": listed(self.repeated),
                "gaps": len(self.gaps), "gaps_first": listed(self.gaps),
                "gap_total_s": float(sum(b - a for _, a, b in self.gaps)),
                "non_finite_samples": int(len(bad)),
                "non_finite_first": [{"sample": int(i), "t_s": float(t[i])} for i in bad[:MAX_LISTED]],
                "exact_duplicates_dropped": int(len(dup)),
                "exact_duplicates_first": [{"sample": int(i), "t_s": float(t[i])} for i in dup[:MAX_LISTED]]}


def _lines(numbers, limit: int = 3) -> str:
    return ", ".join(str(n) for n in numbers[:limit]) + (" ..." if len(numbers) > limit else "")


def timeline(rec: ImuRecording) -> Timeline:
    """Rate and breaks of ``rec``; AllanError naming the source if it has too few samples or is irregular."""
    source = rec.source or "recording"
    if len(rec) < 2:
        raise AllanError(f"{source}: {len(rec)} samples, nothing to analyse")
    bad = screen.non_finite_rows(rec)
    dup = screen.exact_duplicates(rec)
    idx = np.flatnonzero(~bad & ~dup)  # the samples that count; breaks are found between them
    if len(idx) < 2:
        raise AllanError(screen.describe_non_finite(rec, bad) + f": {len(idx)} usable sample(s), nothing to analyse")
    t = rec.t[idx]
    check = check_timestamps(t, source, gap_factor=GAP_FACTOR)
    median = check.nominal_dt_s
    if not np.isfinite(median):
        raise AllanError(f"{source}: time stamps do not increase")
    dt = np.diff(t)
    irregular = (dt > 0) & (np.abs(dt / median - 1.0) > 0.5) & (dt <= GAP_FACTOR * median)
    if irregular.mean() > JITTER_TOLERANCE:
        raise AllanError(f"{source}: {irregular.mean():.1%} of sample intervals differ from the median "
                         f"{median:.4g} s by more than half; Allan variance needs uniform sampling")
    # a step over k non-finite samples is their break, not a gap, unless it is longer than k + 1 intervals allow
    bad_before = np.concatenate(([0], np.cumsum(bad)))
    spanned = bad_before[idx[1:]] - bad_before[idx[:-1] + 1]  # non-finite samples between kept j-1 and j
    over_bad = np.flatnonzero(spanned > 0) + 1
    gaps = np.array([j for j in check.gaps if dt[j - 1] > GAP_FACTOR * median * (spanned[j - 1] + 1)], int)
    cuts = np.unique(np.concatenate([check.backwards, check.duplicates, gaps, over_bad]).astype(int))
    bounds = np.concatenate(([0], cuts, [len(idx)]))
    segments = [(int(idx[a]), int(idx[b - 1]) + 1) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    step = lambda js: [(int(idx[j]), float(t[j - 1]), float(t[j])) for j in js]
    # stamps in s carry float noise: 1e-6 Hz resolution is plenty for any IMU rate
    return Timeline(float(np.round(1.0 / median, 6)), segments, step(check.backwards), step(gaps),
                    step(check.duplicates), bad, dup)
