"""The residual's wander within a fixture's holds: how far its autocorrelation shrinks the effective sample size
of a mean over a hold (NumPy only), so the joint fit with the tilts (:mod:`fixture`) weights each channel by it,
and each sensor's own bias change from one hold to the next, a random effect of that joint fit (with the fit's
penalised solver)."""
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


def stated_inflation(model, hold: np.ndarray, dt: float) -> np.ndarray:
    """Per channel (6,) the variance inflation of a mean over half the median hold (s) that the model's own stated
    noise makes: its Allan variance there over the white part's alone (white noise: 1; a consumer unit's flicker,
    stated five times its white level: ~4). :func:`inflation` measures the residual's wander over 2-10 s only, and
    the stated flicker grows past it: a slow curve's evidence within a hold lies at the hold's own scale (own
    consumer fixture null 8003: a 20-s warm-up at LR 53 against 26.7, a flicker's wander in the first hold)."""
    from imu_sim.diagnose.case import effective_model
    from imu_sim.diagnose.noise_tests import predicted_avar
    from nav_core.noise_stats import noise_psd
    spans = mask_spans(hold)
    if not spans:
        return np.ones(6)
    tau = 0.5 * dt * float(np.median([b - a for a, b in spans]))
    mdl = effective_model(model)
    white = np.r_[mdl.gyro.white_noise, mdl.accel.white_noise] ** 2
    full = [predicted_avar(lambda f, c=c: noise_psd(mdl, np.r_[0.0, f])[c, 1:], [tau])[0] for c in range(6)]
    ratio = np.asarray(full) / np.maximum(predicted_avar(lambda f: np.ones_like(f), [tau])[0] * white, 1e-300)
    return np.where(white > 0, np.maximum(ratio, 1.0), 1.0)


def bias_wander(case, w: np.ndarray):
    """(columns (6 n, 6 m at most), prior (6 m, 6 m) with prior.T @ prior the offsets' precision, each column's
    channel 0..5) of each hold's own
    bias offset of each gyro and accelerometer (``w`` (n, m): each hold's weight at each sample, as the fixture's
    tilts) whose model states a bias instability B or a rate random walk K; None when it states neither anywhere.
    The offsets are a random effect (a GLS term) with the unit's stated wander as their covariance per axis: B^2 on
    each hold alone (flicker: hold means differ by about 0.9 B^2 in variance) plus K^2 min(t_i, t_j) (a walk from
    the record's start to each hold's middle, t s), so neighbouring holds differ by K^2 times their spacing, not by
    the whole record's walk. Its prior is charged in the joint fit's objective (:class:`Prior`).

    On still holds a gyro sees only the Earth rate (7.3e-5 rad/s), less than a consumer gyro's bias wander
    (10-50 deg/h): a gyro scale factor or misalignment fitted there took the holds' bias changes (blind seeds 1 and
    2: gyro misalignments of 0.02-1.4 rad and scale factors of 0.06-1.3 as findings). An accelerometer's wander
    from hold to hold (an industrial unit's 10-100 ug) is what an accelerometer scale factor of 1e-5..1e-4 needs on
    +-g holds (blind seed 3's fixture null: 1.8e-5, 6.2e-5, -2.3e-5 as a finding). The effective sample size,
    measured within the holds, misses the wander from one hold to the next. Free (uncharged) offsets took a per-hold
    pattern far beyond the stated wander (blind seed 3: g-sensitivity's likelihood ratio 131 -> 6.8, the up/down
    Earth rate's 37 -> 3.1)."""
    b = np.r_[np.asarray(case.model.gyro.bias_instability, float) * np.ones(3),
              np.asarray(case.model.accel.bias_instability, float) * np.ones(3)]
    k = np.r_[np.asarray(case.model.gyro.rate_random_walk, float) * np.ones(3),
              np.asarray(case.model.accel.rate_random_walk, float) * np.ones(3)]
    chans = [c for c in range(6) if b[c] > 0 or k[c] > 0]
    if not chans:
        return None
    m = w.shape[1]
    t_mid = (case.t - case.t[0]) @ w / np.maximum(w.sum(axis=0), 1e-12)  # each hold's weighted middle, s
    cols = []
    for s in range(m):
        for c in chans:
            col = np.zeros((6, case.n))
            col[c] = w[:, s]
            cols.append(col.ravel())
    nc = len(chans)
    prec = np.zeros((m * nc, m * nc))
    for j, c in enumerate(chans):
        cov = b[c] ** 2 * np.eye(m) + k[c] ** 2 * np.minimum.outer(t_mid, t_mid)
        idx = np.arange(m) * nc + j
        prec[np.ix_(idx, idx)] = np.linalg.inv(cov)
    return np.column_stack(cols), np.linalg.cholesky(prec).T, np.tile(chans, m)


class Prior(np.ndarray):
    """Prior rows on the joint fit's first parameters (prior.T @ prior their precision). Rows marked ``charged`` are
    a random effect's (the holds' bias wander, :func:`bias_wander`), whose penalty counts in the fit's objective (a
    GLS term; no row mixes two channels' offsets); the others are bounds (each tilt within the tolerance), free within them, so only the data's
    misfit counts."""

    def __new__(cls, rows: np.ndarray, charged: np.ndarray):
        out = np.asarray(rows, float).view(cls)
        out.charged = np.asarray(charged, bool)
        return out

    def __array_finalize__(self, obj):
        self.charged = getattr(obj, "charged", None)


def penalised_fit(x: np.ndarray, y: np.ndarray, prior: np.ndarray | None = None) -> tuple:
    """Objective of the fit of y on x (with prior rows on the first parameters: the data's residual sum of squares
    plus a random effect's penalty, :class:`Prior`) and the fit. Solved on the normal equations (p x p): an SVD of
    the (6 n, p) design took 4 s a call on a 22-dwell rate table."""
    a, b = x.T @ x, x.T @ y
    if prior is not None:
        k = prior.shape[1]
        a[:k, :k] += np.asarray(prior).T @ np.asarray(prior)
    d = np.sqrt(np.diag(a))
    d[d == 0] = 1.0
    theta = np.linalg.lstsq(a / np.outer(d, d), b / d, rcond=1e-12)[0] / d
    rss = float(np.sum((y - x @ theta) ** 2))
    charged = getattr(prior, "charged", None)
    if charged is not None and np.any(charged):
        rss += float(np.sum((np.asarray(prior)[charged] @ theta[:prior.shape[1]]) ** 2))
    return rss, theta
