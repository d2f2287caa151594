"""The reference trajectory's own error: a nuisance tied to the motion, separated before sensor physics is blamed.

A truth a user brings (a reference INS, a smoothed GNSS track, a CSV from another simulator) carries its own slow
error, and the simulator turns it into rates and specific forces through a smoothing spline, whose error follows
the motion: (1) on a moving truth file, the residual of every channel carries the reference's error (a smoothed
track's 5-30 cm at periods of 30-600 s, its attitude error, and the spline's specific-force error of ~5e-3 m/s^2
at the end of speed changes, 3-30x the Coriolis acceleration). It is estimated as an extra PSD beside the sensor
noise (:func:`with_reference_error`: the smoothed residual periodogram's excess over the model's noise) and the
regressions are weighted by both, so a regressor with a known shape (2 Omega x v, the Earth rate, the gravity model)
is fitted jointly with it and still found where its power stands above the reference's; the slow noise terms,
which have no shape of their own against it, are not separable from the reference on such a record;
(2) spectral lines at harmonics of the trajectory (where the truth's own rate/specific force has a line) are the
reference's error, not vibration; lines below :data:`F_MECH_HZ` are slow periodic wander, not a mechanical source.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from imu_sim.diagnose.case import trajectory
from imu_sim.diagnose.unstated import mask_spans

F_MECH_HZ = 1.0
"""Lowest frequency (Hz) searched for a vibration line: below it no mechanical source of a sensor mount."""
FILE_SOURCES = ("trajectory", "gnss_track")
MOVING_MPS = 0.05
"""A truth whose speed exceeds this (m/s) somewhere translates: its spline's position error reaches the
accelerometers."""
HARMONIC_RATIO = 100.0
"""A bin where the truth's rate/specific force has 100x its local median power is a harmonic of the motion."""


NOT_SEPARABLE = ("not separable from the reference on this record: a moving truth file's own slow error (a smoothed "
                 "track's position and attitude error, the simulator's spline error and its start-up transient) puts "
                 "power at the same low frequencies with no shape to tell it from a slow drift or noise term; not "
                 "ranked")


CORIOLIS_WEAK = ("not separable from the reference on this record: the truth moves, but weighted by its own slow "
                 "error (a smoothed track's position and attitude error at the frequencies where 2 Omega x v has its "
                 "power: a slow vehicle, long straight legs) the Coriolis regressor determines its scale no better "
                 "than +-1; not ranked")


TRACK_ERROR_M = 0.3
"""Slow horizontal position error (m) of a truth smoothed from a GNSS track: a coloured fix error no larger is the
truth's."""
TRACK_VERTICAL_RATIO = 2.0
"""A GNSS track's vertical error over its horizontal one (satellites above only: VDOP ~ 1.5-2 HDOP), so a truth
smoothed from it carries about twice the slow error in height."""


def track_error_m() -> np.ndarray:
    """Slow ENU position error (m) a truth smoothed from a GNSS track may carry itself, per axis."""
    return TRACK_ERROR_M * np.array([1.0, 1.0, TRACK_VERTICAL_RATIO])


def colored_fix_note(cand) -> str:
    """'' when the coloured fix error is larger than a smoothed track's own slow error on some axis at 95 % (the
    lower end of its sigma interval above :func:`track_error_m`); else why it is not separable from the
    reference. The fix residual is fix minus truth: a truth's slow error and a receiver's coloured error are the
    same signal there, so only a coloured error the truth cannot carry is the receiver's."""
    bound = track_error_m()
    low = np.array([cand.intervals.get(f"sigma_m[{a}]", [0.0, 0.0])[0] for a in "enu"])
    if np.any(low > bound):
        return ""
    fit = ", ".join(f"{a} {cand.params.get(f'sigma_m[{a}]', 0.0):.3g}" for a in "enu")
    return (f"not separable from the reference on this record: a coloured fix error of {fit} m (95 % lower ends "
            f"{', '.join(f'{v:.3g}' for v in low)}) is what a truth smoothed from a GNSS track carries itself (up to "
            f"{bound[0]:g} m horizontal, {bound[2]:g} m vertical at periods of minutes); not ranked")


def moving_file_truth(case) -> bool:
    """True when the truth comes from a file and the IMU translates (a tumble or a rate table does not)."""
    if getattr(case.scenario, "source", None) not in FILE_SOURCES:
        return False
    if "moving_file_truth" not in case.cache:
        traj = trajectory(case)
        speed = np.linalg.norm(traj.position.enu(case.sim_t_abs, 1), axis=1)
        case.cache["moving_file_truth"] = bool(np.max(speed) > MOVING_MPS)
    return case.cache["moving_file_truth"]


