"""The residual's wander within a fixture's holds: how far its autocorrelation shrinks the effective sample size
of a mean over a hold (NumPy only), so the joint fit with the tilts (:mod:`fixture`) weights each channel by it,
and the gyro bias's own change from one hold to the next, a nuisance of that joint fit."""
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


def gyro_bias_wander(case, w: np.ndarray):
    """(columns (6 n, 3 m), prior precisions (3 m,)) of each hold's own gyro bias offset (``w`` (n, m): each hold's
    weight at each sample, as the fixture's tilts), the model's stated gyro bias instability B (plus a stated rate
    random walk K over the record, K sqrt(T / 3)) as its prior sd (rad/s); None when the model states neither.
    On still holds a gyro sees only the Earth rate (7.3e-5 rad/s), less than a consumer gyro's bias wander
    (10-50 deg/h): a gyro scale factor or misalignment fitted there took the holds' bias changes (blind seeds 1 and
    2: gyro misalignments of 0.02-1.4 rad and scale factors of 0.06-1.3 as findings), and the effective sample size,
    measured within the holds, misses the wander from one hold to the next."""
    gm = case.model.gyro
    span = float(case.t[-1] - case.t[0])
    sd = np.sqrt(np.asarray(gm.bias_instability, float) ** 2 + np.asarray(gm.rate_random_walk, float) ** 2 * span / 3)
    axes = [a for a in range(3) if sd[a] > 0]
    if not axes:
        return None
    cols, prec = [], []
    for s in range(w.shape[1]):
        for a in axes:
            col = np.zeros((6, case.n))
            col[a] = w[:, s]
            cols.append(col.ravel())
            prec.append(1.0 / sd[a])
    return np.column_stack(cols), np.asarray(prec)
