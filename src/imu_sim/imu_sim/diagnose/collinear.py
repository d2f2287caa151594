"""Slow deterministic terms a record cannot tell apart by their regressors alone: a warm-up's exponential and the
recorded temperature.

A unit's temperature often rises with its warm-up, so the temperature regressor and the warm-up's exponential are
nearly the same curve over the record (blind seed 2: a tactical warm-up of time constant 193 s was named
temperature_bias, its statistic given the warm-up still large). Where they correlate beyond :data:`COLLINEAR` over
the stated samples, both candidates' ``tested`` notes say so. On a fixture of still holds the two are also fitted
jointly with the holds' tilts, one weighting for both (:func:`decide_on_holds`): the one the other does not explain
ranks first; a temperature curve is weighed against a found bias random walk on the holds' means
(:func:`walk_or_temperature`).
"""
from __future__ import annotations

import numpy as np

from scipy.stats import chi2

from imu_sim.diagnose import fixture, reference
from imu_sim.diagnose.hold_noise import Prior, walk_and_temperature

COLLINEAR = 0.95
"""|correlation| of the two regressors (demeaned: the turn-on bias is free) beyond which the record cannot tell
the two effects apart."""


def correlation(t: np.ndarray, temp_c: np.ndarray, tau_s: float, keep: np.ndarray | None = None) -> float:
    """Correlation over ``keep`` of the temperature (degC) and exp(-(t - t0) / tau) (t, tau in s)."""
    keep = np.ones(len(t), bool) if keep is None else keep
    a = np.exp(-(t - t[0]) / tau_s)[keep]
    b = np.asarray(temp_c, float)[keep]
    a, b = a - a.mean(), b - b.mean()
    den = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / den) if den > 0 else 0.0


def note_collinear(case, cands: list, resid: np.ndarray | None = None, model=None) -> None:
    """Add to the significant warm-up and temperature candidates' notes when their regressors are collinear here;
    with ``resid`` (the pass's cleaned residual) on a fixture, rank the two by :func:`decide_on_holds` first."""
    by = {c.effect: c for c in cands}
    constant_before_mimic(case, by, getattr(case, "model", None) if model is None else model)
    if walk_or_temperature(case, by, resid, model):
        return  # the temperature is no rival of the warm-up then
    warm, temp = by.get("warmup_drift"), by.get("temperature_bias")
    if warm is None or temp is None or not (warm.significant and temp.significant):
        return
    if resid is not None:
        decide_on_holds(case, temp, warm, resid, model)
    tau = (warm.params or {}).get("time_constant_s")
    if getattr(case, "temp_c", None) is None or not tau:
        return
    unstated = getattr(case, "unstated", None)
    r = correlation(case.t, case.temp_c, float(tau), None if unstated is None else ~unstated)
    if abs(r) < COLLINEAR:
        return
    text = (f"collinear with {{other}} on this record: the recorded temperature and the warm-up's exponential (time "
            f"constant {float(tau):.3g} s) correlate at r = {r:.3f} over the stated samples, so this record cannot "
            "tell a warm-up from a temperature coefficient by the regressors alone")
    for cand, other in ((warm, "temperature_bias"), (temp, "warmup_drift")):
        cand.reason = (cand.reason + "; " if cand.reason else "") + text.format(other=other)


