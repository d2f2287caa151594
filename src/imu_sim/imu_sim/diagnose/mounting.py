"""The unit's mounting on a rate table as a nuisance: a rotation of each mounting, within the scenario's
``attitude_tolerance_deg``, fitted jointly with every tilt-sensitive effect.

On a level one-axis table a gyro's sensitivity to the table rate (x-z) is exactly a tilt of the mounting about y,
and the accelerometers see only each mounting's constant specific force. A unit remounted by hand for each spin axis
has a tilt of its own in each mounting; fitted without them, the blind consumer table's gyro misalignments came out
0.3-5 mrad off with +-0.2-mrad intervals and its industrial null named a 0.5-deg mounting axis_misalignment.
"""
from __future__ import annotations

import copy

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import noise_stats

from imu_sim.diagnose.reference import _lr, rotation_columns, stated_samples
from imu_sim.diagnose.unstated import is_rate_table


def table_record(case) -> bool:
    """Whether the record is a rate table typed as static segments (one at least spinning, ``rate_dps``)."""
    return getattr(case.scenario, "source", None) == "static_segments" and is_rate_table(case.scenario.spec or [])


def mounting_groups(case) -> list:
    """Sample masks (n,) of the unit's mountings on a rate table: consecutive static segments at one nominal roll and
    pitch are one mounting (the table turns about its axis, so only the yaw changes; a new roll or pitch is the unit
    remounted, by hand unless the scenario states its moves). One mask for the whole record when ``moves_known``
    (a motorised sequence, the unit mounted once) or when every segment has one roll and pitch."""
    if "mounting_groups" in case.cache:
        return case.cache["mounting_groups"]
    segs = sorted(case.scenario.spec or [], key=lambda s: float(s["t0"]))
    t = getattr(case, "sim_t_abs", case.t)
    if getattr(case.scenario, "moves_known", False):
        groups = [np.ones(case.n, bool)]
    else:
        groups, key = [], None
        for seg in segs:
            k = (round(float(seg.get("roll_deg", 0.0)), 3), round(float(seg.get("pitch_deg", 0.0)), 3))
            if k != key:
                groups.append(np.zeros(case.n, bool))
                key = k
            groups[-1] |= (t > float(seg["t0"])) & (t <= float(seg["t1"]))
    case.cache["mounting_groups"] = groups
    return groups


def _nuisance(case, drift: bool) -> tuple:
    """(mounting groups, rotation columns, table tilt columns, accelerometer wander sd per offset, gyro drift columns,
    off-axis columns) of :func:`_mounting_system`'s nuisance; the drift columns empty without ``drift``."""
    groups = mounting_groups(case)
    wander = accel_wander_sd(case, groups) if len(groups) > 1 else np.zeros(0)
    slow = gyro_drift_columns(case, groups) if drift else np.zeros((case.n, 0))
    return groups, rotation_columns(case), table_tilt_columns(case), wander, slow, off_axis_columns(case)


def off_axis_columns(case) -> np.ndarray:
    """(n, 3, 3) per sample the accelerometers' residual (m/s^2, body) of a constant vector per body axis (last
    index) times the squared true rate |w|^2 (rad/s): the centripetal acceleration of a unit whose sensing centre is
    off the table's axis, w x (w x r) = |w|^2 (s (s . r) - r) for the spin axis s, a vector fixed in the body times
    the dwell's rate squared - and so is its change with the mounting's own tilt d (s turned by d x s in the body:
    |w|^2 times a vector along the spin axis that w x (w x r) alone does not span; a navigation-grade null was left at
    LR 321-882 without it). The tangential dw/dt x r is 0 on a dwell; the truth's rate steps at a dwell's edge, and its
    gradient there, 1e2 rad/s^2 at 100 Hz, took the fit of r (6 times too small on the own industrial short table
    8002, whose gyro misalignment stayed at LR 2.7e4). A unit mounted by hand sits centimetres off the axis: 5 cm is
    0.18 m/s^2 at 110 deg/s, a different step on the accelerometers at each dwell, which pulled each mounting's tilt
    (pinned by its accelerometers) away from what its gyros say, and the gyros' misalignment took the difference (own
    short tables 5 cm off: the industrial null named axis_misalignment 1-4e-3 rad at LR 3.7e4)."""
    if "off_axis_columns" not in case.cache:
        w2 = np.sum(case.gyro_true ** 2, axis=1)
        case.cache["off_axis_columns"] = w2[:, None, None] * np.eye(3)[None, :, :]
    return case.cache["off_axis_columns"]


