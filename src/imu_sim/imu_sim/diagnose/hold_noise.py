"""The residual's wander within a fixture's holds: how far its autocorrelation shrinks the effective sample size
of a mean over a hold (NumPy only), so the joint fit with the tilts (:mod:`fixture`) weights each channel by it,
and each sensor's own bias change from one hold to the next, a random effect of that joint fit (with the fit's
penalised solver)."""
from __future__ import annotations

import numpy as np

from imu_sim.diagnose.unstated import mask_spans

INFLATION_BLOCKS_S = (2.0, 5.0, 10.0)
"""Block lengths (s) at which the residual's wander within each hold is measured (:func:`inflation`)."""


def inflation(resid: np.ndarray, hold: np.ndarray, dt: float, blocks_s=INFLATION_BLOCKS_S) -> np.ndarray:
    """Per channel (6,) the variance inflation of a mean over the holds' time scales: block length times the variance
    of the block means about their hold's mean over the per-sample variance (its lower 2-sigma bound), the largest
    over ``blocks_s``, at least 1 (white noise: 1; the residual's autocorrelation shrinks the effective sample size
    by this factor). ``resid`` is (6, n), ``hold`` the (n,) mask of hold samples."""
    spans = mask_spans(hold)
    var = np.array([np.var(resid[c, hold]) for c in range(6)])
    out = np.ones(6)
    for block_s in blocks_s:
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


def hold_scale_blocks(hold: np.ndarray, dt: float) -> tuple:
    """INFLATION_BLOCKS_S and a quarter of the median hold (s): a slow curve's evidence lies at the hold's own scale,
    where a wander the model does not state (a Gauss-Markov bias of a correlation time near the hold) has grown
    past what 2-10-s blocks see (own industrial fixture, 2.8e-4 rad/s at 40 s: a temperature curve first)."""
    spans = mask_spans(hold)
    if not spans:
        return INFLATION_BLOCKS_S
    return INFLATION_BLOCKS_S + (0.25 * dt * float(np.median([b - a for a, b in spans])),)


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


def bias_wander(case, w: np.ndarray, model=None):
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
    from imu_sim.diagnose.case import effective_model
    mdl = case.model if model is None else effective_model(model)  # a noise term found in a pass before is in it
    b = np.r_[np.asarray(mdl.gyro.bias_instability, float) * np.ones(3),
              np.asarray(mdl.accel.bias_instability, float) * np.ones(3)]
    k = np.r_[np.asarray(mdl.gyro.rate_random_walk, float) * np.ones(3),
              np.asarray(mdl.accel.rate_random_walk, float) * np.ones(3)]
    tc = np.r_[np.asarray(mdl.gyro.bias_correlation_time, float) * np.ones(3),
               np.asarray(mdl.accel.bias_correlation_time, float) * np.ones(3)]
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
    prior = np.zeros((m * nc, m * nc))
    for j, c in enumerate(chans):
        # a Gauss-Markov bias (a correlation time stated or found) stays correlated from one hold to the next
        corr = np.exp(-np.abs(np.subtract.outer(t_mid, t_mid)) / tc[c]) if tc[c] > 0 else np.eye(m)
        cov = b[c] ** 2 * corr + k[c] ** 2 * np.minimum.outer(t_mid, t_mid)
        idx = np.arange(m) * nc + j
        prior[np.ix_(idx, idx)] = _precision_factor(cov)
    return np.column_stack(cols), prior, np.tile(chans, m)


def _precision_factor(cov: np.ndarray) -> np.ndarray:
    """F with F.T @ F the inverse of ``cov`` (symmetric), its eigenvalues floored at 1e-9 of the largest variance.
    A correlation time past the record makes ``cov`` rank one: inverted, then Cholesky-factored, it was not
    positive definite in floating point (LinAlgError on the own generator's mounted-table null 8001)."""
    lam, vec = np.linalg.eigh(cov)
    lam = np.maximum(lam, 1e-9 * max(float(np.max(np.diag(cov))), 1e-300))
    return vec.T / np.sqrt(lam)[:, None]


def noise_key(model) -> tuple:
    """The model's stochastic terms as a hashable key (the holds' wander prior depends on them only)."""
    from imu_sim.diagnose.case import effective_model
    mdl = effective_model(model)
    return tuple(float(v) for tri in (mdl.gyro, mdl.accel) for name in ("white_noise", "bias_instability",
                 "bias_correlation_time", "rate_random_walk") for v in np.ravel(getattr(tri, name)))


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


LEVEL_GRID_S = 1.0
"""Grid (s) on which a hold's mean is integrated for :func:`level_preference` (a hold of 40-90 s: 40-90 nodes)."""
WANDER_TERMS = ("gauss_markov_bias", "bias_random_walk")