def clean(case, resid: np.ndarray) -> np.ndarray:
    """The residual less each joined file's own turn-on bias (its mean per channel) and, on a rate table, less each
    dwell's yaw offset (:func:`dwell_yaw_fit`; else unchanged). The moving truth file's error is not removed here
    but weighted (:func:`with_reference_error`)."""
    resets = list(getattr(case, "bias_resets", None) or [])
    if resets:
        resid = resid.copy()
        for a, b in zip([0] + resets, resets + [len(resid)]):
            resid[a:b] -= resid[a:b].mean(axis=0)
    fit = dwell_yaw_fit(case, resid)
    return resid if fit is None else resid - fit


def dwell_yaw_columns(case) -> list:
    """Per spinning dwell of a rate table typed as static segments, (sample indices, (m, 3) gyro column): the residual
    a yaw offset of 1 rad of the truth about the table's (vertical) axis makes, a_b x w_ie,b - the Earth rate's
    horizontal part rotated about the axis; the table's own rate is along the axis and gravity along it too, so
    nothing else moves. Demeaned over the dwell: only its turning part is used, a constant (a misalignment or a
    bias times the dwell's rate) is left to the tests. [] when the record is no such table."""
    from imu_sim.diagnose.unstated import is_rate_table
    scenario = getattr(case, "scenario", None)
    segs = getattr(scenario, "spec", None) or []
    if getattr(scenario, "source", None) != "static_segments" or not is_rate_table(segs):
        return []
    if "dwell_yaw_columns" in case.cache:
        return case.cache["dwell_yaw_columns"]
    from nav_core.earth import RATE as EARTH_RATE
    out = []
    traj = trajectory(case)
    rot = traj.attitude.rotation(case.sim_t_abs).as_matrix()
    lat = float(traj.geodetic(np.array([case.sim_t_abs[0]]))[0][0])
    w_ie = np.einsum("nji,j->ni", rot, EARTH_RATE * np.array([0.0, np.cos(lat), np.sin(lat)]))
    col = np.cross(rot[:, 2, :], w_ie)  # the ENU up axis in body coordinates is row 2 of body-to-ENU
    stated = stated_samples(case)
    for seg in segs:
        if not float(seg.get("rate_dps", 0.0) or 0.0):
            continue
        idx = np.flatnonzero((case.sim_t_abs > float(seg["t0"])) & (case.sim_t_abs <= float(seg["t1"])) & stated)
        if len(idx) > 10:
            out.append((idx, col[idx] - col[idx].mean(axis=0)))
    case.cache["dwell_yaw_columns"] = out
    return out


def dwell_yaw_fit(case, resid: np.ndarray):
    """(n, 6) the fitted residual of each dwell's yaw offset (:func:`dwell_yaw_columns`, one angle per dwell, least
    squares on the gyros weighted by each one's white noise), or None when the record is no rate table. A user types
    a dwell's start to half a second and its yaw from the encoder at the dwell's start: at 60 deg/s the yaw at the
    typed start is then off by up to 15 deg, and the Earth rate's horizontal part, rotated by that much, is a
    sinusoid at the table rate on gyro x/y (1.2e-5 rad/s: own navigation-grade table nulls 8000 and 8004 named an
    axis misalignment, a Gauss-Markov bias at tau 0.8 s and a random walk on gyro x/y, LR 30-176 against 20-36;
    with the yaw stated at the typed start, nothing was significant)."""
    cols = dwell_yaw_columns(case)
    if not cols:
        return None
    from imu_sim.diagnose.unstated import diff_noise_sd
    w = 1.0 / np.maximum(diff_noise_sd(resid[:, :3]), 1e-300) ** 2
    out = np.zeros_like(resid)
    for idx, x in cols:
        den = float(np.sum(w * x * x))
        if den > 0:
            out[idx, :3] = x * (float(np.sum(w * x * resid[idx, :3])) / den)
    return out