def _mounting_system(ctx, cand, keep: list, resid_f: np.ndarray | None = None, nuisance: tuple | None = None):
    """(A, b, k, tol) of ``cand``'s parameters ``keep`` followed by a rotation of each mounting
    (:func:`mounting_groups`: w x d on the gyros, f x d on the accelerometers, one d per mounting shared by both
    triads), the tolerance as a Gaussian prior on each d, then the table axis's tilt from the vertical
    (:func:`table_tilt_columns`, the tolerance its prior too), each mounting's centripetal acceleration (a free
    vector times the rate squared, :func:`off_axis_columns`), each mounting's own accelerometer bias offset
    (:func:`accel_wander_sd` its prior; none when the model states no wander), then a turn-on bias per channel (a
    mounting tilt's f x d is constant on a level table, the bias's own shape: only the mountings' differences tell
    them apart). ``nuisance`` is :func:`_nuisance`'s (default: without drift); with drift, each gyro's slow bias
    drift (:func:`gyro_drift_columns`, free) comes before the turn-on biases."""
    case, wh = ctx.case, _white(ctx)
    tol = np.radians(float(getattr(case.scenario, "attitude_tolerance_deg", 1.0)))
    nuisance = _nuisance(case, False) if nuisance is None else nuisance
    groups, _, tilt, wander, slow, _ = nuisance
    stated = stated_samples(case)
    k, m, nt, nw, nd = len(keep), 3 * len(groups), tilt[0].shape[1], len(wander), 3 * slow.shape[1]
    size = k + m + nt + 3 * len(groups) + nw + nd + 6
    a, b = np.zeros((size, size)), np.zeros(size)
    for ch in range(6):
        xf = wh.spectrum(_design(case, cand, keep, ch, nuisance, stated))
        a += wh.gram(ch, xf, xf)
        b += wh.gram(ch, xf, (ctx.resid_f if resid_f is None else resid_f)[:, ch])
    # the tolerance as a prior (sd = tolerance): a rotation about the table axis, which only the Earth rate's
    # horizontal part shows, stays within it instead of fitting that part's noise
    a[k:k + m + nt, k:k + m + nt] += np.eye(m + nt) / max(tol, 1e-12) ** 2
    if nw:
        o = k + 2 * m + nt
        a[o:o + nw, o:o + nw] += np.diag(1.0 / wander**2)
    return a, b, k, tol


def _design(case, cand, keep: list, ch: int, nuisance: tuple, stated: np.ndarray) -> np.ndarray:
    """(n, size) channel ``ch``'s columns of :func:`_mounting_system` (``nuisance``: :func:`_nuisance`'s) in the time
    domain, 0 at unstated samples."""
    groups, rot, tilt, wander, slow, arm = nuisance
    k, m, nt, nw, nd = len(keep), 3 * len(groups), tilt[0].shape[1], len(wander), 3 * slow.shape[1]
    xc = cand.columns[ch][:, keep] if ch in cand.columns else np.zeros((case.n, k))
    bias = np.zeros((case.n, 6))
    bias[:, ch] = 1.0  # the turn-on bias as a parameter: under coloured weights a demeaned column is not
    # orthogonal to a constant (a navigation-grade mounting fit was 0.06 deg off without it)
    offsets = np.zeros((case.n, nw))
    if nw and ch >= 3:
        for g, mask in enumerate(groups):
            offsets[:, 3 * g + ch - 3] = mask
    drifts = np.zeros((case.n, nd))
    if nd and ch < 3:
        drifts[:, ch * slow.shape[1]:(ch + 1) * slow.shape[1]] = slow
    # each mounting's centripetal vector (free, m): the accelerometers' dwell-to-dwell steps in |w|^2
    offaxis = [arm[:, ch - 3, :] * g[:, None] if ch >= 3 else np.zeros((case.n, 3)) for g in groups]
    x = np.hstack([xc] + [rot[ch] * g[:, None] for g in groups] + [tilt[ch]] + offaxis + [offsets, drifts, bias])
    demean = np.arange(x.shape[1]) < k + 2 * m + nt
    return np.where(stated[:, None], x - x[stated].mean(axis=0) * demean, 0.0)