def _hold_mean_cov(nodes: list, kernel) -> np.ndarray:
    """Covariance (m, m) of each hold's mean of a process with covariance ``kernel(s, u)`` (s: times of each hold's
    grid ``nodes``): each entry the kernel's mean over the two holds' grids."""
    m = len(nodes)
    out = np.empty((m, m))
    for i in range(m):
        for j in range(i, m):
            out[i, j] = out[j, i] = float(np.mean(kernel(nodes[i][:, None], nodes[j][None, :])))
    return out


def _gm_kernels(s2: float, tau0: float, taus) -> list:
    """Gauss-Markov kernels (s, u) -> covariance over correlation times ``taus`` (s), each at the level sigma^2 / tau
    of (``s2``, ``tau0``): the 1/f^2 power above the knee, all that a hold shorter than tau sees."""
    return [lambda s, u, tc=tc: s2 * tc / tau0 * np.exp(-np.abs(s - u) / tc) for tc in taus]


def _gyro_wander(cand, i: int, record_s: float) -> list:
    """Kernels (s, u) -> covariance (rad/s)^2 of gyro axis ``i``'s wander that noise candidate ``cand`` states: a
    walk's one; a Gauss-Markov bias' over correlation times from its fitted one up to the record, at its fitted
    sigma^2 / tau (:func:`_gm_kernels`): as tau passes the record it becomes the walk, its limit."""
    ax = "xyz"[i]
    if cand.effect == "bias_random_walk":
        k2 = float(cand.params.get(f"gyro_rad_per_s_per_sqrt_s[{ax}]", 0.0)) ** 2
        return [lambda s, u: k2 * np.minimum(s, u)]
    s2 = float(cand.params.get(f"gyro_sigma_rad_per_s[{ax}]", 0.0)) ** 2
    tau0 = max(float(cand.params.get(f"gyro_correlation_time_s[{ax}]", 0.0)), 1e-3)
    return _gm_kernels(s2, tau0, np.logspace(np.log10(tau0), np.log10(max(record_s, tau0)), 10))


def still_holds(case) -> list:
    """The record's holds [(a, b)] when there are three or more and none turns (a fixture's, not a rate table's:
    a table's spinning dwells carry its scale factor), else []."""
    from imu_sim.diagnose.reference import holds
    spans = holds(case) if hasattr(case, "scenario") else []
    if len(spans) < 3 or any(np.max(np.abs(case.gyro_true[a:b])) >= 1e-3 for a, b in spans):
        return []
    return spans


def hold_means_ll(case, model, resid: np.ndarray, i: int, kernels: list, spans: list,
                  x: np.ndarray | None = None) -> np.ndarray:
    """Restricted log-likelihood of gyro axis ``i``'s hold means under each wander kernel: each hold's mean is the
    process' mean over the hold (1-s grid), with the model's white noise (N^2 / hold), stated bias instability (B^2
    a hold) and a tilt's Earth-rate change within the tolerance on the diagonal; the turn-on bias (a constant)
    profiled out, and a regressor's hold means ``x`` (m,) too when given (its coefficient by GLS under each kernel).
    Accelerometers are left out: their hold means are the tilts'."""
    from imu_sim.diagnose.case import effective_model
    t = case.t - case.t[0]
    nodes = [np.arange(t[a], t[b - 1] + 1e-9, LEVEL_GRID_S) + LEVEL_GRID_S / 2 for a, b in spans]
    nodes = [x[x <= t[b - 1]] if np.any(x <= t[b - 1]) else t[a:a + 1] for x, (a, b) in zip(nodes, spans)]
    mdl = effective_model(model)
    tol = np.radians(getattr(case.scenario, "attitude_tolerance_deg", 0.0) or 0.0)
    m = len(spans)
    basis = np.linalg.svd(np.eye(m) - 1.0 / m)[0][:, :m - 1]  # the constant profiled out: m - 1 contrasts
    r = basis.T @ np.array([np.mean(resid[a:b, i]) for a, b in spans])
    diag = (mdl.gyro.white_noise[i] ** 2 / np.array([(b - a) * case.dt for a, b in spans])
            + mdl.gyro.bias_instability[i] ** 2 + (7.292115e-5 * tol) ** 2)
    out = []
    for kernel in kernels:
        cov = basis.T @ (_hold_mean_cov(nodes, kernel) + np.diag(diag)) @ basis
        sign, logdet = np.linalg.slogdet(cov)
        e = r
        if x is not None:
            xr = basis.T @ x
            cx = np.linalg.solve(cov, xr)
            e = r - xr * float(cx @ r) / max(float(cx @ xr), 1e-300)
        out.append(-0.5 * (logdet + float(e @ np.linalg.solve(cov, e))) if sign > 0 else -np.inf)
    return np.array(out)