def pair_on_holds(case, temp, warm, resid: np.ndarray, model=None) -> dict | None:
    """Likelihood ratios on a fixture's holds of the temperature and warm-up curves, each given the holds' tilts and
    bias offsets (``temperature_bias``, ``warmup_drift``) and each given the other too (``temperature_bias|other``,
    ...), all under one weighting (each channel's noise level and effective sample size after both curves): the
    fixture's per-candidate weights (:func:`fixture._given`) follow each candidate's own residual, so their
    statistics are not comparable (blind seed 7, a navigation warm-up of 160 s: the temperature ranked first at 40.5
    against the warm-up's 43.6 given a walk's wander; on one weighting the warm-up given the temperature is 197, the
    temperature given it 4). None off a fixture or without both curves' columns."""
    if not (temp.columns and warm.columns):
        return None
    n = case.n
    kt, kw = (next(iter(c.columns.values())).shape[1] for c in (temp, warm))
    joint = {c: np.hstack([temp.columns.get(c, np.zeros((n, kt))), warm.columns.get(c, np.zeros((n, kw)))])
             for c in set(temp.columns) | set(warm.columns)}
    setup = fixture._setup(case, joint, resid, slow=True, model=model)
    if setup is None:
        return None
    weights, _, tilt, eff, raw, w, prior = setup[:7]
    rows = case.cache.get("fixture_gyro_offset_rows")
    if rows is not None:  # a slow curve's gyro offsets stay free, as in its own test (fixture._given)
        prior = Prior(prior, prior.charged & ~rows)
    rss = [fixture._fit_tilts(case, weights, tilt, raw, w, prior, x)[0]
           for x in (None, eff[:, :kt], eff[:, kt:], eff)]
    return {"temperature_bias": rss[0] - rss[1], "warmup_drift": rss[0] - rss[2],
            "temperature_bias|other": rss[2] - rss[3], "warmup_drift|other": rss[1] - rss[3]}


def decide_on_holds(case, temp, warm, resid: np.ndarray, model=None) -> None:
    """On a fixture, rank the two slow curves by :func:`pair_on_holds`: one below its threshold given the other (and
    the tilts) ranks below it; if each is below given the other, the one that explains more of the holds alone
    ranks first; if both stand given each other, nothing changes. One the fixture's tilts took (not identifiable)
    is a rival too: the other, below its threshold given it, is not ranked either (the two are treated alike)."""
    got = pair_on_holds(case, temp, warm, resid, model)
    if got is None:
        return
    pair = {"temperature_bias": (temp, warm), "warmup_drift": (warm, temp)}
    below = {e: got[e + "|other"] < c.threshold for e, (c, _) in pair.items()}
    if below["temperature_bias"] == below["warmup_drift"]:
        if not below["temperature_bias"]:
            return  # each stands given the other: both may be present
        loser = min(pair, key=lambda e: got[e] - pair[e][0].threshold)
    else:
        loser = next(e for e in pair if below[e])
    lose, win = pair[loser]
    said = (f"on the fixture's holds, given {win.effect} and each hold's tilt (one weighting for both), its "
            f"likelihood ratio is {got[loser + '|other']:.4g} against the threshold {lose.threshold:.3g}; "
            f"{win.effect} given it: {got[win.effect + '|other']:.4g} against {win.threshold:.3g}")
    if win.identifiable is False and lose.identifiable is not False:
        lose.identifiable, lose.reason = False, "; ".join(filter(None, [lose.reason, (
            f"{fixture.NOT_SEPARABLE}: {said}, and {win.effect} is not separable from the fixture's tilts; not "
            "ranked")]))
        return
    if win.identifiable is False or lose.identifiable is False:
        return
    top = win.rank if win.rank is not None else win.stat - win.threshold
    own = lose.rank if lose.rank is not None else lose.stat - lose.threshold
    lose.rank = min(own, got[loser + "|other"] - lose.threshold, top - 1.0)
    lose.reason = "; ".join(filter(None, [lose.reason, f"{said}: ranked below {win.effect}"]))


def _found_walk_k2(case, by: dict, model) -> np.ndarray:
    """Each gyro's found walk K^2 ((rad/s)^2/s): this pass's significant ``bias_random_walk`` candidate's, or the one
    an earlier pass put in ``model`` beyond the user's stated walk; zeros if none."""
    from imu_sim.diagnose.case import effective_model
    walk = by.get("bias_random_walk")
    if walk is not None and walk.significant and walk.params:
        return np.array([float(walk.params.get(f"gyro_rad_per_s_per_sqrt_s[{a}]", 0.0)) ** 2 for a in "xyz"])
    if model is None:
        return np.zeros(3)
    k = np.asarray(effective_model(model).gyro.rate_random_walk, float) * np.ones(3)
    k0 = np.asarray(effective_model(case.model).gyro.rate_random_walk, float) * np.ones(3)
    return np.where(k > k0, k * k - k0 * k0, 0.0)


