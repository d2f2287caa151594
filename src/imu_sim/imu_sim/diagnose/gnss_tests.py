"""GNSS-side effects from the fixes' position residual against the scenario's truth antenna track.

Residual r (ENU, m) = recorded fix - the antenna position the model predicts (truth at the fix
time minus the model's latency, plus C_nb times the model's lever arm). Fixes are taken as
evenly spaced at the median fix interval (gaps closed up), so the tests work on DFT bins:

* colored_gps_noise: Whittle likelihood ratio of the model's noise PSD (white, plus the model's
  own Gauss-Markov part) against it plus an extra Gauss-Markov term, level free, correlation
  time profiled on a grid and shared by the three axes. On a short record (:data:`EXACT_MAX_FIXES`) its sigma and
  tau and their intervals come from the exact restricted likelihood (:func:`exact_profile`), and its held-out fit
  is each half's one-step prediction under the noise fitted on the other half (:func:`heldout_noise_deviance`).
* gps_latency: GLS (frequency-domain whitening, DC dropped so a datum offset is a nuisance) of
  r on -v_enu(t). Whiteness first: if the residual left by the fit is coloured beyond the model
  (the colored_gps_noise test at the 1 % level), the GLS is redone under the model PSD plus the
  fitted extra Gauss-Markov, so coloured noise is not taken for latency.
* gps_lever_arm: the same GLS of r on the rows of C_nb(t) (parameters: body offset, m); body
  axes whose rotated offset stays constant (e.g. z on a level drive) are not identifiable.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymap3d
from scipy import stats
from scipy.linalg import solve_triangular

from nav_core.units import DEG

from imu_sim.diagnose import noise_tests, reference
from imu_sim.diagnose.case import trajectory
from imu_sim.gnss import GpsEffects, antenna_offset_n

AXES = "ENU"
CHANNELS = ("gps_e", "gps_n", "gps_u")
MIN_FIXES = 60
WEAK_SD_RATIO = 10.0
"""A design parameter whose standard error is this many times the best one's is reported as not identifiable."""


@dataclass
class GnssResidual:
    """Fix residual and the truth quantities the GNSS regressors need (SI, ENU)."""

    t: np.ndarray
    """Truth times of the valid fixes, s."""
    r: np.ndarray
    """(n, 3) residual, m."""
    dt: float
    vel: np.ndarray
    rot: np.ndarray
    """(n, 3, 3) body-to-ENU matrices."""
    sigma_w: np.ndarray
    colored_sigma: np.ndarray
    colored_tau: float
    t_rel: np.ndarray = field(default=None)
    """Fix times on the recording's time base, s."""
    reference_error: bool = False
    """The truth is a moving truth file, whose own slow position error is in the residual (always weighted)."""


def gnss_residual(case, model) -> GnssResidual | None:
    """The residual of the case's GNSS fixes under ``model`` (None without fixes or with too few)."""
    g = case.gnss
    if g is None:
        return None
    traj = trajectory(case)
    offset_t = case.sim_t_abs[0] - case.rec.t[0]
    ok = (g.status >= 0) & np.isfinite(g.lat) & np.isfinite(g.lon) & np.isfinite(g.h)
    t_abs = g.t[ok] + offset_t
    ok_t = (t_abs >= traj.t0) & (t_abs <= traj.t1)
    t_abs = t_abs[ok_t]
    if len(t_abs) < MIN_FIXES:
        return None
    eff = GpsEffects.from_physics(model.physics, case.scenario.gps_lever_arm_m)
    t_true = np.clip(t_abs - eff.latency_s, traj.t0, traj.t1)
    lat, lon, h = traj.geodetic(t_true)
    e, n, u = pymap3d.geodetic2enu(g.lat[ok][ok_t] / DEG, g.lon[ok][ok_t] / DEG, g.h[ok][ok_t],
                                   lat / DEG, lon / DEG, h)
    r = np.column_stack([e, n, u]) - antenna_offset_n(traj, t_true, eff.lever_arm_m)
    vel = traj.velocity_n(t_abs)
    rot = traj.attitude.rotation(t_abs).as_matrix()
    dt = float(np.median(np.diff(t_abs)))
    return GnssResidual(t_abs, r, dt, vel, rot, np.asarray(case.scenario.gps.sigma_m, float),
                        eff.colored_sigma_m, eff.colored_time_s, g.t[ok][ok_t], reference.moving_file_truth(case))