def dwell_dispersion(ctx, cand, keep: list, nuisance: tuple, theta_all: np.ndarray, cov: np.ndarray,
                     rest: np.ndarray) -> float:
    """The factor (>= 1) the gyros' scale factors' sd are widened by: the scatter of the joint fit's residual means
    over the spinning dwells that turn about each gyro, over their white-noise sd, as a chi-square per degree of
    freedom left (the dwells' count less one and their leverage under the fit's covariance ``cov``), pooled over the
    gyros (``nuisance``: the fit's :func:`_nuisance`).
    A table whose dwells are each off their stated rate by 1e-5..1e-4 (a servo's accuracy, which the scenario does
    not state) puts that error times the rate into each dwell: the fit's white-noise interval does not carry it."""
    case = ctx.case
    stated = stated_samples(case)
    t = getattr(case, "sim_t_abs", case.t)
    chi2_all = dof_all = 0.0
    from imu_sim.diagnose.unstated import diff_noise_sd
    for ch in range(3):
        x = _design(case, cand, keep, ch, nuisance, stated)
        e = ctx.resid[:, ch] - rest[:, ch] - x @ theta_all
        e = e - e[stated].mean()  # the whitener leaves the mean out: the turn-on bias is not determined by the fit
        sd = float(diff_noise_sd(e[stated]))
        if not sd > 0.0:  # a noise-free record (a simulator's own output): no scatter to weigh
            continue
        means, rows, counts = [], [], []
        for seg in case.scenario.spec or []:
            idx = np.flatnonzero((t > float(seg["t0"])) & (t <= float(seg["t1"])) & stated)
            if len(idx) < 10 or not float(seg.get("rate_dps", 0.0) or 0.0):
                continue
            if abs(case.gyro_true[idx, ch].mean()) < 0.5 * np.radians(abs(float(seg["rate_dps"]))):
                continue
            means.append(e[idx].mean())
            rows.append(x[idx].mean(axis=0))
            counts.append(len(idx))
        if len(means) < 3:
            continue
        # relative to their weighted mean (the turn-on bias, which the fit leaves undetermined, drops out), in units
        # of each dwell mean's white-noise sd; each one's leverage under the fit's covariance within [0, 1]
        w = np.array(counts, float) / np.sum(counts)
        z = np.sqrt(counts) / sd
        dev = (np.array(means) - w @ np.array(means)) * z
        rows = (np.array(rows) - w @ np.array(rows)) * z[:, None]
        lev = np.clip(np.nan_to_num(np.einsum("ij,jk,ik->i", rows, cov, rows), nan=1.0), 0.0, 1.0)
        dof, chi2 = len(means) - 1.0 - float(lev.sum()), float(np.sum(dev**2))
        if dof >= 1.0:
            chi2_all, dof_all = chi2_all + chi2, dof_all + dof
    # one table turns under every mounting: its dwells' errors pooled over the gyros (a few dof each), the
    # dispersion's estimate never below white noise's
    return max(1.0, float(np.sqrt(chi2_all / dof_all))) if dof_all >= 1.0 else 1.0


def gyro_drift_columns(case, groups: list) -> np.ndarray:
    """(n, p) one gyro's slow bias drift on a hand-mounted table, free: piecewise linear between knots every
    :data:`reference.SLOW_REFERENCE_KNOT_S` (the first hat dropped: the hats sum to the turn-on bias) and a step at
    each remount after the first (a g-sensitivity's bias changes with the axis that is up). A scale factor's or
    misalignment's information is in the rate alternating from dwell to dwell; a consumer unit's warm-up,
    temperature, g-sensitivity and flicker wander move its bias by 1e-4..1e-3 rad/s over the record, and fitted
    without it the scale factors took part of that drift with white-noise intervals (own consumer three-mounting
    table with those physics, 7 seeds: 15 of 21 covering, misses of 1.04-2.66 half-widths; 20 of 21 with it, the
    one miss 1.77; the blind's consumer table: 1 of 3, errors of 1.5-3.3 half-widths). The intervals are barely
    wider (4.1-5.7e-5 both): the drift moved the estimate, it did not add scatter the white weights missed."""
    from imu_sim.diagnose.reference import slow_hats
    return np.column_stack([slow_hats(case.t)[:, 1:]] + [g.astype(float) for g in groups[1:]])


