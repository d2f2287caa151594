"""The fixture as a nuisance: can a tilt of each static segment, within the scenario's tolerance, mimic a finding?

A static segment's real attitude differs from its stated one by a small rotation d (rad, body axes), the same for the
whole segment; it changes the true specific force by f_b x d and the true rate by w_b x d (both from the truth,
varying in time on a rate table). A candidate's fitted contribution (n, 6) is regressed jointly on these columns
(three tilt parameters per segment, shared by the six channels) and a turn-on bias per channel, each channel weighted
by its noise level, on the holds only. When the candidate's likelihood ratio given the tilts is below its threshold
and the tilts lie within ``attitude_tolerance_deg``, the effect is not separable from the reference on this
record.
"""
from __future__ import annotations

import numpy as np

NOT_SEPARABLE = "not separable from the reference on this record"
TILT_EFFECTS = ("axis_misalignment", "scale_factor", "gyro_g_sensitivity", "gravity_model", "earth_rotation",
                "warmup_drift", "temperature_bias")
"""Effects whose regressors a fixture tilt can reproduce (true rate / specific force on a static segment; a slow
drift sampled by a sequence of holds, each with its own offset)."""


def _weights(case) -> np.ndarray | None:
    """(n, segments) weight of each static segment's tilt at each sample and its time derivative (1/s), or None.

    1 on the hold; across a move the tilt passes from one hold's to the next's with the move's own profile (the
    simulator moves along a smoothstep in rotation-vector space, so its rate magnitude is that profile's slope).
    """
    if getattr(case.scenario, "source", None) != "static_segments":
        return _truth_hold_weights(case)
    t = case.sim_t_abs
    segs = sorted(case.scenario.spec, key=lambda s: float(s["t0"]))
    n, m = case.n, len(segs)
    w, wdot = np.zeros((n, m)), np.zeros((n, m))
    speed = np.linalg.norm(case.gyro_true, axis=1)
    for s, seg in enumerate(segs):
        w[(t > float(seg["t0"])) & (t <= float(seg["t1"])), s] = 1.0
    w[t <= float(segs[0]["t0"]), 0] = 1.0
    w[t > float(segs[-1]["t1"]), m - 1] = 1.0
    for s in range(m - 1):
        rows = (t > float(segs[s]["t1"])) & (t <= float(segs[s + 1]["t0"]))
        if not rows.any():
            continue
        p = speed[rows] if speed[rows].sum() > 0 else np.ones(rows.sum())
        p = p / (p.sum() * case.dt)
        cum = np.cumsum(p) * case.dt
        w[rows, s], w[rows, s + 1] = 1.0 - cum, cum
        wdot[rows, s], wdot[rows, s + 1] = -p, p
    # a rate table's spinning segments get no tilt of their own: the unit is mounted once, and its tilt against the
    # table axis, common to every spinning hold, is the gyro misalignment the table is there to measure
    spinning = [s for s, seg in enumerate(segs) if float(seg.get("rate_dps", 0.0) or 0.0) != 0.0]
    w[:, spinning], wdot[:, spinning] = 0.0, 0.0
    return np.stack([w, wdot])


TILT_SLACK = 1.5
"""A fitted tilt component up to this many tolerances is within it: a fixture off by the tolerance in each of its
Euler angles is off by more about one body axis, and the fit carries its own scatter."""
STILL_RAD_S = 1e-3
"""A truth file's hold turning slower than this (rad/s; the Earth rate is 7.3e-5) is a static fixture pose."""


def _truth_hold_weights(case) -> np.ndarray | None:
    """Weights of :func:`_weights` for a truth file's static holds (:func:`reference.holds` that do not turn: a
    tumble from a CSV), blended linearly across each move; None with fewer than two. A rate table's spinning holds
    are left out: its one mounting tilt, common to every hold, is the gyro misalignment it is there to measure."""
    from imu_sim.diagnose.reference import holds
    spans = [(a, b) for a, b in holds(case) if np.max(np.abs(case.gyro_true[a:b])) < STILL_RAD_S]
    if len(spans) < 2:
        return None
    n, m = case.n, len(spans)
    w, wdot = np.zeros((n, m)), np.zeros((n, m))
    for s, (a, b) in enumerate(spans):
        w[a:b, s] = 1.0
    w[:spans[0][0], 0] = 1.0
    w[spans[-1][1]:, m - 1] = 1.0
    for s in range(m - 1):
        a, b = spans[s][1], spans[s + 1][0]
        if b > a:
            u = (np.arange(a, b) - a + 1) / (b - a + 1)
            w[a:b, s], w[a:b, s + 1] = 1.0 - u, u
            wdot[a:b, s], wdot[a:b, s + 1] = -1.0 / ((b - a + 1) * case.dt), 1.0 / ((b - a + 1) * case.dt)
    return np.stack([w, wdot])


