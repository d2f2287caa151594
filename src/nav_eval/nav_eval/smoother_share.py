"""How often a smoother's error can be no larger than the forward filter's (issue 25's "≥ 95 % of epochs").

For an optimal (Rauch–Tung–Striebel) smoother the smoothed error ``e_s`` is orthogonal to the difference of the two
estimates ``d = x_f - x_s`` (the smoothed estimate is the projection on all the data, the forward one on part of it),
so the forward error is ``e_f = e_s + d`` with ``d`` independent of ``e_s`` for Gaussians. In one dimension
``|e_s| <= |e_f|`` iff ``d (2 e_s + d) >= 0``, a pair of correlated Gaussians: the probability is
``1/2 + asin(rho)/pi``, ``rho = sigma_d / sqrt(sigma_d^2 + 4 sigma_s^2)`` (:func:`share_1d`); 95 % needs
``sigma_f >= 12.6 sigma_s``. :func:`linear_monte_carlo` checks this on an exactly known linear-Gaussian system (an
INS-like error model per horizontal axis, the filter's model = the truth's, exact RTS) and :func:`share_by_kind`
splits a drive's epochs into inside outages, just after one, and with GNSS.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ins_gps_kf.smoother import covariance_root, no_worse_probability

G = 9.81  # m/s^2


def share_1d(sigma_f, sigma_s):
    """Probability that an optimal smoother's 1-D error is no larger in magnitude than the forward one's, from their
    stds (same unit; ``sigma_f >= sigma_s``)."""
    var_d = np.maximum(np.square(sigma_f) - np.square(sigma_s), 0.0)
    return 0.5 + np.arcsin(np.sqrt(var_d / (var_d + 4.0 * np.square(sigma_s)))) / np.pi


@dataclass(frozen=True)
class InsAxis:
    """One horizontal axis of an INS error model (states: position m, velocity m/s, tilt rad, gyro bias rad/s,
    accel bias m/s^2; the tilt couples gravity into the velocity), driven by white noise (rad/sqrt(s),
    m/s/sqrt(s)) and bias random walks (rad/s/sqrt(s), m/s^2/sqrt(s)); position fixes of ``fix_std_m``. Defaults:
    the BP3010 grade of the paper drive (its white noise and rate random walk) and its 0.5-m GNSS."""

    gyro_white: float = 1.75e-3
    accel_white: float = 1.96e-3
    gyro_walk: float = 1e-5
    accel_walk: float = 1e-4
    fix_std_m: float = 0.5
    init_std: tuple = (1.0, 0.5, 0.02, 1.7e-4, 0.03)  # m, m/s, rad, rad/s, m/s^2

    def discrete(self, dt: float) -> tuple:
        """(Phi (5, 5), Q (5, 5)) over ``dt`` s (van Loan)."""
        f = np.zeros((5, 5))
        f[0, 1], f[1, 2], f[1, 4], f[2, 3] = 1.0, G, 1.0, 1.0
        q = np.diag([0.0, self.accel_white, self.gyro_white, self.gyro_walk, self.accel_walk]) ** 2
        big = np.zeros((10, 10))
        big[:5, :5], big[:5, 5:], big[5:, 5:] = -f, q, f.T
        e = expm(big * dt)
        phi = e[5:, 5:].T
        return phi, phi @ e[:5, 5:]


def kalman_rts(model: InsAxis, fixes: np.ndarray, dt: float, runs: int, rng) -> dict:
    """Forward Kalman filter and exact RTS smoother on ``runs`` simulated realisations of ``model`` (the filter's
    model is the truth's); ``fixes`` (n,) bool: a position fix at that epoch. Returns the position errors
    ``e_f``, ``e_s`` (runs, n) m and their variances ``var_f``, ``var_s`` (n,) m^2 (the same for every run)."""
    n = len(fixes)
    phi, q = model.discrete(dt)
    p0 = np.diag(np.square(model.init_std))
    lq, r = np.linalg.cholesky(q + 1e-30 * np.eye(5)), model.fix_std_m ** 2
    e = rng.standard_normal((runs, 5)) @ np.linalg.cholesky(p0).T  # the error (estimate - truth) is all we track
    h = np.array([1.0, 0, 0, 0, 0])
    p, errs, prior = p0.copy(), np.zeros((n, runs, 5)), np.zeros((n, runs, 5))
    p_plus, p_minus = np.zeros((n, 5, 5)), np.zeros((n, 5, 5))
    for k in range(n):
        if k:
            e = e @ phi.T - rng.standard_normal((runs, 5)) @ lq.T  # error = estimate - truth; the truth is driven
            p = phi @ p @ phi.T + q
        p_minus[k], prior[k] = p, e
        if fixes[k]:
            gain = p @ h / (h @ p @ h + r)
            noise = rng.standard_normal(runs) * model.fix_std_m
            e = e - np.outer(e @ h + noise, gain)
            p = p - np.outer(gain, h @ p)
        errs[k], p_plus[k] = e, p
    e_s, p_s = errs[-1].copy(), p_plus[-1].copy()
    out_s, var_s = np.zeros((n, runs)), np.zeros(n)
    out_s[-1], var_s[-1] = e_s[:, 0], p_s[0, 0]
    for k in range(n - 2, -1, -1):
        c = p_plus[k] @ phi.T @ np.linalg.inv(p_minus[k + 1])
        e_s = errs[k] + (e_s - prior[k + 1]) @ c.T
        p_s = p_plus[k] + c @ (p_s - p_minus[k + 1]) @ c.T
        out_s[k], var_s[k] = e_s[:, 0], p_s[0, 0]
    return {"e_f": errs[:, :, 0].T, "e_s": out_s.T, "var_f": p_plus[:, 0, 0], "var_s": var_s}


def linear_monte_carlo(fixes: np.ndarray, dt: float = 0.5, runs: int = 200, seed: int = 0,
                       model: InsAxis | None = None) -> dict:
    """Two independent horizontal axes of :func:`kalman_rts`: the horizontal errors ``h_f``, ``h_s`` (runs, n) m,
    ``no_worse`` (runs, n) bool, the theory's per-epoch probability ``theory`` (n,) (2-D, Monte Carlo from the two
    variances: :func:`ins_gps_kf.smoother.no_worse_probability`), ``one_d`` (n,) (:func:`share_1d`) and the
    correlation of ``e_s`` with ``d = e_f - e_s`` over all epochs and runs (0 for an optimal smoother)."""
    model = model or InsAxis()
    rng = np.random.default_rng(seed)
    axes = [kalman_rts(model, fixes, dt, runs, rng) for _ in range(2)]
    h_f = np.hypot(axes[0]["e_f"], axes[1]["e_f"])
    h_s = np.hypot(axes[0]["e_s"], axes[1]["e_s"])
    var_f, var_s = axes[0]["var_f"], axes[0]["var_s"]
    e_s = np.concatenate([a["e_s"] for a in axes])
    d = np.concatenate([a["e_f"] - a["e_s"] for a in axes])
    theory = no_worse_probability(var_f[:, None, None] * np.eye(2), var_s[:, None, None] * np.eye(2))
    return {"h_f": h_f, "h_s": h_s, "no_worse": h_s <= h_f, "theory": theory,
            "one_d": share_1d(np.sqrt(var_f), np.sqrt(var_s)), "var_f": var_f, "var_s": var_s,
            "corr": float(np.sum(e_s * d) / np.sqrt(np.sum(e_s ** 2) * np.sum(d ** 2)))}


KINDS = ("inside outages", "after an outage", "with GNSS", "GNSS throughout")


def epoch_kinds(t: np.ndarray, windows, after_s: float) -> np.ndarray:
    """Per epoch stamp ``t`` (s): 0 inside an outage window, 1 within ``after_s`` s after one, 2 otherwise (with
    GNSS); index into :data:`KINDS`."""
    kind = np.full(len(t), 2)
    for a, b in windows:
        kind[(t > b) & (t <= b + after_s) & (kind == 2)] = 1
    for a, b in windows:
        kind[(t >= a) & (t <= b)] = 0
    return kind


def share_by_kind(kind: np.ndarray, no_worse: np.ndarray, expected: np.ndarray | None = None) -> dict:
    """{kind name: (epochs, measured share, expected share or NaN)} over the kinds present."""
    out = {}
    for i, name in enumerate(KINDS):
        sel = kind == i
        if np.any(sel):
            out[name] = (int(sel.sum()), float(np.mean(no_worse[sel])),
                         float(np.mean(expected[sel])) if expected is not None else float("nan"))
    return out


def common_epochs(runs) -> tuple:
    """``runs``: per Monte Carlo run (t (n_i,) s, forward error (n_i,), smoothed error (n_i,)). Returns (t (n,) s,
    forward (runs, n), smoothed (runs, n)) at the epochs every run has (stamps equal to the microsecond)."""
    keys = [np.round(np.asarray(t, float), 6) for t, _, _ in runs]
    common = keys[0]
    for k in keys[1:]:
        common = np.intersect1d(common, k)
    idx = [np.searchsorted(k, common) for k in keys]
    return (common, np.array([np.asarray(f)[i] for (_, f, _), i in zip(runs, idx)]),
            np.array([np.asarray(s)[i] for (_, _, s), i in zip(runs, idx)]))


def rms_share(err_f: np.ndarray, err_s: np.ndarray) -> dict:
    """The error statistic per epoch over Monte Carlo runs (issue 25's "smoothed error no larger than the forward
    one in >= 95 % of epochs" as a navigation engineer reads it on simulated drives): ``err_f``, ``err_s`` (runs, n)
    horizontal errors (m) of the same drive's epochs. Returns the RMS across runs per epoch ``rms_f``, ``rms_s``
    (n,) m, ``no_worse`` (n,) bool (``rms_s <= rms_f``), its ``share`` over the epochs and ``ratio`` (n,)
    ``rms_s / rms_f``."""
    err_f, err_s = np.asarray(err_f, float), np.asarray(err_s, float)
    if err_f.shape != err_s.shape or err_f.ndim != 2:
        raise ValueError(f"forward {err_f.shape} and smoothed {err_s.shape} errors: need the same (runs, epochs)")
    rms_f, rms_s = (np.sqrt(np.mean(np.square(e), axis=0)) for e in (err_f, err_s))
    no_worse = rms_s <= rms_f
    ratio = np.divide(rms_s, rms_f, out=np.ones_like(rms_s), where=rms_f > 0)
    return {"rms_f": rms_f, "rms_s": rms_s, "no_worse": no_worse, "share": float(np.mean(no_worse)), "ratio": ratio}


def rms_no_worse_probability(cov_forward, cov_smoothed, runs: int, draws: int = 400, seed: int = 0,
                             chunk: int = 64) -> np.ndarray:
    """Per epoch, the probability that an optimal smoother's RMS error across ``runs`` independent runs is no larger
    than the forward filter's (:func:`rms_share`'s statistic), from the covariances (m, k, k) (m^2): per run
    ``e_s ~ N(0, P_s)`` and ``d ~ N(0, P_f - P_s)`` independent, ``e_f = e_s + d`` (as in
    :func:`ins_gps_kf.smoother.no_worse_probability`); ``draws`` Monte Carlo draws of the ``runs`` runs. Below 1 only
    where the smoother adds little (the end of the data, a long stop), where the runs' sampling noise decides."""
    cov_f, cov_s = np.asarray(cov_forward, float), np.asarray(cov_smoothed, float)
    rng = np.random.default_rng(seed)
    out = np.empty(len(cov_f))
    for lo in range(0, len(cov_f), chunk):
        sl = slice(lo, lo + chunk)
        m, k = cov_f[sl].shape[:2]
        e_s = np.einsum("mij,mdrj->mdri", covariance_root(cov_s[sl]), rng.standard_normal((m, draws, runs, k)))
        d = np.einsum("mij,mdrj->mdri", covariance_root(cov_f[sl] - cov_s[sl]), rng.standard_normal((m, draws, runs, k)))
        out[sl] = np.mean(np.sum(e_s ** 2, axis=(2, 3)) <= np.sum((e_s + d) ** 2, axis=(2, 3)), axis=1)
    return out


def spans(t: np.ndarray, mask: np.ndarray, gap_s: float) -> list[tuple[float, float, int]]:
    """The runs of ``mask`` over stamps ``t`` (s) as (first t, last t, epochs), joining runs less than ``gap_s`` s
    apart."""
    out = []
    for k in np.flatnonzero(mask):
        if out and t[k] - out[-1][1] < gap_s:
            out[-1] = (out[-1][0], float(t[k]), out[-1][2] + 1)
        else:
            out.append((float(t[k]), float(t[k]), 1))
    return out