def _freqs(n: int, dt: float) -> np.ndarray:
    return np.fft.rfftfreq(n, dt)


def ar1_psd(freqs: np.ndarray, dt: float, sigma: float, tau: float) -> np.ndarray:
    """Two-sided PSD (m^2/Hz) of a sampled Gauss-Markov (AR(1)) process, std sigma m, time constant tau s."""
    phi = np.exp(-dt / tau)
    return sigma**2 * (1 - phi**2) * dt / np.abs(1 - phi * np.exp(-2j * np.pi * freqs * dt)) ** 2


def model_psd(gr: GnssResidual, freqs: np.ndarray) -> np.ndarray:
    """(3, nf) PSD of the model's GNSS noise: white sigma_w plus the model's own Gauss-Markov part."""
    out = np.tile((gr.sigma_w**2 * gr.dt)[:, None], (1, len(freqs)))
    for a in range(3):
        if gr.colored_sigma[a] > 0:
            out[a] += ar1_psd(freqs, gr.dt, gr.colored_sigma[a], gr.colored_tau)
    return out


def tau_grid(gr: GnssResidual) -> np.ndarray:
    """Correlation times profiled (s): 3 fix intervals to a third of the run."""
    span = len(gr.r) * gr.dt
    return np.logspace(np.log10(3 * gr.dt), np.log10(span / 3), 8)


@dataclass
class ColoredFit:
    """Extra Gauss-Markov beyond the model: LR (summed over axes), per-axis variance c, tau."""

    lr: float
    lr_axes: np.ndarray
    var: np.ndarray
    var_ci: list
    tau: float
    n_grid: int
    tau_ci: list = field(default_factory=list)
    by_tau: list = field(default_factory=list)
    """(tau s, per-axis variance) at each correlation time of tau's 95 % set."""
    lr_by_tau: list = field(default_factory=list)
    """The likelihood ratio at each correlation time profiled."""


def whitening_taus(gr: GnssResidual) -> np.ndarray:
    """Correlation times (s) a regression's whitening profiles: :func:`tau_grid` continued at its spacing up to the
    run's length (a correlation time of half the run or more is a slow error a few turns can follow)."""
    base = tau_grid(gr)
    step = base[-1] / base[-2]
    more = base[-1] * step ** np.arange(1, 8)
    return np.r_[base, more[more <= len(gr.r) * gr.dt]]


def colored_fit(r: np.ndarray, gr: GnssResidual, taus: np.ndarray | None = None) -> ColoredFit:
    """Whittle test of an extra Gauss-Markov term in ``r`` (n, 3), correlation time shared by the axes (profiled on
    ``taus``, default :func:`tau_grid`)."""
    freqs, pgram = noise_tests.periodogram(r, gr.dt)
    s0 = model_psd(gr, freqs)
    taus = tau_grid(gr) if taus is None else taus
    best, lr_by_tau, ci_by_tau, var_by_tau = None, [], [], []
    for tau in taus:
        extra = ar1_psd(freqs, gr.dt, 1.0, tau)
        fits = [noise_tests.whittle_extra(pgram[:, a], s0[a], extra) for a in range(3)]
        lr_axes = np.array([f[0] for f in fits])
        lr_by_tau.append(lr_axes.sum())
        ci_by_tau.append([f[2] for f in fits])
        var_by_tau.append(np.array([f[1] for f in fits]))
        if best is None or lr_axes.sum() > best.lr:
            best = ColoredFit(float(lr_axes.sum()), lr_axes, np.array([f[1] for f in fits]),
                              [f[2] for f in fits], float(tau), len(taus))
    keep = np.asarray(lr_by_tau) >= best.lr - 3.84
    inside = taus[keep]
    best.tau_ci = [float(inside.min()), float(inside.max())]
    best.by_tau = [(float(tau), var) for tau, var, k in zip(taus, var_by_tau, keep) if k]
    best.lr_by_tau = [float(v) for v in lr_by_tau]
    # the variance interval at every tau of tau's own 95 % set, joined: tau's uncertainty is carried over
    sets = [ci for ci, k in zip(ci_by_tau, keep) if k]
    best.var_ci = [(min(ci[a][0] for ci in sets), max(ci[a][1] for ci in sets)) for a in range(3)]
    return best


