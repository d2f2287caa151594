"""The diagnosis loop: residual -> test every effect -> fit the strongest -> re-simulate -> repeat.

Each effect of the vocabulary is tested by its own statistic (likelihood ratio, chi-square under
the null); its threshold is the chi-square quantile at a family-wise level ALPHA shared
(Bonferroni) across the effects tested and the grid points profiled, times a factor
calibrated by Monte Carlo on null simulations (``calibration.yaml``, written by
``benchmarks/bench_diagnosis.py --calibrate``, see :mod:`calibrate`). Among significant effects the one with the largest
excess (statistic - threshold, an information-criterion-like penalty per parameter;
for the slow-wander effects, their statistic given the strongest rival, see
:func:`_rank_low_frequency`) is fitted, added to the model, and the model re-simulated; a finding is kept only if
the held-out statistic improves.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import yaml
from scipy import stats

from nav_core.sensor_model import EFFECTS, SensorModel

from imu_sim.diagnose import local_level, metrics, noise_tests, regressors
from imu_sim.diagnose.case import CHANNELS, Case, deterministic, effective_model, residual
from imu_sim.diagnose.spectral import Whitener, gls

ALPHA = 0.05
CALIBRATION_FILE = Path(__file__).with_name("calibration.yaml")
GNSS_EFFECTS = ("gps_lever_arm", "gps_latency", "colored_gps_noise")
EXPLAIN = {
    "earth_rotation": "The gyro residual follows the Earth rate rotated into the body frame; the model leaves out "
                      "Earth rotation (15 deg/h times the attitude-dependent projection).",
    "gravity_model": "The accelerometer residual is proportional to the specific force with the size of normal "
                     "gravity at this latitude and height minus 9.80665 m/s^2: the model uses constant gravity.",
    "coriolis": "The residual follows the Coriolis and transport-rate terms of the truth velocity.",
    "gyro_g_sensitivity": "Gyro bias proportional to the specific force on the same axis (g-sensitivity), visible "
                          "because the orientation changes the specific force on each axis.",
    "temperature_bias": "Biases track the logged temperature linearly; the model has no thermal coefficient.",
    "warmup_drift": "Biases decay exponentially after switch-on (warm-up); a constant turn-on bias misses it.",
    "scale_factor": "The residual is proportional to the true rate / specific force on the same axis: a "
                    "scale-factor error the model does not have.",
    "axis_misalignment": "The residual on one axis follows the true rate / specific force on the other axes: "
                         "non-orthogonal or misaligned sensing axes.",
    "vibration": "A spectral line the model does not produce: a sinusoidal vibration (or its alias) in the "
                 "sensor output.",
    "quantization": "The raw values lie on a lattice (a fixed output step); a continuous simulator misses the "
                    "quantization even where the step is smaller than the noise.",
    "gauss_markov_bias": "Excess low-frequency power with a corner: a correlated (Gauss-Markov) bias wander "
                         "beyond the model's noise.",
    "bias_random_walk": "Excess power rising as 1/f^2 at low frequency: a bias random walk beyond the model's "
                        "noise.",
    "gps_latency": "The fix residual follows minus the truth velocity: the fixes are stamped later than the "
                   "position they report (receiver latency).",
    "gps_lever_arm": "The fix residual follows the attitude-rotated body offset: the antenna is not at the IMU "
                     "(lever arm) and the model leaves it out.",
    "colored_gps_noise": "The fix residual has excess low-frequency power with a corner (Gauss-Markov): the "
                         "model's GNSS noise is white but the receiver's error is correlated in time.",
}


CONING_NOTE = ("not identifiable by any scenario of this simulator: the wobble's rectified rate (a^2 W / 2 on "
               "gyro z) and specific force (-a A on accel z) are constant over the run (the effect has no time "
               "window), so they are collinear with the turn-on bias; the wobble itself is a line on gyro x/y, "
               "tested as vibration")


def load_calibration() -> dict:
    """Per-effect threshold factors from the null Monte Carlo (1.0 when not calibrated; never below the floor)."""
    from imu_sim.diagnose.calibrate import FLOOR  # calibrate imports this module
    if CALIBRATION_FILE.exists():
        data = yaml.safe_load(CALIBRATION_FILE.read_text()) or {}
        return {k: max(float(v), FLOOR) for k, v in (data.get("factors") or {}).items()}
    return {}


@dataclass
class Candidate:
    """One effect's test: statistic against threshold, fit, and how to add it to the model."""

    effect: str
    stat: float
    threshold: float
    statistic: str
    identifiable: bool = True
    reason: str = ""
    channels: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    intervals: dict = field(default_factory=dict)
    physics: dict | None = None
    columns: dict | None = None
    contrib: np.ndarray | None = None
    kind: str = "regression"
    block_s: float = 1.0
    band: dict | None = None
    rank: float | None = None
    """Ranking key when it is not statistic - threshold (e.g. a conditional LR of correlated effects)."""
    caveat: str = ""
    """Added to the finding's explanation (e.g. a rival this record cannot tell it from)."""

    @property
    def significant(self) -> bool:
        """Identifiable and above threshold."""
        return self.identifiable and self.stat > self.threshold

    def tested_entry(self) -> dict:
        """What ``tested`` in diagnosis.json lists."""
        return {"effect": self.effect, "statistic": self.statistic, "value": _r(self.stat),
                "threshold": _r(self.threshold), "significant": bool(self.significant),
                "identifiable": bool(self.identifiable), "note": self.reason}


