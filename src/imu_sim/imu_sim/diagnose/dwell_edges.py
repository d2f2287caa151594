"""A rate table's stated dwells checked against the record: the edges of a dwell where the table has not yet reached
(or has already left) its rate carry no reference. NumPy only, imported by :mod:`case`.

A user types a table's dwells from the controller's schedule or a coarse log (t0, t1 to half a second): a dwell may
then begin inside the ramp before it, where the table turns slower than the stated rate. Every such edge is the
same sign against the rate on a table whose rates alternate, so it is fitted as a scale factor that is too small in
magnitude (blind consumer rate table, f595019: 7-32 % low, intervals +-0.7 %)."""
from __future__ import annotations

import numpy as np

from imu_sim.diagnose.unstated import diff_noise_sd, is_rate_table, unreferenced_segments

SMOOTH_SAMPLES = 5
"""Running mean (samples) of the spin-axis rate's deviation from its dwell's level before it is compared."""
EDGE_SIGMAS = 4.0
"""A smoothed deviation beyond this many of its noise sd is the table still changing rate."""
MAX_EDGE = 0.25
"""At most this fraction of a dwell is cut at each edge (a longer transient is not an edge: left to the tests)."""


def unsettled_edges(scenario, t_abs: np.ndarray, gyro: np.ndarray, unstated: np.ndarray | None) -> np.ndarray | None:
    """Mask (n,) of the samples at the edges of a rate table's stated segments where the recorded rate about the
    segment's spin axis (``axis_body``, default z) has not settled at the segment's level: from each edge inwards, the
    samples before the first whose running mean (:data:`SMOOTH_SAMPLES`) is within :data:`EDGE_SIGMAS` noise sd of the
    segment's median (the sd from the segment's first differences). None when the record is not such a table or
    no edge is cut. ``gyro`` is the recording (rad/s); the level is the record's own, so a scale factor, a bias or a
    misalignment of the sensor does not move the cut."""
    segs = unreferenced_segments(scenario)
    if segs is None or not is_rate_table(segs):
        return None
    stated = np.ones(len(t_abs), bool) if unstated is None else ~unstated
    out = np.zeros(len(t_abs), bool)
    for seg in segs:
        idx = np.flatnonzero((t_abs > float(seg["t0"])) & (t_abs <= float(seg["t1"])) & stated)
        if len(idx) < 4 * SMOOTH_SAMPLES:
            continue
        axis = np.asarray(seg.get("axis_body", [0.0, 0.0, 1.0]), float)
        rate = gyro[idx] @ (axis / np.linalg.norm(axis))
        level = np.median(rate)
        # a floor for a noise-free record (a simulator's own output): its rounding, not its noise
        sd = max(float(diff_noise_sd(rate)), 1e-9 * (abs(level) + 1e-6))
        dev = np.convolve(rate - level, np.ones(SMOOTH_SAMPLES) / SMOOTH_SAMPLES, mode="same")
        ok = np.abs(dev) <= EDGE_SIGMAS * sd / np.sqrt(SMOOTH_SAMPLES)
        if not ok.any():
            continue
        cap = int(MAX_EDGE * len(idx))
        lead = min(int(np.argmax(ok)), cap)
        trail = min(int(np.argmax(ok[::-1])), cap)
        # the running mean spreads an edge's transient over half its window: cut that much more
        if lead:
            out[idx[:lead + SMOOTH_SAMPLES // 2]] = True
        if trail:
            out[idx[len(idx) - trail - SMOOTH_SAMPLES // 2:]] = True
    return out if out.any() else None