@dataclass
class GnssGls:
    """GLS of the residual on a design: estimates, covariance, Wald LR, identifiable columns."""

    theta: np.ndarray
    cov: np.ndarray
    lr: float
    used: np.ndarray
    whitened_by: str
    noise_extra: tuple | None = None
    """The fitted extra Gauss-Markov it was whitened by: ((3,) variance m^2, tau s), or None."""
    sd_joint: np.ndarray | None = None
    """(k,) standard error of each parameter were all k fitted together (inf where the others or a constant explain
    its regressor): what a parameter left out as weak is determined to on this record."""


def _weights(psd: np.ndarray, n: int, dt: float) -> np.ndarray:
    mult = np.full(psd.shape[1], 2.0)
    mult[0] = 0.0
    if n % 2 == 0:
        mult[-1] = 1.0
    return mult[None, :] * dt / (n * psd)


def gls(r: np.ndarray, design: np.ndarray, psd: np.ndarray, dt: float, groups=None) -> GnssGls:
    """GLS of r (n, 3) on design (n, 3, k) under the per-axis PSD (3, nf); level per axis robustly rescaled;
    ``groups`` as in :func:`_solve_weak_dropped`."""
    n, _, k = design.shape
    rf = np.fft.rfft(r, axis=0)
    xf = np.fft.rfft(design, axis=0)
    w = _weights(psd, n, dt)
    # interior bins: |X|^2 w / 2 ~ Exp(1) under the model, so the median / ln 2 is the level
    scale = np.array([np.median(np.abs(rf[1:, a]) ** 2 * w[a, 1:] / 2.0) / np.log(2) for a in range(3)])
    w = w / np.maximum(scale, 1e-300)[:, None]
    a_mat = np.einsum("fa,fai,faj->ij", w.T, np.conj(xf), xf).real
    b = np.einsum("fa,fai,fa->i", w.T, np.conj(xf), rf).real
    return _solve_used(a_mat, b, k, groups)


EXACT_MAX_FIXES = 600
"""Up to this many fixes (a 10-min drive at 1 Hz) a regression is fitted under the noise's exact covariance
(:func:`gls_exact`: a few correlation times per record is where the DFT's periodic weights go wrong; 2.7 s a fit at
900 fixes, 0.05 s on the DFT); longer records on the DFT."""


def noise_cov(gr: GnssResidual, extra=None) -> np.ndarray:
    """(3, n, n) covariance (m^2) of the fix noise per axis at the fixes' lags: white sigma_w, the model's own
    Gauss-Markov part and ``extra`` ((3,) variance m^2, tau s) when given."""
    n = len(gr.r)
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) * gr.dt
    out = np.zeros((3, n, n))
    own = np.exp(-lag / gr.colored_tau) if np.any(gr.colored_sigma > 0) else None
    more = np.exp(-lag / extra[1]) if extra is not None else None
    for a in range(3):
        if own is not None and gr.colored_sigma[a] > 0:
            out[a] += gr.colored_sigma[a] ** 2 * own
        if more is not None and extra[0][a] > 0:
            out[a] += extra[0][a] * more
        out[a][np.diag_indices(n)] += gr.sigma_w[a] ** 2
    return out


