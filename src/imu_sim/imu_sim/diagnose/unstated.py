"""Samples a static-segment scenario does not state (a fixture's moves between holds, a rate table's ramps): the
record carries no reference there, so the truth is set to 0 and the residual filled with what carries no information.
NumPy only, imported by :mod:`case` (no cycle through :mod:`reference`)."""
from __future__ import annotations

import numpy as np


TABLE_EDGE_S = 0.1
"""A rate table's stated dwell is trusted from this long (s) after its t0 to this long before its t1: a dwell typed
to 0.01 s may hold the last milliseconds of a ramp (at 150 deg/s^2, 5 ms is 0.75 deg/s in one sample)."""
FILL_SEED = 24
"""Seed of the white noise that stands for the residual where the reference is unknown (fixed: every model's
residual gets the same fill, so fits and drop-one energies compare like with like)."""


def unreferenced_segments(scenario) -> list | None:
    """The stated segments of a static-segment scenario whose moves between them are unknown (None: not such a
    scenario, or one stating ``moves_known: true``)."""
    if getattr(scenario, "source", None) != "static_segments" or getattr(scenario, "moves_known", False):
        return None
    return list(scenario.spec or [])


def is_rate_table(segs) -> bool:
    """Whether any stated segment turns (``rate_dps`` not 0): a rate table, not a fixture."""
    return any(float(s.get("rate_dps", 0.0) or 0.0) != 0.0 for s in segs)


def diff_noise_sd(x: np.ndarray) -> np.ndarray:
    """Robust white-noise sd along axis 0 (same units as ``x``): the MAD of first differences over sqrt 2."""
    diffs = np.diff(x, axis=0)
    return 1.4826 * np.median(np.abs(diffs - np.median(diffs, axis=0)), axis=0) / np.sqrt(2.0)


def mask_spans(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in ``mask`` (n,) as (start, stop) index pairs."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return list(zip(edges[::2], edges[1::2]))


def unstated_moves(scenario, t_abs: np.ndarray, dt: float) -> np.ndarray | None:
    """Mask (n,) of the samples a static-segment scenario does not state: outside its holds (a fixture's moves between
    poses) or its dwells (a rate table's ramps, less :data:`TABLE_EDGE_S` at each edge of a dwell); None when there
    are none or the record is not of static segments. The ramps between two rates are the table controller's (their
    acceleration and shape differ from ramp to ramp), a fixture's moves the operator's (a six-position test turned by
    hand: its profile, duration and wobble); the simulator's own smooth move there is a guess, and its error (tens of
    deg/s for a second) would be fitted as a scale factor, misalignment or warm-up. Such samples are a reference
    error: they carry no information. A scenario stating ``moves_known: true`` (a motorised fixture or table
    driven by it, as the simulator moves) has none."""
    segs = unreferenced_segments(scenario)
    if segs is None:
        return None
    # a fixture's moves (a six-position or up/down test turned by hand) are as unknown as a table's ramps: their
    # profile, duration and wobble are the operator's; at the holds' edges the hand's move starts from rest
    table = is_rate_table(segs)
    edge = TABLE_EDGE_S if table else 0.0
    stated = np.zeros(len(t_abs), bool)
    for seg in segs:
        stated |= (t_abs - dt >= float(seg["t0"]) + edge) & (t_abs <= float(seg["t1"]) - edge)
    if not table:  # a fixture's first hold from the record's start, its last to the end
        stated |= (t_abs <= float(min(s["t0"] for s in segs)) + dt) | (t_abs > float(max(s["t1"] for s in segs)))
    out = ~stated
    return out if out.any() and stated.any() else None


def fill_unstated(resid: np.ndarray, unstated: np.ndarray) -> np.ndarray:
    """The residual (n, 6) with its unstated samples replaced by what carries no information there: each channel's
    level passing linearly from the stated samples before to those after the gap (the turn-on bias and each hold's
    tilt, so no square wave of them reaches the line and noise tests) plus
    white noise at the stated samples' level (robust sd of first differences / sqrt 2, so the GLS noise scale, a
    median over the whole record, is not shrunk by the gap). Regressors are 0 there (the truth is set to 0)."""
    out = resid.copy()
    kept = resid[~unstated]
    level = np.median(kept, axis=0)
    sd = diff_noise_sd(kept)
    noise = np.random.default_rng(FILL_SEED).standard_normal((int(unstated.sum()), resid.shape[1]))
    out[unstated] = level + noise * sd
    # a fixture's holds differ by their tilts (0.17 m/s^2 at 1 deg): a fill at one level made a step at every edge of
    # a move, whose broadband power was a 'vibration' on every hand-turned null and hid a real line; the fill passes
    # from the hold before to the hold after instead (their medians over EDGE_SAMPLES), so no step reaches any test
    for a, b in mask_spans(unstated):
        left = resid[max(0, a - EDGE_SAMPLES):a]
        right = resid[b:b + EDGE_SAMPLES]
        lo = np.median(left, axis=0) if len(left) else (np.median(right, axis=0) if len(right) else level)
        hi = np.median(right, axis=0) if len(right) else lo
        u = (np.arange(b - a) + 1.0)[:, None] / (b - a + 1.0)
        out[a:b] += lo + (hi - lo) * u - level
    return out


EDGE_SAMPLES = 50
"""Samples either side of a gap whose median sets the fill's level at that edge."""