def with_reference_error(case, resid: np.ndarray, psd: np.ndarray) -> np.ndarray:
    """The model's noise PSD (6, nf, on the rfft grid of ``resid``) plus, on a moving truth file, the reference's
    error: per channel the excess of the residual's smoothed periodogram (running mean over +-REF_WINDOW in
    frequency: a reference error made of a few slow lines is spread over its neighbourhood, so a regressor near
    one of them is weighted by it) over the model's PSD at its robust level (else ``psd`` unchanged)."""
    if not moving_file_truth(case):
        return psd
    n = len(resid)
    pgram = (np.abs(np.fft.rfft(resid, axis=0)) ** 2 * case.dt / n).T
    level = np.median(pgram[:, 1:] / psd[:, 1:], axis=1) / np.log(2.0)
    smooth = _log_running_mean(pgram)
    excess = np.clip(smooth - level[:, None] * psd, 0.0, None)
    excess[:, 0] = 0.0
    return psd + excess / level[:, None]


REF_WINDOW = 0.25
"""Half-width of the running mean that estimates the reference error's PSD, relative to the frequency."""
REF_MIN_BINS = 15


def _log_running_mean(pgram: np.ndarray) -> np.ndarray:
    """Running mean (6, nf) of a periodogram over bins within +-REF_WINDOW of each frequency (at least
    +-REF_MIN_BINS bins), on a log-spaced set of centres interpolated back to every bin."""
    nf = pgram.shape[1]
    centres = np.unique(np.r_[np.arange(1, min(nf, 4 * REF_MIN_BINS)),
                              np.geomspace(1, nf - 1, 400).astype(int)])
    med = np.empty((pgram.shape[0], len(centres)))
    for j, k in enumerate(centres):
        half = max(REF_MIN_BINS, int(REF_WINDOW * k))
        med[:, j] = np.mean(pgram[:, max(1, k - half):min(nf, k + half + 1)], axis=1)
    out = np.empty_like(pgram)
    for c in range(pgram.shape[0]):
        out[c, 1:] = np.exp(np.interp(np.log(np.arange(1, nf)), np.log(centres), np.log(np.maximum(med[c], 1e-300))))
    out[:, 0] = out[:, 1]
    return out


def harmonic_bins(case) -> np.ndarray:
    """Mask (nf,) of rfft bins at lines of the truth's own rate / specific force (one bin either side)."""
    truth = np.column_stack([case.gyro_true, case.accel_true])
    truth = truth - truth.mean(axis=0)
    nf = len(case.t) // 2 + 1
    if not np.any(np.std(truth, axis=0) > 1e-9):
        return np.zeros(nf, bool)
    power = np.abs(np.fft.rfft(truth, axis=0)) ** 2
    local = median_filter(power, size=(101, 1), mode="nearest")
    ratio = np.max(power / np.maximum(local, 1e-300 + 1e-12 * power.max(axis=0)), axis=1)
    lines = ratio > HARMONIC_RATIO
    lines[0] = False
    return lines | np.r_[lines[1:], False] | np.r_[False, lines[:-1]]


def note(case, n_harmonic: int) -> str:
    """What the vibration test left out, for ``tested``."""
    parts = [f"lines below {F_MECH_HZ:g} Hz are not searched (no mechanical source; slow periodic wander is "
             "tested by the low-frequency effects)"]
    if n_harmonic:
        parts.append(f"{n_harmonic} bins at harmonics of the trajectory's own motion excluded (the reference "
                     "trajectory's error follows the motion)")
    if moving_file_truth(case):
        parts.append("the residual's smooth excess over the model's noise weighted as the reference trajectory's "
                     "error (moving truth file)")
    return "; ".join(parts)


HOLD_MIN_S = 2.0
"""Shortest hold (s) of a truth file's static or constant-rate stretch."""
HOLD_RATE_STEP = 1e-7
"""Largest per-sample change of the true rate (rad/s) and of the true specific force over g (1) within a hold."""


def holds(case) -> list:
    """Sample ranges [(a, b)] of the record's holds (static segments, or constant-rate stretches of a truth file
    that does not translate); [] for a moving truth file or a record that never holds still."""
    if "holds" in case.cache:
        return case.cache["holds"]
    out = []
    t = case.sim_t_abs
    if getattr(case.scenario, "source", None) == "static_segments":
        for seg in sorted(case.scenario.spec, key=lambda s: float(s["t0"])):
            idx = np.flatnonzero((t > float(seg["t0"])) & (t <= float(seg["t1"])))
            if len(idx):
                out.append((int(idx[0]), int(idx[-1]) + 1))
    elif not moving_file_truth(case):
        step = np.r_[np.inf, np.max(np.abs(np.diff(case.gyro_true, axis=0)), axis=1)]
        step_f = np.r_[np.inf, np.max(np.abs(np.diff(case.accel_true, axis=0)), axis=1)] / 9.8
        still = (step < HOLD_RATE_STEP * 10) & (step_f < HOLD_RATE_STEP * 10)
        min_n = int(HOLD_MIN_S / case.dt)
        out = [(int(a), int(b)) for a, b in mask_spans(still) if b - a >= min_n]
    case.cache["holds"] = out
    return out