def _on_axes(threshold: float, k: int, axes: int) -> float:
    """A threshold of ``k`` parameters moved to ``axes`` of them at the same false-alarm rate."""
    return float(chi2.isf(chi2.sf(threshold, k), axes))


def walk_or_temperature(case, by: dict, resid: np.ndarray | None, model=None) -> bool:
    """A significant temperature curve on a fixture's holds that a found bias random walk explains: both explain the
    holds' slow level changes, so they are weighed on the gyros' hold means on one weighting
    (:func:`hold_noise.walk_and_temperature`); where the temperature given the walk is below its threshold and the
    walk given the temperature above its own, the temperature is not significant on the holds and not ranked
    (own consumer fixture walk at 1.5 times its floor: ``temperature_bias`` first on 6 of 10 seeds, its
    coefficients 0.2-0.8 mrad/s/degC on a unit with none). True when it took the temperature out."""
    temp = by.get("temperature_bias")
    if resid is None or temp is None or not temp.significant or temp.identifiable is False:
        return False
    k2 = _found_walk_k2(case, by, model)
    got = walk_and_temperature(case, model if model is not None else case.model, resid, k2)
    if got is None:
        return False
    thr_t = _on_axes(temp.threshold, 6, got["axes"])  # six coefficients, one a channel
    walk = by.get("bias_random_walk")
    thr_w = _on_axes(walk.threshold if walk is not None else temp.threshold, 6, got["axes"])
    if got["temperature|walk"] >= thr_t or got["walk|temperature"] < thr_w:
        return False
    temp.given_rivals["bias_random_walk"] = min(temp.given_rivals.get("bias_random_walk", np.inf),
                                                got["temperature|walk"])
    temp.identifiable, temp.reason = False, "; ".join(filter(None, [temp.reason, (
        f"not significant on the holds given bias_random_walk: on the gyros' hold means (one weighting for both) its "
        f"likelihood ratio given the walk is {got['temperature|walk']:.3g} against {thr_t:.3g} "
        f"({got['axes']} axes), the walk's given it {got['walk|temperature']:.3g} against {thr_w:.3g}; a slow wander "
        "explains the same levels; not ranked")]))
    return True


MIMICS = {"earth_rotation": ("gyro_g_sensitivity",)}
"""Effects whose free parameters can reproduce a known constant's pattern on some records: on an up/down, the Earth
rate's vertical part flips with gravity, which a g-sensitivity k = Omega sin(lat) / g makes on every axis."""
MIMIC_FRACTION = 0.5
"""Share of a known constant's hold-to-hold pattern (each channel's level free) a rival's columns can reproduce
beyond which the rival mimics it on this record."""


def mimicked_fraction(case, constant, rival) -> float:
    """The share (0..1) of ``constant``'s pattern over the stated samples (each channel demeaned: the turn-on bias is
    free) that a least-squares fit of ``rival``'s columns reproduces; 0 without columns."""
    if not (constant.columns and rival.columns):
        return 0.0
    keep = reference.stated_samples(case)
    k = next(iter(rival.columns.values())).shape[1]
    chans = sorted(constant.columns)
    r = np.concatenate([constant.columns[c][keep, 0] - constant.columns[c][keep, 0].mean() for c in chans])
    x = np.vstack([rival.columns[c][keep] - rival.columns[c][keep].mean(axis=0) if c in rival.columns
                   else np.zeros((int(keep.sum()), k)) for c in chans])
    den = float(r @ r)
    if den <= 0 or not np.any(x):
        return 0.0
    fit = x @ np.linalg.lstsq(x, r, rcond=None)[0]
    return float(fit @ fit / den)