def _tilt_design(case, weights: np.ndarray) -> np.ndarray:
    """Stacked design (6 n, 3 per segment + 6 biases + 1 per segment): f_b x d on accel, w_b x d + dd/dt on gyro;
    then each segment's specific-force scale, the tilt's second-order term (a tilt theta shortens the specific force
    along its nominal direction by 1 - cos theta, up to tolerance^2 / 2)."""
    w, wdot = weights
    n = case.n
    cols = []
    for s in range(w.shape[1]):
        for a in range(3):
            e = np.zeros(3)
            e[a] = 1.0
            col = np.zeros((n, 6))
            col[:, :3] = w[:, s:s + 1] * np.cross(case.gyro_true, e) + wdot[:, s:s + 1] * e
            col[:, 3:] = w[:, s:s + 1] * np.cross(case.accel_true, e)
            cols.append(col.T.ravel())
    for c in range(6):
        col = np.zeros((6, n))
        col[c] = 1.0
        cols.append(col.ravel())
    for s in range(w.shape[1]):
        col = np.zeros((n, 6))
        col[:, 3:] = w[:, s:s + 1] * case.accel_true
        cols.append(col.T.ravel())
    return np.column_stack(cols)


def _stack(columns: dict, n: int, k: int) -> np.ndarray:
    """A candidate's columns per channel (n, k each, shared parameters) as one (6 n, k) design."""
    out = np.zeros((6 * n, k))
    for c, x in columns.items():
        out[c * n:(c + 1) * n] = x
    return out


def _rss(x: np.ndarray, y: np.ndarray, prior: np.ndarray | None = None) -> tuple:
    """Residual sum of squares of y on x (with prior rows on the first parameters) and the fit."""
    if prior is not None:
        p = np.zeros((prior.shape[0], x.shape[1]))
        p[:, :prior.shape[1]] = prior
        theta, *_ = np.linalg.lstsq(np.vstack([x, p]), np.concatenate([y, np.zeros(len(p))]), rcond=None)
    else:
        theta, *_ = np.linalg.lstsq(x, y, rcond=None)
    return float(np.sum((y - x @ theta) ** 2)), theta


def check(case, cand, resid: np.ndarray) -> str | None:
    """The note when a fixture tilt within tolerance can stand for ``cand`` (None: separable or not applicable).

    Joint fit on the residual (n, 6), each channel scaled by its noise std: the candidate's likelihood ratio given
    the tilts (and turn-on biases), against the one given the biases alone, scales its GLS statistic.
    """
    if cand.effect not in TILT_EFFECTS or not cand.columns:
        return None
    weights = _weights(case)
    tol = np.radians(case.scenario.attitude_tolerance_deg)
    if weights is None or tol <= 0:
        return None
    n, m = case.n, weights.shape[2]
    k = next(iter(cand.columns.values())).shape[1]
    tilt = _tilt_design(case, weights)
    eff = _stack(cand.columns, n, k)
    bias = tilt[:, 3 * m:3 * m + 6]
    raw = resid.T.ravel()
    _, th = _rss(np.hstack([tilt, eff]), raw)
    sigma = np.std((raw - np.hstack([tilt, eff]) @ th).reshape(6, n), axis=1)
    # the moves between holds are left out: the simulator's path between two tilted holds is not the first-order
    # blend of their tilts (a rotation-vector path of up to 180 deg), so only the holds are compared
    hold = np.all(np.isin(weights[0], (0.0, 1.0)), axis=1)
    w = np.repeat(1.0 / np.maximum(sigma, 1e-300), n) * np.tile(hold, 6)
    y, tilt, eff, bias = raw * w, tilt * w[:, None], eff * w[:, None], bias * w[:, None]
    # the tolerance is a Gaussian prior (sd = tolerance) on each tilt: a rotation about the gravity axis, which the
    # specific force cannot see, stays within it instead of fitting the Earth rate's noise with tens of degrees
    prior = np.diag(np.r_[np.full(3 * m, 1.0 / tol), np.zeros(6), np.full(m, 2.0 / tol**2)])
    lr_alone = _rss(bias, y)[0] - _rss(np.hstack([bias, eff]), y)[0]
    rss_tilt, _ = _rss(tilt, y, prior)
    rss_joint, theta = _rss(np.hstack([tilt, eff]), y, prior)
    if lr_alone <= 0:
        return None
    if getattr(case.scenario, "source", None) != "static_segments" and lr_alone < cand.threshold:
        return None  # a truth file's effect seen only off its still holds (a rate table's spins): no tilt's doing
    given = max(rss_tilt - rss_joint, 0.0)
    _, th_tilt = _rss(tilt, y, prior)
    tilts = np.abs(th_tilt[:3 * m])
    if given < cand.threshold and np.all(tilts <= TILT_SLACK * tol):
        return (f"{NOT_SEPARABLE}: on the holds, given a tilt of each static segment's fixture (at most "
                f"{np.degrees(tilts.max()):.3g} deg, tolerance {case.scenario.attitude_tolerance_deg:g} deg: "
                f"attitude_tolerance_deg) its likelihood ratio falls from {lr_alone:.3g} to {given:.3g}, below the "
                f"threshold {cand.threshold:.3g}; not ranked")
    return None