def level_preference(case, model, resid: np.ndarray, cand, rival) -> float:
    """Twice the log-likelihood ratio (>= 0) of ``cand`` over ``rival`` (a Gauss-Markov bias and a bias random walk,
    each as fitted within the holds) on the gyros' hold means (:func:`hold_means_ll`), the data those fits never
    saw (they run on each hold's residual less its own mean); 0 off three or more still holds or for another pair.
    Within a hold both put the same 1/f^2 power above the hold's frequency once the correlation time nears the hold
    (blind industrial fixture, 2.8e-4 rad/s at 40 s: the Gauss-Markov given the walk 9.9, the walk given it 0, and
    the walk named for its smaller threshold); across holds a Gauss-Markov bias stays within sigma of its mean where
    a walk keeps spreading (K^2 t)."""
    spans = still_holds(case) if {cand.effect, rival.effect} == set(WANDER_TERMS) else []
    if not spans:
        return 0.0
    record = float(case.t[-1] - case.t[0])
    out = sum(float(np.max(hold_means_ll(case, model, resid, i, _gyro_wander(cand, i, record), spans)))
              - float(np.max(hold_means_ll(case, model, resid, i, _gyro_wander(rival, i, record), spans)))
              for i in range(3))
    return max(2.0 * out, 0.0) if np.isfinite(out) else 0.0


def gm_on_hold_means(case, model, resid: np.ndarray, i: int, lev: float, tc: float):
    """(sigma^2, its interval, tau, its interval) of gyro axis ``i``'s Gauss-Markov bias with the correlation time
    profiled on the hold means (:func:`hold_means_ll`) from the fit within the holds (``lev`` = sigma^2 at ``tc`` s)
    up to the record, sigma^2 / tau kept; None off three or more still holds. Within holds a process of tau near or
    past the hold shows only sigma^2 / tau (own industrial fixture, 2.8e-4 rad/s at 40 s: 1.4-1.7e-4 at 4-11 s);
    across holds its bound shows."""
    spans = still_holds(case)
    if not spans or lev <= 0 or tc <= 0:
        return None
    taus = np.logspace(np.log10(tc), np.log10(max(float(case.t[-1] - case.t[0]), tc)), 12)
    ll = hold_means_ll(case, model, resid, i, _gm_kernels(lev, tc, taus), spans)
    if not np.all(np.isfinite(ll)):
        return None
    inside = taus[ll >= ll.max() - 1.92]
    best = float(taus[int(np.argmax(ll))])
    return lev * best / tc, (lev * inside.min() / tc, lev * inside.max() / tc), best, (inside.min(), inside.max())


WALK_GRID = (0.01, 0.03, 0.1, 0.3, 1.0, 3.0)
"""Factors of a walk's fitted K^2 over which :func:`walk_and_temperature` profiles it on the hold means."""


def walk_and_temperature(case, model, resid: np.ndarray, k2: np.ndarray) -> dict | None:
    """Twice the log-likelihood ratios on the gyros' hold means (:func:`hold_means_ll`) of the recorded temperature's
    curve and a bias random walk (K^2 ``k2`` (3,) (rad/s)^2/s as fitted, profiled over :data:`WALK_GRID`), each alone
    and each given the other, on one weighting: ``temperature|walk``, ``walk|temperature``, ``temperature``,
    ``walk``, summed over the gyro axes with a walk. Both explain the holds' slow level changes (a slow wander and a
    slow curve); the hold means tell a walk's spreading scatter from a curve in the logged temperature. None off
    three or more still holds, without a temperature log or a walk."""
    spans = still_holds(case)
    if not spans or getattr(case, "temp_c", None) is None or not np.any(np.asarray(k2) > 0):
        return None
    temp = np.asarray(case.temp_c, float)
    x = np.array([np.mean(temp[a:b]) for a, b in spans])
    zero = [lambda s, u: 0.0 * np.minimum(s, u)]
    out = dict.fromkeys(("temperature|walk", "walk|temperature", "temperature", "walk"), 0.0)
    for i in np.flatnonzero(np.asarray(k2) > 0):
        walks = [lambda s, u, q=f * float(k2[i]): q * np.minimum(s, u) for f in WALK_GRID]
        ll = {(w, t): float(np.max(hold_means_ll(case, model, resid, int(i), zero if w == 0 else walks, spans,
                                                  x if t else None))) for w in (0, 1) for t in (0, 1)}
        if not all(np.isfinite(v) for v in ll.values()):
            return None
        out["temperature|walk"] += 2.0 * (ll[1, 1] - ll[1, 0])
        out["walk|temperature"] += 2.0 * (ll[1, 1] - ll[0, 1])
        out["temperature"] += 2.0 * (ll[0, 1] - ll[0, 0])
        out["walk"] += 2.0 * (ll[1, 0] - ll[0, 0])
    out["axes"] = int(np.sum(np.asarray(k2) > 0))
    return out
