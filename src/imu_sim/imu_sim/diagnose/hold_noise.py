"""The residual's wander within a fixture's holds: how far its autocorrelation shrinks the effective sample size
of a mean over a hold (NumPy only), so the joint fit with the tilts (:mod:`fixture`) weights each channel by it."""
from __future__ import annotations

import numpy as np

from imu_sim.diagnose.unstated import mask_spans

INFLATION_BLOCKS_S = (2.0, 5.0, 10.0)
"""Block lengths (s) at which the residual's wander within each hold is measured (:func:`inflation`)."""


def inflation(resid: np.ndarray, hold: np.ndarray, dt: float) -> np.ndarray:
    """Per channel (6,) the variance inflation of a mean over the holds' time scales: block length times the variance
    of the block means about their hold's mean over the per-sample variance (its lower 2-sigma bound), the largest
    over INFLATION_BLOCKS_S, at least 1 (white noise: 1; the residual's autocorrelation shrinks the effective sample size by this factor).
    ``resid`` is (6, n), ``hold`` the (n,) mask of hold samples."""
    spans = mask_spans(hold)
    var = np.array([np.var(resid[c, hold]) for c in range(6)])
    out = np.ones(6)
    for block_s in INFLATION_BLOCKS_S:
        m = max(int(round(block_s / dt)), 1)
        ss, dof = np.zeros(6), 0
        for a, b in spans:
            j = (b - a) // m
            if j < 2:
                continue
            bm = resid[:, a:a + j * m].reshape(6, j, m).mean(axis=2)
            ss += np.sum((bm - bm.mean(axis=1, keepdims=True)) ** 2, axis=1)
            dof += j - 1
        if dof >= 10:  # the estimate's lower 2-sigma bound: white noise's scatter at 10 s is no wander
            lower = max(1.0 - 2.0 * np.sqrt(2.0 / dof), 0.0)
            out = np.maximum(out, lower * m * ss / dof / np.maximum(var, 1e-300))
    return out
