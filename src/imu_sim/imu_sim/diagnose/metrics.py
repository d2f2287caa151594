"""Held-out fit statistics (lower is better) and where a fitted effect shows (time span, band)."""
from __future__ import annotations

import numpy as np

from imu_calib.allan import AllanError, overlapping_adev

from imu_sim.diagnose.noise_tests import block_means

N_CHUNKS = 10
"""The run is cut into this many chunks; even chunks train, odd chunks are held out."""
SPAN_BLOCKS = 50


def robust_var(x: np.ndarray) -> float:
    """Variance of x's white part from the median absolute first difference."""
    d = np.abs(np.diff(x))
    return float((np.median(d) / 0.6745) ** 2 / 2.0) if len(d) else 1.0


def heldout_rms(resid: np.ndarray, columns: dict, dt: float, block_s: float, keep: np.ndarray | None = None,
                *, fixed=None, contiguous: bool = False):
    """Normalised RMS of held-out block means before (bias only) and after (bias + effect), trained on even chunks.

    Block means of ``block_s`` s; each channel normalised by its block-to-block scatter, so 1 means
    nothing systematic is left at that averaging time. ``keep`` (n,) bool: only blocks wholly inside it are used.
    ``fixed`` (k,): the effect's coefficients are known (a physical constant at its value), not trained.
    ``contiguous``: trained on the first half of the chunks, scored on the second (a slow curve must extrapolate).
    """
    m = max(1, int(round(block_s / dt)))
    yb = block_means(resid, m)
    nb = len(yb)
    chunk = np.minimum((np.arange(nb) * N_CHUNKS) // max(nb, 1), N_CHUNKS - 1)
    inside = np.ones(nb, bool) if keep is None else block_means(keep[:, None].astype(float), m)[:nb, 0] > 1 - 1e-9
    first = chunk < N_CHUNKS // 2 if contiguous else chunk % 2 == 0
    train, test = first & inside, ~first & inside
    chans = sorted(columns)
    k = next(iter(columns.values())).shape[1]
    xb = {c: block_means(columns[c], m) for c in chans}
    var = {c: robust_var(yb[:, c]) for c in chans}
    rows, rhs = [], []
    for j, c in enumerate(chans):
        bias = np.zeros((train.sum(), len(chans)))
        bias[:, j] = 1.0
        w = 1.0 / np.sqrt(var[c])
        rows.append(np.hstack([xb[c][train], bias]) * w)
        rhs.append(yb[train, c] * w)
    sol = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    if fixed is not None:  # a known constant: its coefficient is not trained, only each channel's bias
        fixed = np.asarray(fixed, float)
        sol = np.concatenate([fixed, [np.mean(yb[train, c] - xb[c][train] @ fixed) for c in chans]])
    before, after = [], []
    for j, c in enumerate(chans):
        mean_train = yb[train, c].mean()
        before.append((yb[test, c] - mean_train) ** 2 / var[c])
        after.append((yb[test, c] - xb[c][test] @ sol[:k] - sol[k + j]) ** 2 / var[c])
    return float(np.sqrt(np.mean(np.concatenate(before)))), float(np.sqrt(np.mean(np.concatenate(after))))


def time_span(resid: np.ndarray, contrib: np.ndarray, t: np.ndarray) -> list:
    """[start, end] s of the stretch where removing the fitted effect helps most (epidemic change points).

    Per block the drop in squared residual, minus its median, then the maximum-sum run of blocks
    (two change points: the effect's onset and end).
    """
    var = np.array([max(robust_var(resid[:, c]), 1e-300) for c in range(resid.shape[1])])
    gain = np.sum((resid**2 - (resid - contrib) ** 2) / var, axis=1)
    edges = np.linspace(0, len(t), SPAN_BLOCKS + 1).astype(int)
    per = np.array([gain[a:b].sum() for a, b in zip(edges[:-1], edges[1:])])
    d = per - np.median(per)
    best, cur, start, span = -np.inf, 0.0, 0, (0, SPAN_BLOCKS - 1)
    for i, v in enumerate(d):
        if cur <= 0:
            cur, start = v, i
        else:
            cur += v
        if cur > best:
            best, span = cur, (start, i)
    if best <= 0:
        return [float(t[0] - (t[1] - t[0])), float(t[-1])]
    return [float(t[edges[span[0]]] - (t[1] - t[0])), float(t[edges[span[1] + 1] - 1])]


def allan_band(before: np.ndarray, after: np.ndarray, rate_hz: float):
    """Cluster times where the Allan deviation before exceeds the one after beyond its 95 % interval.

    Returns (band dict, adev_before, adev_after); the band is the range of such cluster times,
    or the cluster time of the largest ratio marked ``significant: false`` when none qualifies.
    """
    try:
        a_b = overlapping_adev(before, rate_hz)
        a_a = overlapping_adev(after, rate_hz)
    except AllanError:
        return {"cluster_time_s": None, "significant": False}, None, None
    lo_b = a_b.lo if a_b.lo.ndim == 2 else a_b.lo[:, None]
    ad_a = a_a.adev if a_a.adev.ndim == 2 else a_a.adev[:, None]
    ad_b = a_b.adev if a_b.adev.ndim == 2 else a_b.adev[:, None]
    sig = np.any(lo_b > a_a.hi.reshape(ad_a.shape), axis=1)
    if np.any(sig):
        taus = a_b.taus[sig]
        return {"cluster_time_s": [float(taus.min()), float(taus.max())], "significant": True}, a_b, a_a
    ratio = np.max(ad_b / np.maximum(ad_a, 1e-300), axis=1)
    tau = float(a_b.taus[int(np.argmax(ratio))])
    return {"cluster_time_s": [tau / 2, tau * 2], "significant": False}, a_b, a_a