def gls_exact(r: np.ndarray, design: np.ndarray, cov: np.ndarray, groups=None) -> GnssGls:
    """GLS of r (n, 3) on design (n, 3, k) under each axis's exact noise covariance (3, n, n), a datum offset per axis
    a nuisance, the level per axis robustly rescaled (the median square of the whitened residual). The DFT bins'
    weights treat the record as periodic: a Gauss-Markov error whose correlation time is half a 240-s run (1.4 m,
    130 s) then let a lever arm on five turns reach LR > 13.8 in 17 of 60 synthetic runs under the true noise
    (median 6.9; under its exact covariance 0 of 60, median 1.5, chi-square(2)'s 1.4)."""
    n, _, k = design.shape
    one = np.ones(n)
    a_mat, b = np.zeros((k, k)), np.zeros(k)
    for ax in range(3):
        chol = np.linalg.cholesky(cov[ax])
        wx = solve_triangular(chol, np.column_stack([one, design[:, ax, :], r[:, ax]]), lower=True)
        w1, wd, wy = wx[:, :1], wx[:, 1:k + 1], wx[:, k + 1]
        # the datum offset projected out of the whitened columns
        wd = wd - w1 @ np.linalg.lstsq(w1, wd, rcond=None)[0]
        wy = wy - w1[:, 0] * (w1[:, 0] @ wy) / (w1[:, 0] @ w1[:, 0])
        scale = max(float(np.median(wy ** 2)) / stats.chi2.ppf(0.5, 1), 1e-300)
        a_mat += wd.T @ wd / scale
        b += wd.T @ wy / scale
    return _solve_used(a_mat, b, k, groups)


def joint_sd(a_mat: np.ndarray) -> np.ndarray:
    """(k,) standard error of each parameter of the normal equations ``a_mat`` fitted with all the others: one over
    the square root of its Schur complement (inf where the other columns, or nothing, explain its regressor)."""
    k = len(a_mat)
    out = np.full(k, np.inf)
    for i in range(k):
        rest = [j for j in range(k) if j != i]
        cross = a_mat[rest, i]
        schur = a_mat[i, i] - (cross @ np.linalg.lstsq(a_mat[np.ix_(rest, rest)], cross, rcond=1e-12)[0]
                               if rest else 0.0)
        if schur > 1e-12 * max(a_mat[i, i], 1e-300):
            out[i] = 1.0 / np.sqrt(schur)
    return out


def _solve_used(a_mat: np.ndarray, b: np.ndarray, k: int, groups=None) -> GnssGls:
    """Estimates of the normal equations on the columns the data determine (see :data:`WEAK_SD_RATIO`)."""
    fit = _solve_weak_dropped(a_mat, b, k, groups)
    fit.sd_joint = joint_sd(a_mat)
    return fit


def _solve_weak_dropped(a_mat: np.ndarray, b: np.ndarray, k: int, groups=None) -> GnssGls:
    """:func:`_solve_used` without the joint standard errors. ``groups`` (k,) labels the columns of one effect:
    standard errors are compared within an effect only (a latency's in s against a lever arm's in m is a ratio of
    units: on own tactical figure-eights the joint fit of both dropped the whole arm, its LR given the latency 0)."""
    groups = np.zeros(k, int) if groups is None else np.asarray(groups)
    info = np.diag(a_mat)
    used = np.flatnonzero(info > 1e-9 * max(info.max(), 1e-300))
    theta, cov = np.zeros(k), np.full((k, k), np.nan)
    while len(used):
        sub = a_mat[np.ix_(used, used)]
        d = np.sqrt(np.diag(sub))
        if np.linalg.eigvalsh(sub / np.outer(d, d)).min() <= 1e-8:
            break
        cov_u = np.linalg.inv(sub)
        sd = np.sqrt(np.diag(cov_u))
        # a parameter known 10x worse than the best one of its effect is left to the scenario's limits, not fitted
        ratio = sd / np.array([sd[groups[used] == groups[u]].min() for u in used])
        if ratio.max() > WEAK_SD_RATIO:
            used = np.delete(used, int(np.argmax(ratio)))
            continue
        theta[used] = cov_u @ b[used]
        cov[np.ix_(used, used)] = cov_u
        return GnssGls(theta, cov, float(b[used] @ theta[used]), used, "model PSD")
    return GnssGls(theta, cov, 0.0, np.array([], int), "model PSD")


