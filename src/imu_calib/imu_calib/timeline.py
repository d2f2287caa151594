"""The time line of a static recording before an Allan analysis: uniform rate, steps back, gaps, segments.

The Allan variance assumes one uninterrupted, uniformly sampled record. A stamp
that goes backwards (or repeats) or a gap (missing samples) breaks that: the
clusters spanning it mix data from different times, and the record's duration
is not ``samples / rate``. :func:`timeline` finds every break; the caller
either refuses the recording (the default of ``imu-calib allan``) or, with
``split``, analyses the longest unbroken segment and records what was skipped.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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
    """(sample index, stamp before s, stamp s) where the stamp does not increase."""
    gaps: list = field(default_factory=list)
    """(sample index, stamp before s, stamp s) where samples are missing."""

    @property
    def broken(self) -> bool:
        return bool(self.backward_steps or self.gaps)

    def longest(self) -> tuple:
        """Index range (start, stop) of the longest segment."""
        return max(self.segments, key=lambda s: s[1] - s[0])

    def describe(self, source: str) -> str:
        """One line naming the first breaks."""
        parts = []
        if self.backward_steps:
            i, a, b = self.backward_steps[0]
            parts.append(f"time goes backwards {len(self.backward_steps)} time(s), first at sample {i} "
                         f"(t = {b:.6g} s after {a:.6g} s)")
        if self.gaps:
            i, a, b = max(self.gaps, key=lambda g: g[2] - g[1])
            parts.append(f"{len(self.gaps)} gap(s) in the stamps, the longest {b - a:.6g} s at sample {i} "
                         f"(from {a:.6g} s to {b:.6g} s)")
        return f"{source}: " + "; ".join(parts)

    def report(self, used: tuple, t) -> dict:
        """What the analysis used and skipped, for the sensor model's provenance (s, samples)."""
        skipped = [s for s in self.segments if s != used]
        listed = lambda items: [{"sample": int(i), "from_s": float(a), "to_s": float(b)} for i, a, b in items[:MAX_LISTED]]
        return {"segments": len(self.segments),
                "used": {"first_sample": int(used[0]), "samples": int(used[1] - used[0]),
                         "from_s": float(t[used[0]]), "to_s": float(t[used[1] - 1])},
                "skipped_samples": int(sum(b - a for a, b in skipped)),
                "skipped_segments": [{"first_sample": int(a), "samples": int(b - a), "from_s": float(t[a]),
                                      "to_s": float(t[b - 1])} for a, b in skipped[:MAX_LISTED]],
                "backward_steps": len(self.backward_steps), "backward_steps_first": listed(self.backward_steps),
                "gaps": len(self.gaps), "gaps_first": listed(self.gaps),
                "gap_total_s": float(sum(b - a for _, a, b in self.gaps))}


def timeline(rec: ImuRecording) -> Timeline:
    """Rate and breaks of ``rec``; AllanError naming the source if it has too few samples or is irregular."""
    source = rec.source or "recording"
    if len(rec) < 2:
        raise AllanError(f"{source}: {len(rec)} samples, nothing to analyse")
    check = check_timestamps(rec.t, source, gap_factor=GAP_FACTOR)
    if len(check.non_finite):
        raise AllanError(f"{source}: {len(check.non_finite)} time stamps are not finite")
    median = check.nominal_dt_s
    if not np.isfinite(median):
        raise AllanError(f"{source}: time stamps do not increase")
    dt = np.diff(rec.t)
    irregular = (dt > 0) & (np.abs(dt / median - 1.0) > 0.5) & (dt <= GAP_FACTOR * median)
    if irregular.mean() > JITTER_TOLERANCE:
        raise AllanError(f"{source}: {irregular.mean():.1%} of sample intervals differ from the median "
                         f"{median:.4g} s by more than half; Allan variance needs uniform sampling")
    back = np.union1d(check.backwards, check.duplicates)  # index i: the step t[i-1] -> t[i] does not increase
    cuts = np.union1d(back, check.gaps)
    bounds = np.concatenate(([0], cuts, [len(rec)]))
    segments = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    t = rec.t
    # stamps in s carry float noise: 1e-6 Hz resolution is plenty for any IMU rate
    return Timeline(float(np.round(1.0 / median, 6)), segments,
                    [(int(i), float(t[i - 1]), float(t[i])) for i in back],
                    [(int(i), float(t[i - 1]), float(t[i])) for i in check.gaps])