def stated_samples(case) -> np.ndarray:
    """(n,) bool: the samples the scenario gives a reference for (all but ``case.unstated``: moves between a
    table's dwells and their cut edges)."""
    unstated = getattr(case, "unstated", None)
    return np.ones(case.n, bool) if unstated is None else ~unstated


def hold_demeaned(case, resid: np.ndarray) -> np.ndarray:
    """The residual with each hold's own mean (over its stated samples) removed, 0 between holds and at unstated
    samples, on a record of two or more holds (else unchanged): a fixture's tilt (and a truth's attitude error) is
    constant on each hold, so what remains is what a stochastic term may take; the moves, whose profile the
    simulator only guesses, and a table's unsettled dwell edges carry nothing."""
    spans = holds(case)
    if len(spans) < 2:
        return resid
    out = np.zeros_like(resid)
    stated = stated_samples(case)
    for a, b in spans:
        # a rate table's cut dwell edges (dwell_edges) lie inside its stated segments; their fill passes linearly
        # from the dwell before to this one, whose levels differ by the mounting's tilt times the rate step, so
        # once demeaned it left a ramp at every edge: a Gauss-Markov bias at tau 0.3 s, 2-3e-4 rad/s on the cross
        # axes of a tactical table (own hand-mounted table, 100 Hz, 3-8 s dwells; blind seed 8's at 0.25 s)
        keep = stated[a:b]
        if keep.any():
            out[a:b][keep] = resid[a:b][keep] - resid[a:b][keep].mean(axis=0)
    return out


def rotation_columns(case) -> dict:
    """Per channel (n, 3): the residual a small constant rotation d (rad) of the truth's attitude makes, d x the
    true rate on the gyros and d x the true specific force on the accelerometers (one d for both triads)."""
    cols = {}
    for tri, true in enumerate((case.gyro_true, case.accel_true)):
        for i in range(3):
            cols[3 * tri + i] = np.column_stack([np.cross(np.eye(3)[j], true)[:, i] for j in range(3)])
    return cols


SLOW_REFERENCE_KNOT_S = 30.0
"""Knot spacing (s) of the slow reference error a moving truth file may carry: a smoothed track's attitude and bias
error wander at periods of 30-600 s."""
SHAPED_EFFECTS = ("scale_factor", "axis_misalignment", "gyro_g_sensitivity")
"""Sensor effects whose regressor is the truth's own rate or specific force: a truth whose attitude wanders makes
their shape (known constants, whose value is fixed, are not tested against it)."""


def slow_hats(t: np.ndarray) -> np.ndarray:
    """(n, k) piecewise-linear hats at knots every :data:`SLOW_REFERENCE_KNOT_S` from ``t[0]`` (s); they sum to 1, so
    a fit that has a constant of its own drops the first."""
    knot = SLOW_REFERENCE_KNOT_S
    return np.column_stack([np.clip(1.0 - np.abs(t - k) / knot, 0.0, None)
                            for k in np.arange(t[0], t[-1] + knot, knot)])


def _slow_reference_spectra(case, bias: bool = True) -> dict:
    """Per channel the rfft (nf, m) of the slow reference error's columns on a moving truth file: a rotation d(t) of
    the truth's attitude (d x the true rate / specific force, shared by all six channels) and, with ``bias``, a bias
    wander per channel, each piecewise linear between knots every :data:`SLOW_REFERENCE_KNOT_S` (the first bias hat
    dropped: the hats sum to the turn-on bias, already free)."""
    key = ("slow_reference_spectra", bias)
    if key not in case.cache:
        hats = slow_hats(case.t)
        m = hats.shape[1] - 1
        rot = rotation_columns(case)
        out = {}
        for c in range(6):
            wander = np.zeros((case.n, 6 * m if bias else 0))
            if bias:
                wander[:, c * m:(c + 1) * m] = hats[:, 1:]
            out[c] = np.fft.rfft(np.hstack([rot[c][:, [a]] * hats for a in range(3)] + [wander]), axis=0)
        case.cache[key] = out
    return case.cache[key]