def _regress(gr: GnssResidual, design: np.ndarray, extra=None, groups=None) -> GnssGls:
    """GLS of the fix residual on ``design`` under the model's noise plus ``extra`` ((3,) variance m^2, tau s, or
    None): under its exact covariance up to :data:`EXACT_MAX_FIXES` fixes, on DFT bins beyond."""
    if len(gr.r) <= EXACT_MAX_FIXES:
        fit = gls_exact(gr.r, design, noise_cov(gr, extra), groups)
        fit.whitened_by = "model noise (exact covariance)"
    else:
        freqs = _freqs(len(gr.r), gr.dt)
        psd = model_psd(gr, freqs)
        if extra is not None:
            psd = psd + np.array([extra[0][a] * ar1_psd(freqs, gr.dt, 1.0, extra[1]) for a in range(3)])
        fit = gls(gr.r, design, psd, gr.dt, groups)
    fit.noise_extra = extra
    return fit


def gls_whiteness_first(gr: GnssResidual, design: np.ndarray, level: float = 0.01, groups=None) -> tuple:
    """GLS under the model's noise; if its residual is coloured beyond the model, redo it with the extra GM. On a
    moving truth file the extra GM is always added: the truth's own slow position error is in the fix residual
    whether or not it reaches significance (a 240-s drive's few turns let a lever arm take it).

    Returns (GnssGls, ColoredFit of the fit's residual, whether the noise was found coloured).
    """
    fit = _regress(gr, design, groups=groups)
    left = gr.r - np.einsum("nak,k->na", design, fit.theta)
    col = colored_fit(left, gr, whitening_taus(gr))  # once: the test's own grid is its first len(tau_grid) points
    grid = len(tau_grid(gr))
    coloured = max(col.lr_by_tau[:grid]) > stats.chi2.isf(level / grid, 6)
    if coloured or gr.reference_error:
        # the regression must hold up under every coloured term the residual allows (each correlation time in the
        # 95 % set of its profile, its variance fitted there, the grid continued to the run's length): under the
        # best one alone a slow error the regressor half follows was whitened at too short a time constant (blind
        # consumer drive: lever arm LR 29 under tau 32 s for a 130-s error)
        fit = min((_regress(gr, design, (var, tau), groups) for tau, var in col.by_tau), key=lambda f: f.lr)
        var, tau = fit.noise_extra
        fit.whitened_by = (f"model noise + fitted Gauss-Markov (tau {tau:.3g} s, sigma "
                           f"{', '.join(f'{v:.2g}' for v in np.sqrt(var))} m; the least favourable of the "
                           f"correlation times {col.tau_ci[0]:.3g}-{col.tau_ci[1]:.3g} s the residual allows): " +
                           ("residual not white" if coloured else "the truth file's own slow error") +
                           (" (exact covariance)" if len(gr.r) <= EXACT_MAX_FIXES else ""))
    return fit, col, coloured


def conditional_lrs(gr: GnssResidual) -> dict:
    """LR of latency given the lever arm and of the lever arm given latency (joint fit, same whitening).

    On a car the antenna's forward offset rotates with the heading, as the velocity does, so the
    two regressors are correlated; the conditional LR says which one the data need.
    """
    lat, arm = design_latency(gr), design_lever_arm(gr)
    joint, _, _ = gls_whiteness_first(gr, np.concatenate([lat, arm], axis=2), groups=[0, 1, 1, 1])
    return {"gps_latency": joint.lr - _regress(gr, arm, joint.noise_extra).lr,
            "gps_lever_arm": joint.lr - _regress(gr, lat, joint.noise_extra).lr}


def design_latency(gr: GnssResidual) -> np.ndarray:
    """(n, 3, 1): the residual of an unmodelled latency L is -v(t) L."""
    return -gr.vel[:, :, None]


def design_lever_arm(gr: GnssResidual) -> np.ndarray:
    """(n, 3, 3): the residual of an unmodelled body offset l is C_nb(t) l."""
    return gr.rot