def table_tilt_columns(case) -> dict:
    """Per channel (n, 2) the residual a tilt of the table's spin axis from the vertical makes (rad, about east and
    north): the unit turns about the tilted axis, so its gyros see no change, but gravity in the body axes tilts
    with the table angle - a sinusoid at the table angle on the accelerometers, R^T (f x t) for the truth's
    body-to-ENU R and specific force f in ENU. Without it, a table level only to 0.01 deg left its accelerometers'
    mean over each mounting to pin that mounting's tilt wrongly, and the gyro misalignment took the difference (own
    tactical three-mounting null: LR 423 given the mountings, 3-6e-5 rad; blind tactical table null: 0.3-1.1e-4 rad
    at LR 108). Zero columns when the truth's attitude is not known."""
    if "table_tilt_columns" not in case.cache:
        rot = body_to_enu(case)
        cols = {ch: np.zeros((case.n, 2 if rot is not None else 0)) for ch in range(6)}
        if rot is not None:
            f_n = np.einsum("nij,nj->ni", rot, case.accel_true)
            for j in range(2):
                cols_j = np.einsum("nji,nj->ni", rot, np.cross(f_n, np.eye(3)[j]))
                for i in range(3):
                    cols[3 + i][:, j] = cols_j[:, i]
        case.cache["table_tilt_columns"] = cols
    return case.cache["table_tilt_columns"]


def body_to_enu(case):
    """(n, 3, 3) the truth's body-to-ENU rotation at each sample (None when the case has no truth trajectory)."""
    if "body_to_enu" not in case.cache:
        try:
            from imu_sim.diagnose.case import trajectory
            case.cache["body_to_enu"] = trajectory(case).attitude.rotation(case.sim_t_abs).as_matrix()
        except (AttributeError, TypeError):
            case.cache["body_to_enu"] = None
    return case.cache["body_to_enu"]


def accel_wander_sd(case, groups: list) -> np.ndarray:
    """(3 m,) prior sd (m/s^2) of each mounting's own accelerometer bias offset (mounting-major): the model's stated
    bias instability B and rate random walk K over a mounting's span T, sqrt(B^2 + K^2 T); empty when it states
    neither. The accelerometers' mean over each mounting pins that mounting's tilt against one turn-on bias: their
    wander from one mounting to the next (5e-4 m/s^2) put the own three-mounting null's gyro misalignment at LR
    200-1900 given the mountings."""
    model = getattr(case, "model", None)
    if model is None:
        return np.zeros(0)
    b = np.asarray(model.accel.bias_instability, float) * np.ones(3)
    k = np.asarray(model.accel.rate_random_walk, float) * np.ones(3)
    if not np.any(b > 0) and not np.any(k > 0):
        return np.zeros(0)
    span = [float(np.ptp(case.t[g])) if g.any() else 0.0 for g in groups]
    return np.concatenate([np.maximum(np.sqrt(b**2 + k**2 * s), 1e-12) for s in span])


def _white(ctx):
    """The test's whitener with white weights (each channel at the model's white level, scaled from the residual,
    the unstated samples still 0): a table's information is in dwell-to-dwell and mounting-to-mounting differences of
    seconds to a minute, and under the model's coloured weights (flicker bias instability) the fill of the unstated
    ramps and remounts leaks into the fit - own three-mounting table, gyro misalignment intervals covering 22 of 72
    under them (navigation and tactical 0 of 30: z of 20-400), 45 of 48 under white weights."""
    from imu_sim.diagnose.spectral import Whitener
    if "mounting_white" not in ctx.case.cache or ctx.case.cache["mounting_white"][0] is not ctx.resid_f:
        wh = ctx.wh
        w = np.where(wh.weights > 0, noise_stats.bin_multiplicity(wh.n)[None, :], 0.0)
        white = Whitener(wh.n, wh.dt, w, noise_stats.robust_scale2(ctx.resid_f.T, w, wh.n))
        white.unstated = getattr(wh, "unstated", None)
        ctx.case.cache["mounting_white"] = (ctx.resid_f, white)
    return ctx.case.cache["mounting_white"][1]


MOUNTING_STEPS = 2
"""Gauss-Newton steps of the mounting fit: the second-order term of a 1-deg rotation and its product with a 5-mrad
misalignment (1e-4 of the rate each) put the own three-mounting table's misalignments 0.1-0.2 mrad off on
noise-free data."""