def _lr(a: np.ndarray, b: np.ndarray) -> float:
    """b^T A^+ b on the correlation scale (columns of any size; a rotation collinear with a misalignment's
    antisymmetric part is counted once)."""
    d = np.sqrt(np.diag(a))
    d[d == 0] = 1.0
    return float((b / d) @ np.linalg.pinv(a / np.outer(d, d), rcond=1e-9, hermitian=True) @ (b / d))


def _normal_equations(ctx, cand, bias: bool = True):
    """(A, b, k) of ``cand``'s k regressors followed by the slow reference error's columns, on its test's weights."""
    wh, nuis = ctx.wh, _slow_reference_spectra(ctx.case, bias)
    k = next(iter(cand.columns.values())).shape[1]
    m = nuis[0].shape[1]
    a, b = np.zeros((k + m, k + m)), np.zeros(k + m)
    for ch in range(6):
        xc = wh.spectrum(cand.columns[ch]) if ch in cand.columns else np.zeros((nuis[ch].shape[0], k), complex)
        xf = np.hstack([xc, nuis[ch]])
        a += wh.gram(ch, xf, xf)
        b += wh.gram(ch, xf, ctx.resid_f[:, ch])
    return a, b, k


def slow_reference_lr(ctx, cand) -> float:
    """Likelihood ratio of ``cand``'s regressors given the slow reference error of a moving truth file
    (:func:`_slow_reference_spectra`), on the same weights as its test."""
    a, b, k = _normal_equations(ctx, cand)
    return _lr(a, b) - _lr(a[k:, k:], b[k:])


def constant_given_slow_reference(ctx, cand) -> None:
    """On a moving truth file, a known constant's scale (Coriolis, Earth rate, gravity model), its interval and its
    statistic from the joint fit with the truth's slowly varying attitude error (:func:`_slow_reference_spectra`,
    the rotation only): the constant has a known regressor, so the rotation takes only what the regressor cannot
    explain, and the constant only what the rotation cannot. The bias wander is left out here: on a 240-s drive it
    mimics 2 Omega x v, whose size follows the speed legs (industrial town drive: LR 30 alone, 3.0 given a 30-s bias
    wander, 18.7 and scale 0.87 +- 0.2 given the rotation). Navigation-grade town drive: scale 2.68 +- 0.06 alone
    (an 'implausible' Coriolis: the truth's attitude error fitted into it), 0.99 +- 0.17 given the rotation."""
    from imu_sim.diagnose import regressors
    if (cand.constant_scale is None or not cand.identifiable or not cand.columns
            or not moving_file_truth(ctx.case)):
        return
    before = cand.stat
    theta, cov, lr = _constant_fit(ctx, cand)
    for _ in range(JOINT_ITERATIONS):  # the reference's error estimated from what the constant leaves
        again = _constant_fit(_weighted_without(ctx, cand, theta[0]), cand)
        done = abs(again[0][0] - theta[0]) < 0.05 * np.sqrt(max(again[1][0, 0], 1e-300))
        theta, cov, lr = again
        if done:
            break
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    ci = np.column_stack([theta - 1.959964 * sd, theta + 1.959964 * sd])
    cand.stat = lr
    cand.constant_scale, cand.constant_se = float(theta[0]), float(sd[0])
    cand.params, cand.intervals = regressors.physical_value(cand.effect, theta, ci, ctx.case)
    cand.reason = ((cand.reason + "; ") if cand.reason else "") + (
        f"fitted jointly with the truth file's slowly varying attitude error (a rotation, knots every "
        f"{SLOW_REFERENCE_KNOT_S:g} s, the reference's error spectrum estimated from the residual less the "
        f"constant's fitted part): likelihood ratio {before:.4g} alone, {cand.stat:.4g} given it")


JOINT_ITERATIONS = 4
"""Rounds of re-estimating a moving truth's error spectrum from the residual less a known constant's fitted part."""


def _constant_fit(ctx, cand) -> tuple:
    """(theta (k,), cov (k, k), likelihood ratio) of ``cand``'s regressors jointly with the truth's slow rotation."""
    a, b, k = _normal_equations(ctx, cand, bias=False)
    d = np.sqrt(np.diag(a))
    d[d == 0] = 1.0
    inv = np.linalg.pinv(a / np.outer(d, d), rcond=1e-9, hermitian=True) / np.outer(d, d)
    return (inv @ b)[:k], inv[:k, :k], float(_lr(a, b) - _lr(a[k:, k:], b[k:]))