def heldout_columns(design: np.ndarray) -> dict:
    """The design as {axis: (n, k)} for :func:`metrics.heldout_rms`."""
    return {a: design[:, a, :] for a in range(3)}


def whittle_deviance(r: np.ndarray, gr: GnssResidual, var=None, tau=None) -> float:
    """Mean Whittle deviance per bin of r under the model PSD (+ an extra GM), level free per axis."""
    freqs, pgram = noise_tests.periodogram(r, gr.dt)
    s = model_psd(gr, freqs)
    if var is not None:
        s = s + np.array([var[a] * ar1_psd(freqs, gr.dt, 1.0, tau) for a in range(3)])
    out = []
    for a in range(3):
        ratio = pgram[:, a] / s[a]
        out.append(np.mean(np.log(s[a] * ratio.mean())) + 1.0 - np.mean(np.log(pgram[:, a] + 1e-300)))
    return float(np.mean(out))


def half(gr: GnssResidual, part: slice) -> GnssResidual:
    """The fixes of ``part`` as a residual of their own (same noise model)."""
    t_rel = None if gr.t_rel is None else gr.t_rel[part]
    return GnssResidual(gr.t[part], gr.r[part], gr.dt, gr.vel[part], gr.rot[part], gr.sigma_w, gr.colored_sigma,
                        gr.colored_tau, t_rel, gr.reference_error)


def _whitened_axis(gr: GnssResidual, ax: int, cov: np.ndarray) -> tuple:
    """(whitened residual less the datum offset, log of the covariance's Cholesky diagonal) of one axis."""
    chol = np.linalg.cholesky(cov)
    w = solve_triangular(chol, np.column_stack([np.ones(len(gr.r)), gr.r[:, ax]]), lower=True)
    left = w[:, 1] - w[:, 0] * (w[:, 0] @ w[:, 1]) / (w[:, 0] @ w[:, 0])
    return left, np.log(np.diag(chol))


EXACT_RATIOS = np.r_[0.0, np.logspace(-3, 3, 121)]
"""Extra Gauss-Markov variance profiled by :func:`exact_profile`, in units of the model's variance per fix (20 per
decade: an interval's ends are read off this grid)."""


@dataclass
class ExactProfile:
    """REML deviance of an extra Gauss-Markov term on a (tau, axis, variance) grid, the level free per axis."""

    taus: np.ndarray
    dev: np.ndarray
    """(n_tau, 3, n_var) deviance."""
    var: np.ndarray
    """(n_tau, 3, n_var) extra variance (m^2) at each grid point, the level profiled."""

    def best(self) -> tuple:
        """((3,) variance m^2, tau s) of least deviance (tau shared by the axes)."""
        k = int(np.argmin(self.dev.min(axis=2).sum(axis=1)))
        pick = self.dev[k].argmin(axis=1)
        return self.var[k, np.arange(3), pick], float(self.taus[k])

    def intervals(self) -> tuple:
        """(tau's 95 % set [lo, hi] s, per-axis variance interval [(lo, hi)] m^2 joined over that set): the
        profile likelihood's, tau's own uncertainty carried over into each variance's interval."""
        by_tau = self.dev.min(axis=2).sum(axis=1)
        keep = by_tau <= by_tau.min() + stats.chi2.ppf(0.95, 1)
        inside = [self.var[k, a][self.dev[k, a] <= self.dev[k, a].min() + stats.chi2.ppf(0.95, 1)]
                  for k in np.flatnonzero(keep) for a in range(3)]
        var_ci = [(min(v.min() for v in inside[a::3]), max(v.max() for v in inside[a::3])) for a in range(3)]
        return [float(self.taus[keep].min()), float(self.taus[keep].max())], var_ci