def _second_order(case, cand, keep: list, theta_all: np.ndarray) -> np.ndarray:
    """(n, 6) what the first-order mounting fit leaves out: R(d) v - v - d x v for each mounting's fitted rotation d
    (v the true rate / specific force), and the candidate's own columns applied to R(d) v - v (a misalignment or
    scale factor of the rotated rate)."""
    k = len(keep)
    out = np.zeros((case.n, 6))
    truth = (case.gyro_true, case.accel_true)
    for g, mask in enumerate(mounting_groups(case)):
        d = theta_all[k + 3 * g:k + 3 * g + 3]
        rot = Rotation.from_rotvec(d).as_matrix()
        for tri, v in enumerate(truth):
            dv = v[mask] @ rot.T - v[mask]
            out[mask, 3 * tri:3 * tri + 3] = dv - np.cross(d, v[mask])
            for i in range(3):
                ch = 3 * tri + i
                if ch in cand.columns:
                    cols = cand.columns[ch][:, keep]
                    # the column's response to the rotated truth: columns are linear in the truth on their triad
                    out[mask, ch] += _rotated_column_effect(cols[mask], v[mask], dv) @ theta_all[:k]
    return out


def _rotated_column_effect(cols: np.ndarray, v: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """(m, k) change of regression columns that are single components of the truth ``v`` (a scale factor's or
    misalignment's: each column is one component of v, or 0) when v becomes v + dv."""
    out = np.zeros_like(cols)
    for j in range(cols.shape[1]):
        for a in range(3):
            if np.any(cols[:, j] != 0) and np.allclose(cols[:, j], v[:, a]):
                out[:, j] = dv[:, a]
                break
    return out


def _solve(a: np.ndarray, b: np.ndarray):
    """Estimate and covariance of the normal equations (A, b), on the correlation scale."""
    d = np.sqrt(np.diag(a))
    d[d == 0] = 1.0
    inv = np.linalg.pinv(a / np.outer(d, d), rcond=1e-9, hermitian=True) / np.outer(d, d)
    return inv @ b, inv


MOUNTING_SLACK = 1.5
"""A fitted mounting rotation component up to this many tolerances is within it (as a fixture's tilt)."""
MOUNTED_EFFECTS = ("scale_factor", "axis_misalignment")
"""Effects a hand-mounted table measures: fitted jointly with the mountings (:func:`mounting_fit`), their intervals
from that fit, the accelerometers' part taken as the model states it."""
MOUNTING_RANKED = ("gyro_g_sensitivity", "warmup_drift", "temperature_bias")
"""Effects a mounting's tilt can also mimic (each mounting's f x d is a step in the accelerometers' level between
mountings, which a warm-up or a temperature ramp follows): ranked by their statistic given the mountings."""


def hand_mounted_table(case) -> bool:
    """A rate table typed as static segments whose remounts the scenario does not state (``moves_known`` false)."""
    return table_record(case) and not getattr(case.scenario, "moves_known", False)


def mounting_fit(ctx, cand, drop=()) -> None:
    """On a hand-mounted rate table, an effect fitted jointly with a rotation of each mounting within the tolerance
    (:func:`_mounting_system`), its statistic the likelihood ratio given them. A scale factor's or misalignment's fit
    and intervals come from that joint fit, with each gyro's slow bias drift free (:func:`gyro_drift_columns`; not
    for a warm-up, temperature or g-sensitivity, which are such a drift), so they carry the mountings' uncertainty
    and no mounting tilt or bias drift is fitted as sensor physics; its accelerometer part is the model's: on a table
    the accelerometers see only each mounting's constant specific force, where their misalignment, their scale factor
    (against the tilt's cosine error) and the mounting's tilt make the same residual - and what they say about each
    mounting's tilt (against one turn-on bias common to all mountings) is what separates the gyros' misalignment from
    it; the gyros' scale factor is unaffected by a tilt to first order. A warm-up, temperature or g-sensitivity fit
    that the mountings explain (below its threshold given them) is not separable from the reference. (Blind consumer
    rate table, f595019: gyro misalignments off by 0.3-5 mrad with +-0.2-mrad intervals, fitted without the
    mountings; own three-mounting table at 1 deg: the null named axis_misalignment, 1 of 6 intervals covering.)"""
    effects = MOUNTED_EFFECTS + MOUNTING_RANKED
    if cand.effect not in effects or not cand.identifiable or not cand.columns or not table_record(ctx.case):
        return
    original = copy.copy(cand)  # the fit is rewritten in place: its refit starts again from this
    if not hand_mounted_table(ctx.case):  # a motorised sequence (moves_known): one mounting, a check only
        if cand.effect == "axis_misalignment" and cand.significant and (note := mounting_note(ctx, cand)):
            cand.identifiable, cand.reason = False, (cand.reason + "; " if cand.reason else "") + note
        return
    from imu_sim.diagnose.candidate import threshold
    k_all = next(iter(cand.columns.values())).shape[1]
    names = list(cand.params)[:k_all]
    own = cand.effect in MOUNTED_EFFECTS and len(names) == k_all
    keep = [j for j, nm in enumerate(names) if not (own and nm.startswith("accel"))] if own else list(range(k_all))
    # parameters a refit drops stay in the joint fit as a nuisance, after the reported ones (effect_tests._without)
    keep = [j for j in keep if names[j] not in drop] + [j for j in keep if names[j] in drop]
    kr = len(keep) - sum(names[j] in drop for j in keep)
    if not kr:
        return
    nuisance = _nuisance(ctx.case, own)
    a, b, k, tol = _mounting_system(ctx, cand, keep, nuisance=nuisance)
    theta_all, inv = _solve(a, b)
    for _ in range(MOUNTING_STEPS):  # Gauss-Newton on the rotations' second-order term (see _second_order)
        rest = _second_order(ctx.case, cand, keep, theta_all)
        b = _mounting_system(ctx, cand, keep, ctx.resid_f - np.fft.rfft(rest, axis=0), nuisance)[1]
        theta_all = inv @ b
    before = cand.stat_alone = cand.stat
    cand.stat = float(_lr(a, b) - _lr(a[kr:, kr:], b[kr:]))
    cand.mounting_theta = theta_all[k:k + 3 * len(mounting_groups(ctx.case))].copy()
    groups = len(mounting_groups(ctx.case))
    told = (f"fitted jointly with a rotation of each of the unit's {groups} mountings on the table (within "
            f"attitude_tolerance_deg): likelihood ratio {before:.4g} alone, {cand.stat:.4g} given them")
    if not own:
        top = float(np.max(np.abs(cand.mounting_theta)))
        if before > cand.threshold >= cand.stat and top <= MOUNTING_SLACK * tol:
            cand.identifiable = False
            cand.reason = ((cand.reason + "; ") if cand.reason else "") + (
                f"not separable from the reference on this record: {told}, below its threshold "
                f"{cand.threshold:.4g}; not ranked")
        elif cand.rank is not None:
            cand.rank = min(cand.rank, cand.stat - cand.threshold)
        return
    theta, sd = theta_all[:kr], np.sqrt(np.clip(np.diag(inv)[:kr], 0.0, None))
    if cand.effect == "scale_factor":  # each dwell's own rate error: the dwells' scatter widens the interval
        widen = dwell_dispersion(ctx, cand, keep, nuisance, theta_all, inv, rest)
        sd = sd * np.array([widen if names[j].startswith("gyro[") else 1.0 for j in keep[:kr]])
    cand.threshold = threshold(kr, ctx.m_tests, 1, ctx.factor(cand.effect))
    keep = keep[:kr]
    full = np.zeros(len(names))
    full[keep] = theta
    cand.params = {names[j]: float(v) for j, v in zip(keep, theta)}
    cand.intervals = {names[j]: [float(v - 1.959964 * e), float(v + 1.959964 * e)] for j, v, e in zip(keep, theta, sd)}
    if getattr(cand, "design", None) is not None:
        cand.physics = cand.design.to_physics(full)
    cand.contrib = np.zeros((ctx.case.n, 6))
    for ch, x in cand.columns.items():
        cand.contrib[:, ch] = x @ full
    cand.columns = {c: x[:, keep] for c, x in cand.columns.items() if np.any(x[:, keep] != 0)}
    cand.channels = [ch for ch in cand.channels if not ch.startswith("a")] if cand.channels else cand.channels
    cand.rank = None
    # without some parameters (not identifiable on this record, or out of the grade's bounds): the joint fit again,
    # those kept as a nuisance - on a one-axis table the undetermined gyro x/y scale factors of a z-table's fit had
    # dropped the whole effect (own long industrial table 7002: gyro z significant at LR 2811, no finding)
    cand.refit = lambda names_out: _refit(ctx, original, [*drop, *names_out])
    if getattr(cand, "design", None) is not None:
        cand.design = cand.design.without([j for j in range(len(names)) if j not in keep])
    dropped = len(names) - k
    cand.reason = ((cand.reason + "; ") if cand.reason else "") + told + (
        f"; the accelerometers' {dropped} parameters are the model's: on a table they see only each mounting's "
        f"constant specific force, where they and the mounting's tilt make the same residual" if dropped else "")
    if cand.effect == "axis_misalignment" and before > cand.threshold and (note := mounting_note(ctx, cand)):
        cand.identifiable, cand.reason = False, cand.reason + "; " + note
    top = float(np.max(np.abs(cand.mounting_theta)))
    if cand.identifiable and top > MOUNTING_SLACK * tol:
        # a mounting fitted beyond the tolerance: the record's reference is not the scenario's (own navigation-grade
        # three-mounting table: a 12-deg rotation about a spin axis, misalignments 0.4 mrad off for 1e-5)
        cand.identifiable, cand.reason = False, cand.reason + "; " + (
            f"not separable from the reference on this record: fitted with it, a mounting leaves the scenario's "
            f"attitude_tolerance_deg ({np.degrees(top):.2g} deg against {np.degrees(tol):g}), so the joint fit's "
            f"parameters and intervals do not hold; not ranked")


def _refit(ctx, original, drop: list):
    """``original`` (a candidate before its joint fit) fitted with the mountings again without ``drop``."""
    again = copy.copy(original)
    mounting_fit(ctx, again, drop)
    return again


def mounting_note(ctx, cand) -> str:
    """On a rate table, why an axis misalignment is not separable from the unit's mounting on the table ('' when it
    is): a constant rotation of each mounting (:func:`mounting_groups`), within 1.5 ``attitude_tolerance_deg`` (as a
    fixture's tilt), explains it - its likelihood ratio given the rotations is below the threshold. On a level one-axis
    table a gyro's sensitivity to the table rate (x-z) is exactly a mounting tilt about y (the accelerometers see only
    the constant g there, which the turn-on bias takes). Blind rate-table null (2cf2e33): a 0.5-deg mounting named
    axis_misalignment first, 5-9 mrad in both triads. On a hand-mounted table the candidate is already the joint fit
    (:func:`mounting_fit`)."""
    if hand_mounted_table(ctx.case) and getattr(cand, "mounting_theta", None) is not None:
        given, theta = cand.stat, cand.mounting_theta
        tol = np.radians(float(getattr(ctx.case.scenario, "attitude_tolerance_deg", 1.0)))
    else:
        keep = list(range(next(iter(cand.columns.values())).shape[1]))
        a, b, k, tol = _mounting_system(ctx, cand, keep)
        given = _lr(a, b) - _lr(a[k:, k:], b[k:])
        theta = _solve(a[k:, k:], b[k:])[0][:3 * len(mounting_groups(ctx.case))]
    top = float(np.max(np.abs(theta)))
    if given > cand.threshold or top > MOUNTING_SLACK * tol:
        return ""
    return (f"not separable from the reference on this record: a constant rotation of each of the unit's mountings on "
            f"the table ({np.degrees(top):.2g} deg at most, within the scenario's attitude_tolerance_deg "
            f"{np.degrees(tol):g}) explains it; its likelihood ratio given them {given:.4g} is below the "
            f"threshold {cand.threshold:.4g} (on a rate table a mounting tilt and an axis misalignment make the same "
            f"residual); not ranked")


def without_mountings(case, cand, resid: np.ndarray) -> np.ndarray:
    """The residual (n, 6) less the mountings' rotation fitted with ``cand`` (a hand-mounted table; else unchanged),
    for its held-out fit: on a navigation-grade table a 1-deg tilt's w x d (1.7e-2 rad/s at 1 rad/s) swamped a 5e-5
    scale factor's held-out gain (own seed 7000: significant at 1.2e4 given the mountings, not kept)."""
    theta = getattr(cand, "mounting_theta", None)
    if theta is None or not hand_mounted_table(case):
        return resid
    out = resid.copy()
    for g, mask in enumerate(mounting_groups(case)):
        rot = Rotation.from_rotvec(theta[3 * g:3 * g + 3]).as_matrix()
        for tri, v in enumerate((case.gyro_true, case.accel_true)):
            out[mask, 3 * tri:3 * tri + 3] -= v[mask] @ rot.T - v[mask]
    return out