def _weighted_without(ctx, cand, scale: float):
    """``ctx`` with its weights from the model's noise plus the reference's error (:func:`with_reference_error`)
    estimated from the residual less ``scale`` times the constant's regressor: estimated from the residual itself,
    the reference's excess holds the constant's own power, and a known regressor is weighted out by itself (own slow
    tactical town drive 7013: LR 33, scale 0.97 +- 0.33 so; 331, 1.00 +- 0.11 with the constant taken out first)."""
    from types import SimpleNamespace

    from imu_sim.diagnose.spectral import Whitener, noise_psd
    case = ctx.case
    less = ctx.resid.copy()
    for ch, x in cand.columns.items():
        less[:, ch] -= scale * x[:, 0]
    psd = with_reference_error(case, less, noise_psd(ctx.model, np.fft.rfftfreq(case.n, case.dt), case.dt))
    wh = Whitener.from_psd(psd, less, case.dt)
    wh.unstated = ctx.wh.unstated
    return SimpleNamespace(case=case, model=ctx.model, resid=ctx.resid, resid_f=ctx.resid_f, wh=wh)


def slow_reference_note(ctx, cand) -> str:
    """On a moving truth file, why a scale factor, misalignment or g-sensitivity is not separable from the truth's
    slowly varying attitude and bias error ('' when it is): its likelihood ratio given them is below its threshold.
    (A navigation-grade drive null checked against a truth smoothed from GNSS, 0.1 deg in heading: scale factor
    5320, misalignment 4889, g-sensitivity 101 against 22-39; given the slow reference error 9.9, 0 and 2.6.)"""
    if cand.effect not in SHAPED_EFFECTS or not cand.significant or not cand.columns or not moving_file_truth(ctx.case):
        return ""
    given = slow_reference_lr(ctx, cand)
    if given > cand.threshold:
        return ""
    return (f"not separable from the reference on this record: a slowly varying rotation of the truth file's attitude "
            f"and a slow bias wander (knots every {SLOW_REFERENCE_KNOT_S:g} s: a smoothed track's own error) explain "
            f"it; its likelihood ratio given them {given:.4g} is below the threshold {cand.threshold:.4g}; not ranked")


def attitude_note(ctx, cand) -> str:
    """On a moving truth file, why an axis misalignment is not separable from the truth's own attitude error ('' when
    it is): its likelihood ratio less that of one constant rotation of the truth's attitude (a rotation is an
    antisymmetric misalignment shared by the gyros and the accelerometers; a smoothed track's attitude is off by
    hundredths of a degree, its heading by a tenth, and the IMU's mounting in the vehicle is a rotation too)."""
    if cand.effect == "axis_misalignment" and getattr(ctx.case.scenario, "source", None) == "static_segments":
        return ""  # a rate table's mounting: mounting.mounting_fit, after the fixture's ranking
    if cand.effect != "axis_misalignment" or not cand.significant or not moving_file_truth(ctx.case):
        return slow_reference_note(ctx, cand)
    from imu_sim.diagnose.spectral import gls
    rotation = gls(ctx.wh, ctx.resid_f, rotation_columns(ctx.case), 3)
    given = cand.stat - rotation.lr
    if given > cand.threshold:
        return slow_reference_note(ctx, cand)
    d = np.degrees(np.abs(rotation.theta)).max() if rotation.identifiable else float("nan")
    return (f"not separable from the reference on this record: one constant rotation of the truth file's attitude "
            f"({d:.2g} deg at most) explains it, its likelihood ratio given that rotation {given:.4g} is below the "
            f"threshold {cand.threshold:.4g} (a truth's attitude error and the IMU's mounting are a rotation); not ranked")


def whitened(case, model, resid: np.ndarray, cols: dict):
    """Residual (n, 6) and columns {channel: (n,) or (n, k)} whitened by the model's noise PSD plus a moving truth
    file's reference error (:func:`with_reference_error`; unit gain at the top frequency, DC dropped), so a held-out
    fit or a drop-one energy weights each frequency as the GLS tests do."""
    from imu_sim.diagnose.spectral import noise_psd
    freqs = np.fft.rfftfreq(case.n, case.dt)
    psd = with_reference_error(case, resid, noise_psd(model, freqs, case.dt))
    gain = 1.0 / np.sqrt(psd / psd[:, -1:])
    gain[:, 0] = 0.0

    def whiten(x, c):
        return np.fft.irfft(np.fft.rfft(x, axis=0) * (gain[c][:, None] if x.ndim == 2 else gain[c]), n=case.n, axis=0)
    out = np.column_stack([whiten(resid[:, c], c) for c in range(6)])
    return out, {c: whiten(x, c) for c, x in cols.items()}