def _r(x):
    return None if x is None or not np.isfinite(x) else float(f"{x:.6g}")


def _thr(dof: int, m_tests: int, grid: int = 1, factor: float = 1.0) -> float:
    return float(stats.chi2.isf(ALPHA / (m_tests * grid), dof) * factor)


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


def _regression(case, model, wh, resid_f, design, m_tests, factors, statistic="GLS likelihood ratio") -> Candidate:
    res = gls(wh, resid_f, design.columns, design.k)
    thr = _thr(design.k, m_tests, 1, factors.get(design.effect, 1.0))
    cand = Candidate(design.effect, res.lr, thr, statistic, res.identifiable, res.why, columns=design.columns)
    if not res.identifiable:
        return cand
    ci = res.interval()
    cand.params, cand.intervals = _names_values(design.names, res.theta, ci)
    cand.physics = design.to_physics(res.theta)
    cand.channels = _channels_of(design.columns, res.theta, res.cov)
    cand.contrib = np.zeros((case.n, 6))
    for ch, x in design.columns.items():
        cand.contrib[:, ch] = x @ res.theta
    if design.effect in ("earth_rotation", "gravity_model", "coriolis"):
        cand.params, cand.intervals = regressors.physical_value(design.effect, res.theta, ci, case)
    return cand


def _warmup(case, model, wh, resid_f, m_tests, factors) -> Candidate:
    taus = regressors.warmup_taus(case.t[-1] - case.t[0], case.dt)
    fits = [(tau, gls(wh, resid_f, regressors.design_warmup(case, model, tau).columns, 6)) for tau in taus]
    lrs = np.array([f.lr for _, f in fits])
    best = int(np.argmax(lrs))
    design = regressors.design_warmup(case, model, taus[best])
    cand = _regression(case, model, wh, resid_f, design, m_tests, factors,
                       "GLS likelihood ratio, time constant profiled")
    cand.threshold = _thr(6, m_tests, len(taus), factors.get("warmup_drift", 1.0))
    cand.params["time_constant_s"] = float(taus[best])
    cand.intervals["time_constant_s"] = _profile_interval(np.log(taus), lrs, best)
    if cand.identifiable:
        _carry_tau_uncertainty(case, wh, resid_f, design, cand, taus[best])
    cand.block_s = min(1.0, float(taus[best]) / 5)
    return cand


def _profile_interval(x: np.ndarray, lr: np.ndarray, best: int) -> list:
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