def constant_before_mimic(case, by: dict, model=None) -> None:
    """A significant known constant (zero free parameters) is fitted before a significant rival that mimics its
    pattern here (:data:`MIMICS`, :func:`mimicked_fraction`), which is then tested given it in the next pass: its
    free parameters can always take what the constant explains (blind seed 9's navigation up/down: the left-out
    Earth rate LR 2.7e4, a g-sensitivity with equal y and z coefficients, Omega sin(lat) / g, LR 6.8e4, named first).
    The constant's own ranking (and its interval) is unchanged; only the rival ranks below it. A g-sensitivity that
    is the left-out Earth rate's vertical part by value (:func:`earth_rate_vertical`; ``model`` the pass's, without
    the Earth rate) is not ranked at all, whether the constant's own pattern (its horizontal part placed by the
    stated heading) is significant or not, and in every pass (a constant fitted and not kept, or reported as
    reference_or_model_error, is no longer a candidate)."""
    gs = by.get("gyro_g_sensitivity")
    if (gs is not None and gs.significant and model is not None and not model.has_physics("earth_rotation")
            and (said := earth_rate_vertical(case, gs))):  # in any pass while the Earth rate is left out
        gs.identifiable, gs.reason = False, "; ".join(filter(None, [gs.reason, said]))
    for name, rivals in MIMICS.items():
        const = by.get(name)
        if const is None or not const.significant or const.identifiable is False:
            continue  # in the model (its mimic tested given it), or not significant
        top = const.rank if const.rank is not None else const.stat - const.threshold
        for rival in [by.get(r) for r in rivals]:
            if rival is None or not rival.significant or rival.identifiable is False:
                continue
            share = mimicked_fraction(case, const, rival)
            own = rival.rank if rival.rank is not None else rival.stat - rival.threshold
            if share < MIMIC_FRACTION or own < top:
                continue
            rival.rank = top - 1.0
            rival.reason = "; ".join(filter(None, [rival.reason, (
                f"it reproduces {100 * share:.3g} % of the known constant {name}'s pattern on this record: the "
                f"constant (zero free parameters) is fitted first and {rival.effect} tested given it")]))


def earth_rate_vertical(case, gsens) -> str:
    """The note when a g-sensitivity fitted on a record whose user's model leaves out the Earth rate is that rate's
    vertical part (every identified coefficient's 95 % interval holds Omega sin(lat) / g, the same on every axis:
    on a still hold the Earth rate's vertical part is that times the specific force); '' otherwise. Its
    horizontal part, which a stated heading off the true one misplaces, is then the reference's error: an up/down
    turned about north with its heading stated 10-30 deg off (own ``fx_earth_rotation_updown_heading``) or blind
    seed 9's navigation up/down (y and z -1.77e-6 rad/s per m/s^2: latitude -14 deg) named the g-sensitivity."""
    from nav_core.earth import RATE, normal_gravity
    lat = getattr(getattr(case, "scenario", None), "latitude_deg", None)
    if lat is None or not gsens.intervals:
        return ""
    k0 = RATE * np.sin(np.radians(lat)) / float(normal_gravity(np.radians(lat), 0.0))
    ivs = [gsens.intervals[m] for m in gsens.params if m in gsens.intervals and "gyro_coeff" in m]
    if not ivs or not all(lo <= k0 <= hi for lo, hi in ivs) or all(lo <= 0.0 <= hi for lo, hi in ivs):
        return ""  # not that value, or not told from 0
    return ("it is the left-out Earth rate's vertical part: every coefficient's 95 % interval holds "
            f"Omega sin(lat) / g = {k0:.4g} rad/s per m/s^2 (latitude {lat:g} deg), which the Earth rate makes on a "
            "still hold; a known constant, not sensor physics (its horizontal part not matching: the stated heading "
            "or the reference); not ranked")