def exact_profile(gr: GnssResidual, taus: np.ndarray) -> ExactProfile:
    """The fix residual's restricted (datum offset integrated out) Gaussian likelihood under the model's noise
    (:func:`noise_cov`) plus an extra Gauss-Markov, its level free per axis, profiled over ``taus`` and the
    variance grid :data:`EXACT_RATIOS`; one generalised eigenproblem per tau and axis. A correlation time of half
    the record puts most of the error's variance in the record's mean and trend, where a periodogram (DC dropped)
    cannot see it: the Whittle fit's sigma came out low (intervals covering 48 of 60 on own 300-s drives)."""
    n = len(gr.r)
    cov0 = noise_cov(gr)
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) * gr.dt
    dev = np.zeros((len(taus), 3, len(EXACT_RATIOS)))
    var = np.zeros_like(dev)
    white = [gr.colored_sigma[ax] <= 0 for ax in range(3)]  # the model's own noise white: one eigenproblem per tau
    whiten = [None if white[ax] else solve_triangular(np.linalg.cholesky(cov0[ax]), np.eye(n), lower=True)
              for ax in range(3)]
    cols = [np.column_stack([np.ones(n), gr.r[:, ax]]) for ax in range(3)]
    for k, tau in enumerate(taus):
        shape = np.exp(-lag / tau)
        plain = np.linalg.eigh(shape) if any(white) else None
        for ax in range(3):
            level = cov0[ax][0, 0]
            if white[ax]:
                lam, y1 = plain[0] / level, plain[1].T @ cols[ax] / np.sqrt(level)
            else:
                lam, vec = np.linalg.eigh(whiten[ax] @ shape @ whiten[ax].T)
                y1 = vec.T @ (whiten[ax] @ cols[ax])
            extra = EXACT_RATIOS * level  # m^2
            w = 1.0 / (1.0 + np.outer(extra, np.maximum(lam, 0.0)))
            s11, s1y, syy = w @ y1[:, 0] ** 2, w @ (y1[:, 0] * y1[:, 1]), w @ y1[:, 1] ** 2
            q = (syy - s1y ** 2 / s11) / (n - 1)
            dev[k, ax] = (n - 1) * np.log(q) - np.log(w).sum(axis=1) + np.log(s11)
            var[k, ax] = q * extra
    return ExactProfile(np.asarray(taus, float), dev, var)


def exact_extra_fit(gr: GnssResidual, taus: np.ndarray) -> tuple:
    """The extra Gauss-Markov ((3,) variance m^2, tau s) of largest restricted likelihood (:func:`exact_profile`)."""
    return exact_profile(gr, taus).best()


def conditional_deviance(gr: GnssResidual, start: int, extra=None) -> float:
    """Gaussian deviance of the fixes from ``start`` on given all the fixes before them (the one-step innovations of
    the noise's exact covariance, :func:`noise_cov` plus ``extra``), level free per axis, a datum offset per axis
    fitted; per fix scored, mean over the axes."""
    cov, out = noise_cov(gr, extra), []
    for ax in range(3):
        left, log_diag = _whitened_axis(gr, ax, cov[ax])
        out.append(np.log(np.mean(left[start:] ** 2)) + 2.0 * np.mean(log_diag[start:]))
    return float(np.mean(out))


def heldout_noise_deviance(gr: GnssResidual) -> tuple:
    """(before, after): each half's fixes scored by their one-step prediction from the fixes before them
    (:func:`conditional_deviance`; the first half's from after them, in reverse time - a Gauss-Markov error is
    time-reversible) under the model's noise, and under it plus the extra Gauss-Markov fitted on the other half
    alone (:func:`exact_extra_fit`, correlation times up to the run's length); summed over the halves. A coloured
    error is what makes a fix predictable from its neighbours: with a correlation time of half the record a half's
    spectrum (DC dropped) holds about one correlation time and showed no gain, but each of its fixes still follows
    the one before."""
    mid = len(gr.r) // 2
    fwd, rev = gr, half(gr, slice(None, None, -1))
    taus = whitening_taus(gr)
    first, second = half(gr, slice(0, mid)), half(gr, slice(mid, None))
    before = conditional_deviance(fwd, mid) + conditional_deviance(rev, len(gr.r) - mid)
    after = (conditional_deviance(fwd, mid, exact_extra_fit(first, taus)) +
             conditional_deviance(rev, len(gr.r) - mid, exact_extra_fit(second, taus)))
    return before, after