def _carry_tau_uncertainty(case, wh, resid_f, design, cand, tau) -> None:
    """Amplitude intervals from the Jacobian covariance of amplitudes and time constant together."""
    amps = np.array([cand.params[n] for n in design.names])
    dt_rel = case.t - case.t[0]
    slope = dt_rel / tau**2 * np.exp(-dt_rel / tau)
    cols = {c: np.hstack([x, (amps[c] * slope)[:, None]]) for c, x in design.columns.items()}
    res = gls(wh, resid_f, cols, design.k + 1)
    if not res.identifiable:
        return
    sd = np.sqrt(np.clip(np.diag(res.cov)[:design.k], 0, None))
    cand.intervals.update({n: [float(a - 1.96 * s), float(a + 1.96 * s)] for n, a, s in zip(design.names, amps, sd)})


def _vibration(case, model, wh, resid, resid_f, m_tests, factors) -> Candidate:
    f_min = 10.0 / (case.n * case.dt)
    lr, ch, f0, n_bins = noise_tests.vibration_scan(wh, resid_f, f_min)
    thr = 2.0 * np.log(m_tests * n_bins / ALPHA) * factors.get("vibration", 1.0)
    cand = Candidate("vibration", lr, thr, "max whitened periodogram ordinate (chi-square 2 per bin)",
                     kind="vibration", block_s=case.dt)
    if lr <= thr:
        cand.params = {"frequency_hz": f0}
        return cand
    freq = noise_tests.refine_frequency(resid[:, ch] - resid[:, ch].mean(), case.dt, f0)
    amps, sds, lrs, phase, f_sd = noise_tests.vibration_fit(wh, resid, case.sim_t_abs, freq, ch, gls)
    cand.channels = [CHANNELS[c] for c in range(6) if lrs[c] > stats.chi2.isf(0.01, 2)]
    names = [f"gyro_amplitude_rad_per_s[{a}]" for a in "xyz"] + [f"accel_amplitude_mps2[{a}]" for a in "xyz"]
    cand.params = {"frequency_hz": freq, "phase_rad": phase, **{n: float(a) for n, a in zip(names, amps)}}
    cand.intervals = {"frequency_hz": [freq - 1.96 * f_sd, freq + 1.96 * f_sd],
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


def _quantization(case, model, m_tests, factors) -> Candidate:
    out = [noise_tests.lattice(case.measured[:, c]) for c in range(6)]
    z = np.array([o[2] for o in out])
    thr = 2.0 * np.log(6 * m_tests / ALPHA) * factors.get("quantization", 1.0)
    cand = Candidate("quantization", float(2 * z.max()), thr,
                     "Rayleigh lattice statistic 2z of raw values (chi-square 2 for continuous values)",
                     kind="quantization")
    if cand.stat <= thr:
        return cand
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
            cand.params[key.replace("lsb", "output_step").replace("_rad[", "_rad_per_s[").replace("_mps[", "_mps2[")] = float(q)
            cand.channels.append(CHANNELS[c])
    cand.physics = {"gyro_lsb_rad": lsb["gyro"].tolist(), "accel_lsb_mps": lsb["accel"].tolist()}
    return cand


def _random_walk(case, model, resid, m_tests, factors):
    """Bias random walk by the exact block-mean likelihood (None when the model's noise has flicker)."""
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    yb = noise_tests.block_means(resid, m)
    bgs = noise_tests.walk_backgrounds(model, tb, yb)
    if bgs is None:
        return None
    fits = [local_level.fit(yb[:, c], tb, bgs[c]) for c in range(6)]
    lr_ch = np.array([f.lr for f in fits])
    cand = Candidate("bias_random_walk", float(lr_ch.sum()), _thr(6, m_tests, 1, factors.get("bias_random_walk", 1.0)),
                     f"likelihood ratio of the {tb:.3g}-s block means (Kalman filter: model noise + a walk, "
                     "its level free)", kind="noise")
    cand.channels = [CHANNELS[c] for c in range(6) if lr_ch[c] > stats.chi2.isf(0.01, 2)]
    mdl = effective_model(model)
    phys = {}
    for c, f in enumerate(fits):
        tri, i, ax = ("gyro", "accel")[c // 3], c % 3, "xyz"[c % 3]
        unit = "rad_per_s_per_sqrt_s" if tri == "gyro" else "mps2_per_sqrt_s"
        cand.params[f"{tri}_{unit}[{ax}]"] = f.k
        cand.intervals[f"{tri}_{unit}[{ax}]"] = list(f.k_interval)
        kept = f.k if CHANNELS[c] in cand.channels else float(mdl.triad(tri).rate_random_walk[i])
        phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = kept
    cand.physics = phys
    return cand


def _gauss_markov_kf(case, model, resid, m, taus):
    """Per channel (lr, sigma^2, its interval, tau, tau interval) from the exact block-mean likelihood, or None.

    None when the model's own noise has flicker or a Gauss-Markov bias (the filter holds one such state).
    """
    tb = m * case.dt
    yb = noise_tests.block_means(resid, m)
    bgs = noise_tests.walk_backgrounds(model, tb, yb)
    if bgs is None or any(bg.gm_var > 0 for bg in bgs):
        return None
    out = []
    for c in range(6):
        f = local_level.fit_gauss_markov(yb[:, c], tb, taus, bgs[c])
        out.append((f.lr, f.sigma**2, (f.sigma_interval[0] ** 2, f.sigma_interval[1] ** 2), f.tau, f.tau_interval))
    return out


def _whittle_fits(model, resid, m, tb, effect, taus):
    """Per channel (lr, level, its interval, tau or None, tau interval) from the Whittle test on detrended block means."""
    # detrended, so a random walk's end-to-end drift is not evidence for a Gauss-Markov bias
    xb = noise_tests.detrended(noise_tests.block_means(resid, m))
    freqs, pgram = noise_tests.periodogram(xb, tb)
    s0 = noise_tests.noise_model_psd(model, freqs, tb)
    if effect == "bias_random_walk":
        grids = [(None, noise_tests.rw_extra(freqs))]
    else:
        grids = [(tc, noise_tests.gm_extra(freqs, tc)) for tc in taus]
    best = []
    for c in range(6):
        fits = [(*noise_tests.whittle_extra(pgram[:, c], s0[c], extra)[:3], tc) for tc, extra in grids]
        top = max(fits, key=lambda f: f[0])
        # level interval joined over the correlation times of the profile's 95 % set (tc's uncertainty carried)
        inside = [f for f in fits if f[0] >= top[0] - 3.84]
        ci = (min(f[2][0] for f in inside), max(f[2][1] for f in inside))
        tcs = [f[3] for f in inside if f[3] is not None]
        best.append((top[0], top[1], ci, top[3], (min(tcs), max(tcs)) if tcs else None))
    return best


def _noise(case, model, resid, effect, m_tests, factors) -> Candidate:
    if effect == "bias_random_walk":
        cand = _random_walk(case, model, resid, m_tests, factors)
        if cand is not None:
            return cand
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    # the correlation time must lie well inside the record, else the wander is a random walk here
    taus = np.logspace(np.log10(5 * tb), np.log10((case.n // m) * tb / 20), 8)
    best = _gauss_markov_kf(case, model, resid, m, taus) if effect == "gauss_markov_bias" else None
    n_grid = 1 if effect == "bias_random_walk" else len(taus)
    if best is not None:
        statistic = (f"likelihood ratio of the {tb:.3g}-s block means (Kalman filter: model noise + a Gauss-Markov "
                     "bias, its level free), correlation time profiled")
    else:
        best = _whittle_fits(model, resid, m, tb, effect, taus)
        statistic = "Whittle likelihood ratio of the block-averaged residual" + (
            ", correlation time profiled" if n_grid > 1 else "")
    lr_ch = np.array([b[0] for b in best])
    dof = 6 if effect == "bias_random_walk" else 12
    thr = _thr(dof, m_tests, n_grid, factors.get(effect, 1.0))
    cand = Candidate(effect, float(lr_ch.sum()), thr, statistic, kind="noise")
    cand.channels = [CHANNELS[c] for c in range(6) if lr_ch[c] > stats.chi2.isf(0.01, dof // 6 + 1)]
    mdl = effective_model(model)
    phys = {}
    for c in range(6):
        tri, i, ax = ("gyro", "accel")[c // 3], c % 3, "xyz"[c % 3]
        lr, lev, ci, tc, tc_ci = best[c]
        if effect == "bias_random_walk":
            unit = "rad_per_s_per_sqrt_s" if tri == "gyro" else "mps2_per_sqrt_s"
            key = f"{tri}_{unit}[{ax}]"
            k_old2 = mdl.triad(tri).rate_random_walk[i] ** 2
            cand.params[key] = float(np.sqrt(k_old2 + lev))
            cand.intervals[key] = [float(np.sqrt(k_old2 + ci[0])), float(np.sqrt(k_old2 + ci[1]))]
            phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = cand.params[key]
        else:
            unit = "sigma_rad_per_s" if tri == "gyro" else "sigma_mps2"
            key = f"{tri}_{unit}[{ax}]"
            sig_ch = CHANNELS[c] in cand.channels
            sigma = float(np.sqrt(lev)) if sig_ch else float(mdl.triad(tri).bias_instability[i])
            tcv = float(tc) if sig_ch else float(mdl.triad(tri).bias_correlation_time[i])
            cand.params[key] = sigma
            cand.intervals[key] = [float(np.sqrt(ci[0])), float(np.sqrt(ci[1]))]
            cand.params[f"{tri}_correlation_time_s[{ax}]"] = tcv
            if sig_ch:
                cand.intervals[f"{tri}_correlation_time_s[{ax}]"] = [float(tc_ci[0]), float(tc_ci[1])]
            phys.setdefault(f"{tri}_{unit}", [0.0] * 3)[i] = sigma
            phys.setdefault(f"{tri}_correlation_time_s", [0.0] * 3)[i] = tcv
    cand.physics = phys
    return cand


def _not_testable(effect, why) -> Candidate:
    return Candidate(effect, np.nan, np.nan, "-", identifiable=False, reason=why)


def evaluate(case: Case, model: SensorModel, resid: np.ndarray, exclude=(), factors: dict | None = None) -> list:
    """Test every effect of the vocabulary not in ``exclude``; list of :class:`Candidate`.

    ``factors`` scale the analytic thresholds per effect (None: the committed calibration; {}: analytic).
    """
    factors = load_calibration() if factors is None else factors
    wh = Whitener.from_model(model, resid, case.dt)
    resid_f = np.fft.rfft(resid, axis=0)
    m_tests = len(EFFECTS)
    out = []
    phys = model.physics or {}
    from imu_sim.diagnose import gnss_candidates  # imports this module: keep the import here
    gnss = {c.effect: c for c in gnss_candidates.candidates(case, model, m_tests, factors, exclude)}
    for effect in EFFECTS:
        if effect in exclude:
            continue
        if effect in GNSS_EFFECTS:
            out.append(gnss[effect])
        elif effect in phys and effect in ("earth_rotation", "gravity_model", "coriolis"):
            out.append(_not_testable(effect, "already in the model's physics"))
        elif effect in ("earth_rotation", "gravity_model", "coriolis"):
            out.append(_regression(case, model, wh, resid_f, regressors.design_kinematic(case, model, effect),
                                   m_tests, factors))
        elif effect == "gyro_g_sensitivity":
            out.append(_regression(case, model, wh, resid_f, regressors.design_g_sensitivity(case, model),
                                   m_tests, factors))
        elif effect == "temperature_bias":
            design = regressors.design_temperature(case, model)
            out.append(_not_testable(effect, "no temperature in the recording or the scenario") if design is None
                       else _regression(case, model, wh, resid_f, design, m_tests, factors))
        elif effect == "warmup_drift":
            out.append(_warmup(case, model, wh, resid_f, m_tests, factors))
        elif effect == "scale_factor":
            out.append(_regression(case, model, wh, resid_f, regressors.design_scale_factor(case, model),
                                   m_tests, factors))
        elif effect == "axis_misalignment":
            out.append(_regression(case, model, wh, resid_f, regressors.design_misalignment(case, model),
                                   m_tests, factors))
        elif effect == "vibration":
            out.append(_vibration(case, model, wh, resid, resid_f, m_tests, factors))
        elif effect == "quantization":
            out.append(_quantization(case, model, m_tests, factors))
        elif effect in ("gauss_markov_bias", "bias_random_walk"):
            out.append(_noise(case, model, resid, effect, m_tests, factors))
        elif effect == "coning_sculling":
            out.append(_not_testable(effect, CONING_NOTE))
    for cand in out:
        if cand.effect == "coriolis" and cand.identifiable is False and "constant" in cand.reason:
            cand.reason = "the truth has no velocity here (static): Coriolis cannot show"
    _rank_low_frequency(case, model, resid, wh, resid_f, out, m_tests, factors)
    return out


LOW_FREQUENCY = ("temperature_bias", "warmup_drift", "gauss_markov_bias", "bias_random_walk")
"""Effects that all show as slow residual wander, so each is ranked by its statistic given its rivals."""


def _low_design(case, model, cand):
    if cand.effect == "temperature_bias":
        return regressors.design_temperature(case, model)
    return regressors.design_warmup(case, model, cand.params["time_constant_s"])


def _conditional_lr(case, model, resid, wh, resid_f, cand, rival, m_tests, factors) -> float:
    """Statistic of ``cand`` with ``rival`` already in the model (its fit removed or its noise in the PSD)."""
    if cand.kind == "noise":
        if rival.kind == "noise":
            return _noise(case, add_effect(model, rival), resid, cand.effect, m_tests, factors).stat
        return _noise(case, model, resid - rival.contrib, cand.effect, m_tests, factors).stat
    design = _low_design(case, model, cand)
    if rival.kind == "noise":
        # a random walk's record carries one random end-to-end drift per channel (the common part of its
        # periodogram, the DFT of a ramp), so under the rival's noise a free ramp per channel is a nuisance
        wh2 = Whitener.from_model(add_effect(model, rival), resid, case.dt)
        ramp = (case.t - case.t[0])[:, None] * np.eye(6)[None, 0]
        with_ramp = {c: np.hstack([design.columns.get(c, np.zeros((case.n, design.k))), np.roll(ramp, c, axis=1)])
                     for c in range(6)}
        ramp_only = {c: np.roll(ramp, c, axis=1) for c in range(6)}
        return gls(wh2, resid_f, with_ramp, design.k + 6).lr - gls(wh2, resid_f, ramp_only, 6).lr
    other = _low_design(case, model, rival)
    joint = {c: np.hstack([design.columns.get(c, np.zeros((case.n, design.k))),
                           other.columns.get(c, np.zeros((case.n, other.k)))])
             for c in set(design.columns) | set(other.columns)}
    return gls(wh, resid_f, joint, design.k + other.k).lr - gls(wh, resid_f, other.columns, other.k).lr


def _rank_low_frequency(case, model, resid, wh, resid_f, cands, m_tests, factors) -> None:
    """Rank significant slow-wander candidates by their weakest statistic given one rival, minus threshold.

    A random walk, a Gauss-Markov wander, a temperature-linear bias and a warm-up exponential all
    put power at the lowest frequencies, so their unconditional statistics all rise together;
    the one that still stands once each rival is in the model is the one the data single out.
    """
    sig = [c for c in cands if c.effect in LOW_FREQUENCY and c.significant]
    given = {}
    for cand in sig:
        for rival in sig:
            if rival is not cand:
                given[cand.effect, rival.effect] = _conditional_lr(case, model, resid, wh, resid_f, cand, rival,
                                                                   m_tests, factors)
    for cand in sig:
        mine = {r: v for (c, r), v in given.items() if c == cand.effect}
        if not mine:
            continue
        worst = min(mine, key=mine.get)
        cand.rank = mine[worst] - cand.threshold
        cand.reason = (cand.reason + "; " if cand.reason else "") + (
            f"given {worst}: statistic {mine[worst]:.4g} (ranked by it)")
        thr = {c.effect: c.threshold for c in sig}
        twins = [r for r, v in mine.items() if v <= cand.threshold and given[r, cand.effect] <= thr[r]]
        if twins:
            cand.caveat = (f"This record cannot tell it from {' or '.join(twins)}: each is below its threshold once "
                           "the other is in the model; it is named because it ranks higher, not because the data "
                           "exclude the other.")


def add_effect(model: SensorModel, cand: Candidate) -> SensorModel:
    """The model with the candidate's physics entry added."""
    return model.with_physics(cand.effect, **(cand.physics or {}))


def evidence(cand: Candidate) -> float:
    """Ranking key: statistic minus threshold (or the candidate's own ``rank``)."""
    return cand.rank if cand.rank is not None else cand.stat - cand.threshold


def fit_metric(case: Case, cand: Candidate, model_before: SensorModel, model_after: SensorModel,
               resid: np.ndarray, seed: int = 0):
    """(metric name, before, after) on held-out data."""
    if cand.kind == "gnss":
        from imu_sim.diagnose import gnss_candidates
        return gnss_candidates.fit_metric(case, cand, model_before, model_after)
    if cand.kind in ("regression", "vibration"):
        cols = {c: x for c, x in cand.columns.items() if CHANNELS[c] in cand.channels} or cand.columns
        b, a = metrics.heldout_rms(resid, cols, case.dt, cand.block_s)
        what = "1-s block means" if cand.kind == "regression" else "samples"
        return f"RMS of held-out {what} over their scatter (odd tenths of the run, fit on even tenths)", b, a
    if cand.kind == "quantization":
        half = case.n // 2
        real = case.measured[half:]
        vals = []
        for mdl in (model_before, model_after):
            sim = deterministic(case, mdl, stochastic=True, seed=seed + 1)[half:]
            ratio = [np.log10(len(np.unique(real[:, c])) / len(np.unique(sim[:, c])))
                     for c in range(6) if CHANNELS[c] in cand.channels]
            vals.append(float(np.sqrt(np.mean(np.square(ratio)))))
        return "RMS log10 ratio of distinct-value counts, real vs simulated (second half held out)", vals[0], vals[1]
    held = _filter_metric(case, cand, model_before, resid)
    if held is not None:
        return held
    return _whittle_metric(case, cand, model_before, resid)


def _filter_metric(case, cand, model_before, resid):
    """One-step prediction deviance of the second half's block means, the noise term and level fitted on the first half.

    None when the model's noise is one the filter cannot hold (then the Whittle deviance is used).
    """
    m = noise_tests.block_interval(case.n)
    tb = m * case.dt
    yb = noise_tests.block_means(resid, m)
    half = len(yb) // 2
    bgs = noise_tests.walk_backgrounds(model_before, tb, yb[:half])
    if bgs is None or any(bg.gm_var > 0 for bg in bgs):
        return None
    taus = np.logspace(np.log10(5 * tb), np.log10(half * tb / 20), 8)
    out = np.zeros(2)
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    for c in chans:
        bg = bgs[c]
        _, h0 = local_level.loglik(yb[:half, c], [bg.rw_ratio])
        before = local_level.predictive_deviance(yb[:, c], bg.rw_ratio, h0[0], half, bg)
        if cand.effect == "bias_random_walk":
            fit = local_level.fit(yb[:half, c], tb, bg)
            after = local_level.predictive_deviance(yb[:, c], fit.ratio, fit.h, half, bg)
        else:
            fit = local_level.fit_gauss_markov(yb[:half, c], tb, taus, bg)
            after = local_level.predictive_deviance(yb[:, c], bg.rw_ratio, fit.h, half,
                                                    local_level.Background(fit.gm_var, fit.phi, bg.rw_ratio))
        out += [before, after]
    out /= len(chans)
    return ("one-step prediction deviance per block mean of the held-out second half (v^2/F + log 2 pi F over "
            "the noise level), noise term and level fitted on the first half"), float(out[0]), float(out[1])


def _whittle_metric(case, cand, model_before, resid):
    """Whittle deviance per bin of the second half's block means; the noise term and levels fitted on the first half."""
    half = case.n // 2
    # _noise needs only the length and the sample interval of what it tests
    refit = _noise(SimpleNamespace(n=half, dt=case.dt), model_before, resid[:half], cand.effect, 1, {})
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    m = noise_tests.block_interval(half)
    tb = m * case.dt
    out = []
    for mdl in (model_before, add_effect(model_before, refit)):
        dev = []
        for part in (resid[:half], resid[half:2 * half]):
            freqs, pgram = noise_tests.periodogram(noise_tests.detrended(noise_tests.block_means(part, m)), tb)
            dev.append((pgram, noise_tests.noise_model_psd(mdl, freqs, tb)))
        (p1, s1), (p2, s2) = dev
        tot = []
        for c in chans:
            ratio = p2[:, c] / (np.mean(p1[:, c] / s1[c]) * s1[c])
            tot.append(2 * (ratio - np.log(ratio) - 1))
        out.append(float(np.mean(np.concatenate(tot))))
    return ("Whittle deviance per periodogram bin of the held-out second half's block means, noise term and "
            "levels fitted on the first half (about 1.15 when the noise model is right)"), out[0], out[1]


@dataclass
class Diagnosis:
    """The result: JSON-ready dict plus arrays for the report."""

    result: dict
    model_updated: SensorModel
    case: Case
    resid_before: np.ndarray
    resid_after: np.ndarray
    findings_detail: list


def diagnose(case: Case, max_effects: int = 4, seed: int = 0, progress=None, factors: dict | None = None) -> Diagnosis:
    """Locate, attribute, model and iterate (see module docstring); ``factors`` as in :func:`evaluate`."""
    factors = load_calibration() if factors is None else factors
    model = case.model.copy()
    resid0 = residual(case, model)
    resid = resid0
    findings, details, tested, accepted = [], [], None, set()
    for _ in range(max_effects + 2):
        if len(findings) >= max_effects:
            break
        cands = evaluate(case, model, resid, exclude=accepted, factors=factors)
        if tested is None:
            tested = cands
        if progress is not None:
            progress.update()
        sig = sorted([c for c in cands if c.significant], key=evidence, reverse=True)
        if not sig or len(findings) >= max_effects:
            break
        best = sig[0]
        accepted.add(best.effect)
        new_model = add_effect(model, best)
        name, before, after = fit_metric(case, best, model, new_model, resid, seed)
        new_resid = residual(case, new_model)
        if not after < before:
            best.reason = f"significant but no held-out improvement ({before:.4g} -> {after:.4g}); not kept"
            continue
        if best.kind == "gnss":
            from imu_sim.diagnose import gnss_candidates
            span, band = gnss_candidates.location(case, best, model)
            best.channels = best.channels or list(gnss_candidates.gt.CHANNELS)
        else:
            band = best.band or _band(case, resid, new_resid, best)
            contrib = best.contrib if best.contrib is not None else resid - new_resid
            span = (metrics.time_span(resid, contrib, case.t) if best.kind != "quantization"
                    else [0.0, float(case.t[-1])])
        findings.append({
            "effect": best.effect, "channels": best.channels or list(CHANNELS),
            "time_span_s": span,
            "band": band, "parameters": best.params, "intervals": best.intervals,
            "metric": name, "fit_before": before, "fit_after": after,
            "statistic": {"name": best.statistic, "value": _r(best.stat), "threshold": _r(best.threshold)},
            "explanation": " ".join(filter(None, [EXPLAIN.get(best.effect, best.effect), best.caveat]))})
        details.append((best, resid, new_resid))
        model, resid = new_model, new_resid
    tested_out = [c.tested_entry() for c in tested]
    for entry in tested_out:
        if entry["effect"] in accepted and entry["effect"] not in [f["effect"] for f in findings]:
            entry["note"] = (entry["note"] + "; " if entry["note"] else "") + "not kept (no held-out improvement)"
    result = {"mismatch": bool(findings), "findings": findings, "tested": tested_out,
              "channels": list(CHANNELS), "samples": case.n, "rate_hz": 1.0 / case.dt, "notes": case.notes,
              "alpha_familywise": ALPHA,
              "calibration": factors or "uncalibrated (chi-square, Bonferroni)",
              "n_significant_first_pass": int(sum(c.significant for c in tested))}
    return Diagnosis(result, model, case, resid0, resid, details)


def _band(case, resid, new_resid, cand) -> dict:
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    band, _, _ = metrics.allan_band(resid[:, chans], new_resid[:, chans], 1.0 / case.dt)
    return band
