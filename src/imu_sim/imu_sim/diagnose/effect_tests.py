"""The registry of per-effect tests: each takes one :class:`~imu_sim.diagnose.candidate.Context` and returns a
:class:`~imu_sim.diagnose.candidate.Candidate` (statistic, threshold, fit with intervals, how to add it to the model).

Deterministic effects are GLS regressions on a design from :mod:`regressors`; the line and the lattice are tested
here too; the slow noise terms live in :mod:`noise_candidates`. The GNSS effects are tested together by
:mod:`gnss_candidates` (they share one fix residual).
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from imu_sim.diagnose import metrics, noise_candidates, noise_tests, reference, regressors
from imu_sim.diagnose.candidate import ALPHA, CONING_NOTE, Candidate, Context, not_testable, threshold
from imu_sim.diagnose.case import CHANNELS, effective_model
from imu_sim.diagnose.spectral import SE_MAX, GlsResult, gls

KINEMATIC = ("earth_rotation", "gravity_model", "coriolis")
FILE_LATTICE = 0.01
"""A lattice step below this fraction of the per-sample noise std is the file's, not the sensor's."""


def drifting_channels(model) -> list:
    """Channels whose model noise has a rate random walk or a rate ramp: each carries one end-to-end drift of
    unknown slope (a walk's record is a ramp plus stationary wander in the DFT), a nuisance for regressions."""
    mdl = effective_model(model)
    return [c for c in range(6) if mdl.triad(("gyro", "accel")[c // 3]).rate_random_walk[c % 3] > 0
            or mdl.triad(("gyro", "accel")[c // 3]).rate_ramp[c % 3] != 0]


def nuisance(ctx: Context) -> dict:
    """Nuisance columns per channel: a ramp on each drifting channel, a bias step at each join of files."""
    n = ctx.case.n
    drift = drifting_channels(ctx.model)
    resets = list(getattr(ctx.case, "bias_resets", None) or [])
    out = {}
    for c in range(6):
        cols = [ctx.case.t - ctx.case.t[0]] if c in drift else []
        cols += [(np.arange(n) >= r).astype(float) for r in resets]
        if cols:
            out[c] = np.column_stack(cols)
    return out


def fit(ctx: Context, columns: dict, k: int, se_max: float | None = None):
    """GLS of the residual on ``columns`` (k parameters) with the nuisance columns of :func:`nuisance`.

    Each (channel, nuisance) pair is its own parameter; the likelihood ratio is the increment over the nuisance
    alone; theta and cov are those of the k parameters."""
    nuis = nuisance(ctx)
    if not nuis:
        return gls(ctx.wh, ctx.resid_f, columns, k, se_max)
    n = ctx.case.n
    m = sum(x.shape[1] for x in nuis.values())
    both, alone, at = {}, {}, 0
    for c in sorted(set(columns) | set(nuis)):
        z = np.zeros((n, m))
        if c in nuis:
            z[:, at:at + nuis[c].shape[1]] = nuis[c]
            at += nuis[c].shape[1]
        alone[c] = z
        both[c] = np.hstack([columns.get(c, np.zeros((n, k))), z])
    full = gls(ctx.wh, ctx.resid_f, both, k + m)
    if not full.identifiable:
        full.why = ("its regressors are collinear with the nuisance (the turn-on bias of each joined file, or the "
                    "end-to-end drift of the model's random walk) in this scenario")
        full.theta, full.cov, full.dof, full.dropped = np.zeros(k), np.full((k, k), np.nan), k, []
        return full
    weak = np.flatnonzero(np.sqrt(np.clip(np.diag(full.cov)[:k], 0, None)) > (se_max or np.inf))
    if len(weak):  # determined only through the nuisance (e.g. a step at the join of two files)
        return GlsResult(np.zeros(k), np.full((k, k), np.nan), 0.0, k, False,
                         "its regressors are collinear with the nuisance (the turn-on bias of each joined file, or "
                         "the end-to-end drift of the model's random walk) in this scenario", [int(j) for j in weak])
    base = gls(ctx.wh, ctx.resid_f, alone, m)
    full.theta, full.cov = full.theta[:k], full.cov[:k, :k]
    full.lr, full.dof = full.lr - base.lr, k
    return full


def _names_values(names, theta, ci):
    return ({n: float(v) for n, v in zip(names, theta)}, {n: [float(a), float(b)] for n, (a, b) in zip(names, ci)})


def _channels_of(columns: dict, theta: np.ndarray, cov: np.ndarray) -> list:
    out = []
    for ch, x in columns.items():
        used = np.flatnonzero(np.any(x != 0, axis=0))
        z2 = theta[used] @ np.linalg.solve(cov[np.ix_(used, used)], theta[used]) if len(used) else 0.0
        if z2 > stats.chi2.isf(0.01, max(len(used), 1)):
            out.append(CHANNELS[ch])
    return out


def regression(ctx: Context, design, statistic: str = "GLS likelihood ratio", se_max: float | None = None) -> Candidate:
    """GLS test and fit of one regressor design (columns per channel sharing one parameter vector)."""
    case = ctx.case
    dropped = []
    for _ in range(3):
        res = gls(ctx.wh, ctx.resid_f, design.columns, design.k, se_max)
        if res.identifiable:
            res = fit(ctx, design.columns, design.k, se_max)
        if res.identifiable or not res.dropped or len(res.dropped) == design.k:
            break
        # e.g. the accelerometers' scale factor on a level rate table (constant specific force): test the rest
        dropped += [design.names[j] for j in res.dropped]
        design = design.without(res.dropped)
    thr = threshold(design.k, ctx.m_tests, 1, ctx.factor(design.effect))
    cand = Candidate(design.effect, res.lr, thr, statistic, res.identifiable, res.why, columns=design.columns)
    if dropped:
        cand.reason = ("not identifiable by this scenario (regressor constant over the run" + (
            f", or determined no better than +-{se_max:g}" if se_max else "") + f"): {', '.join(dropped)}; "
            "tested on the others")
    if not res.identifiable:
        return cand

    def refit(names):
        return _without(ctx, cand, design, res.theta, [design.names.index(m) for m in names if m in design.names])
    cand.refit = refit if design.effect not in KINEMATIC else None
    cand.design = design
    ci = res.interval()
    cand.params, cand.intervals = _names_values(design.names, res.theta, ci)
    cand.physics = design.to_physics(res.theta)
    cand.channels = _channels_of(design.columns, res.theta, res.cov)
    cand.contrib = np.zeros((case.n, 6))
    for ch, x in design.columns.items():
        cand.contrib[:, ch] = x @ res.theta
    if design.effect in ("earth_rotation", "gravity_model", "coriolis"):
        cand.params, cand.intervals = regressors.physical_value(design.effect, res.theta, ci, case)
        cand.constant_scale = float(res.theta[0])
        cand.constant_se = float(np.sqrt(max(res.cov[0, 0], 0.0)))
    return cand


def _without(ctx: Context, cand: Candidate, design, theta: np.ndarray, drop: list) -> Candidate:
    """``cand`` less the parameters ``drop`` (indices), tested given them: the dropped ones stay in the joint fit
    as a nuisance (their signal is the reference's or the model's error, not left for the rest to absorb), the rest
    keep their joint estimates, and the statistic is the joint one minus the dropped parameters' alone."""
    keep = [j for j in range(design.k) if j not in set(drop)]
    alone = regression(ctx, design.without(keep))
    out = Candidate(design.effect, float(cand.stat - (alone.stat if alone.identifiable else 0.0)),
                    threshold(len(keep), ctx.m_tests, 1, ctx.factor(design.effect)),
                    cand.statistic + " given the dropped parameters", cand.identifiable, cand.reason)
    theta = np.array(theta, float)
    theta[drop] = 0.0
    names = [design.names[j] for j in keep]
    out.params = {m: cand.params[m] for m in names}
    out.intervals = {m: cand.intervals[m] for m in names if m in cand.intervals}
    out.physics = design.to_physics(theta)
    out.columns = {c: x[:, keep] for c, x in design.columns.items() if np.any(x[:, keep] != 0)}
    out.contrib = np.zeros((ctx.case.n, 6))
    for ch, x in design.columns.items():
        out.contrib[:, ch] = x @ theta
    out.channels = [c for c in cand.channels]
    out.design = design.without(drop)  # a fixture's joint fit with the tilts refits the kept ones from it
    return out


def warmup(ctx: Context) -> Candidate:
    """Warm-up exponential on every channel, its time constant profiled on a log grid."""
    case, model = ctx.case, ctx.model
    taus = regressors.warmup_taus(case.t[-1] - case.t[0], case.dt)
    fits = [(tau, fit(ctx, regressors.design_warmup(case, model, tau).columns, 6)) for tau in taus]
    lrs = np.array([f.lr for _, f in fits])
    best = int(np.argmax(lrs))
    design = regressors.design_warmup(case, model, taus[best])
    cand = regression(ctx, design, "GLS likelihood ratio, time constant profiled")
    cand.threshold = threshold(6, ctx.m_tests, len(taus), ctx.factor("warmup_drift"))
    cand.params["time_constant_s"] = float(taus[best])
    cand.intervals["time_constant_s"] = profile_interval(np.log(taus), lrs, best)
    if cand.identifiable:
        _carry_tau_uncertainty(ctx, design, cand, taus[best])
    cand.block_s = min(1.0, float(taus[best]) / 5)
    cand.refit = None  # one time constant for every channel, profiled with them all: an amplitude beyond its grade's
    # bound makes the whole curve the reference's or the model's error (blind seed 8's table null), not a rest
    return cand


def profile_interval(x: np.ndarray, lr: np.ndarray, best: int) -> list:
    """exp of the 95 % profile-likelihood interval in x (log grid): where lr drops 3.84, linearly interpolated."""
    drop = lr[best] - lr - 3.84
    ends = []
    for step in (-1, 1):
        i = best
        while 0 <= i + step < len(x) and drop[i + step] < 0:
            i += step
        j = i + step
        if 0 <= j < len(x):  # crossing between grid points i and j
            ends.append(x[i] + (x[j] - x[i]) * (-drop[i]) / (drop[j] - drop[i]))
        else:  # profile still inside at the grid's end: the interval reaches it
            ends.append(x[i])
    return [float(np.exp(min(ends))), float(np.exp(max(ends)))]


def _carry_tau_uncertainty(ctx: Context, design, cand, tau) -> None:
    """Amplitude intervals from the Jacobian covariance of amplitudes and time constant together."""
    amps = np.array([cand.params[n] for n in design.names])
    dt_rel = ctx.case.t - ctx.case.t[0]
    slope = dt_rel / tau**2 * np.exp(-dt_rel / tau)
    cols = {c: np.hstack([x, (amps[c] * slope)[:, None]]) for c, x in design.columns.items()}
    res = fit(ctx, cols, design.k + 1)
    if not res.identifiable:
        return
    sd = np.sqrt(np.clip(np.diag(res.cov)[:design.k], 0, None))
    cand.intervals.update({n: [float(a - 1.96 * s), float(a + 1.96 * s)] for n, a, s in zip(design.names, amps, sd)})


def vibration(ctx: Context) -> Candidate:
    """Largest whitened periodogram line; when significant, its frequency refined and amplitudes fitted."""
    case, model, wh, resid, resid_f = ctx.case, ctx.model, ctx.wh, ctx.resid, ctx.resid_f
    if (held := noise_candidates.line_residual(case, resid)) is not resid:  # a fixture: no hold-to-hold ramp
        resid, resid_f = held, np.fft.rfft(held, axis=0)
    f_min = max(10.0 / (case.n * case.dt), reference.F_MECH_HZ)
    harmonics = reference.harmonic_bins(case)
    if f_min >= 0.5 / case.dt:
        return not_testable("vibration", f"the sample rate leaves no band above {f_min:g} Hz to search")
    lr, ch, f0, n_bins = noise_tests.vibration_scan(wh, resid_f, f_min, harmonics)
    thr = 2.0 * np.log(ctx.m_tests * max(n_bins, 1) / ALPHA) * ctx.factor("vibration")
    cand = Candidate("vibration", lr, thr, "max whitened periodogram ordinate (chi-square 2 per bin)",
                     kind="vibration", block_s=case.dt,
                     reason=reference.note(case, int(np.sum(harmonics & (np.fft.rfftfreq(case.n, case.dt) >= f_min)))))
    if lr <= thr:
        cand.params = {"frequency_hz": f0}
        return cand
    # one frequency for every channel (one source): its profile-likelihood interval holds the information of all
    freq, f_lo, f_hi = noise_tests.fit_line_frequency(wh, resid, f0)
    f_sd = (f_hi - f_lo) / (2 * 1.959964)
    amps, sds, lrs, phase = noise_tests.vibration_fit(wh, resid, case.sim_t_abs, freq, ch, gls)
    cand.channels = [CHANNELS[c] for c in range(6) if lrs[c] > stats.chi2.isf(0.01, 2)]
    names = [f"gyro_amplitude_rad_per_s[{a}]" for a in "xyz"] + [f"accel_amplitude_mps2[{a}]" for a in "xyz"]
    cand.params = {"frequency_hz": freq, "phase_rad": phase, **{n: float(a) for n, a in zip(names, amps)}}
    cand.intervals = {"frequency_hz": [f_lo, f_hi],
                      **{n: [float(a - 1.96 * s), float(a + 1.96 * s)] for n, a, s in zip(names, amps, sds)}}
    old = list((model.physics or {}).get("vibration", {}).get("sinusoids", []))
    cand.physics = {**(model.physics or {}).get("vibration", {}),
                    "sinusoids": old + [{"frequency_hz": freq, "phase_rad": phase,
                                         "gyro_amplitude_rad_per_s": amps[:3].tolist(),
                                         "accel_amplitude_mps2": amps[3:].tolist()}]}
    s = noise_tests._mean_sin(case.sim_t_abs, case.dt, freq, phase)
    cand.contrib = s[:, None] * amps[None, :]
    cand.columns = {c: s[:, None] * (np.arange(6) == c)[None, :] for c in range(6)}
    df = 1.0 / (case.n * case.dt)
    cand.band = {"frequency_hz": [freq - max(2 * f_sd, df), freq + max(2 * f_sd, df)]}
    return cand


def quantization(ctx: Context) -> Candidate:
    """Rayleigh lattice statistic of the raw values per channel; the output step where significant."""
    case, model = ctx.case, ctx.model
    out = [noise_tests.lattice(case.measured[:, c]) for c in range(6)]
    z = np.array([o[2] for o in out])
    thr = 2.0 * np.log(6 * ctx.m_tests / ALPHA) * ctx.factor("quantization")
    # a lattice far below the per-sample noise (e.g. the file's print precision) is a property of the file
    sigma = np.sqrt([metrics.robust_var(case.measured[:, c]) for c in range(6)])
    fine = np.array([0 < o[0] < FILE_LATTICE * s and 2 * o[2] > thr for o, s in zip(out, sigma)])
    z_phys = np.where(fine, 0.0, z)
    cand = Candidate("quantization", float(2 * z_phys.max()), thr,
                     "Rayleigh lattice statistic 2z of raw values (chi-square 2 for continuous values)",
                     kind="quantization")
    digits = [noise_tests.print_digits(case.measured[:, c]) for c in range(6)]
    printed = [c for c in range(6) if digits[c] is not None and digits[c] <= 12  # beyond: float arithmetic, not print
               and noise_tests.print_step(case.measured[:, c], digits[c]) < FILE_LATTICE * sigma[c]]
    if printed or any(fine):
        steps = ", ".join(f"{noise_tests.print_step(case.measured[:, c], digits[c]):.3g}" for c in printed)
        cand.reason = (f"values printed with {min(digits[c] for c in printed)}-{max(digits[c] for c in printed)} "
                       f"significant digits (step at most {steps} on {', '.join(CHANNELS[c] for c in printed)})"
                       if printed else "values on a fine lattice (" + ", ".join(
                           f"{CHANNELS[c]} {out[c][0]:.3g}" for c in range(6) if fine[c]) + ")")
        cand.reason += (f", below {FILE_LATTICE:g} of the per-sample noise: a property of the file (its print "
                        "precision), not missing physics")
    if cand.stat <= thr:
        return cand
    out = [o if not f else (0.0, 0.0, 0.0, o[3]) for o, f in zip(out, fine)]
    z = z_phys
    mdl = effective_model(model)
    lsb = {"gyro": (mdl.gyro.quantization * np.sqrt(12)).copy(), "accel": (mdl.accel.quantization * np.sqrt(12)).copy()}
    for c, (q, se, zc, frac) in enumerate(out):
        tri, i = ("gyro", "accel")[c // 3], c % 3
        key = ("gyro_lsb_rad" if tri == "gyro" else "accel_lsb_mps") + f"[{'xyz'[i]}]"
        if 2 * zc > thr:
            lsb[tri][i] = q * case.dt
            half = max(1.96 * se, 1e-9 * q) * case.dt
            cand.params[key] = float(q * case.dt)
            cand.intervals[key] = [float(q * case.dt - half), float(q * case.dt + half)]
            step_key = key.replace("lsb", "output_step").replace("_rad[", "_rad_per_s[").replace("_mps[", "_mps2[")
            cand.params[step_key] = float(q)
            cand.channels.append(CHANNELS[c])
    cand.physics = {"gyro_lsb_rad": lsb["gyro"].tolist(), "accel_lsb_mps": lsb["accel"].tolist()}
    return cand


def kinematic(ctx: Context, effect: str) -> Candidate:
    """Earth rotation, normal gravity or Coriolis: one scale on the exact difference the effect makes."""
    if effect in (ctx.model.physics or {}):
        return not_testable(effect, "already in the model's physics")
    return regression(ctx, regressors.design_kinematic(ctx.case, ctx.model, effect), se_max=SE_MAX)


def temperature(ctx: Context) -> Candidate:
    """Bias linear in the logged (or scenario) temperature."""
    design = regressors.design_temperature(ctx.case, ctx.model)
    if design is None:
        return not_testable("temperature_bias", "no temperature in the recording or the scenario")
    cand = regression(ctx, design)
    # held out at the temperature's own time scale: a 30-min cycle's 3e-5 rad/s is 1/7 of the 1-s block scatter,
    # where the flicker of the held-out half moved the RMS more than the fitted wave (1.0321 -> 1.0327 at LR 87)
    cand.block_s = max(cand.block_s, (ctx.case.t[-1] - ctx.case.t[0]) / TEMPERATURE_BLOCKS)
    return cand


TEMPERATURE_BLOCKS = 100
"""The temperature fit's held-out block means are a hundredth of the run long (72 s of a 2-h run)."""


TESTS = {
    "earth_rotation": lambda ctx: kinematic(ctx, "earth_rotation"),
    "gravity_model": lambda ctx: kinematic(ctx, "gravity_model"),
    "coriolis": lambda ctx: kinematic(ctx, "coriolis"),
    "gyro_g_sensitivity": lambda ctx: regression(ctx, regressors.design_g_sensitivity(ctx.case, ctx.model),
                                                 se_max=SE_MAX),
    "temperature_bias": temperature,
    "warmup_drift": warmup,
    "scale_factor": lambda ctx: regression(ctx, regressors.design_scale_factor(ctx.case, ctx.model), se_max=SE_MAX),
    "axis_misalignment": lambda ctx: regression(ctx, regressors.design_misalignment(ctx.case, ctx.model),
                                                se_max=SE_MAX),
    "vibration": vibration,
    "quantization": quantization,
    "gauss_markov_bias": lambda ctx: noise_candidates.noise(ctx, "gauss_markov_bias"),
    "bias_random_walk": lambda ctx: noise_candidates.noise(ctx, "bias_random_walk"),
    "coning_sculling": lambda ctx: not_testable("coning_sculling", CONING_NOTE),
}
"""Effect name -> its test (the IMU side of the vocabulary)."""
