"""GNSS-side diagnosis on synthetic fix residuals: latency recovered, coloured noise not taken for latency."""
import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from imu_sim.diagnose import gnss_tests as gt
from imu_sim.errors import gauss_markov
from nav_core.sensor_model import SensorModel, TriadModel

N, DT = 900, 1.0


def _residual(seed, latency_s=0.0, colored_sigma=0.0, arm=(0.0, 0.0, 0.0), speed_mps=8.0):
    """A drive with turns and speed changes (``speed_mps`` +- half of it); residual = -v L + C_nb l + white (0.5 m) +
    Gauss-Markov (30 s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    speed = speed_mps * (1 + 0.5 * np.sin(2 * np.pi * t / 97.0) * (np.sin(2 * np.pi * t / 241.0) > -0.3))
    yaw = np.cumsum(np.where(np.sin(2 * np.pi * t / 61.0) > 0.7, 0.15, 0.0))
    vel = np.column_stack([speed * np.cos(yaw), speed * np.sin(yaw), np.zeros(N)])
    rot = Rotation.from_euler("z", yaw[:, None]).as_matrix()
    r = -vel * latency_s + rot @ np.asarray(arm, float) + rng.standard_normal((N, 3)) * [0.5, 0.5, 1.0]
    if colored_sigma:
        r += gauss_markov(N, DT, np.full(3, colored_sigma), np.full(3, 30.0), rng)
    return gt.GnssResidual(t, r, DT, vel, rot, np.array([0.5, 0.5, 1.0]), np.zeros(3), 60.0, t)


LATENCY_SEEDS = range(64)


def test_latency_interval_covers_the_truth():
    # A 95 % interval misses on 5 % of seeds by construction, so coverage is asserted over fixed seeds against the
    # binomial distribution (a count this low has probability 0.001 when the interval is exact), and the spread of
    # the standardised errors against chi-square (an interval too wide or too narrow by ~25 % fails). Over seeds
    # 0..399 the measured coverage is 95.25 % and the standardised error's sd 0.996.
    z = []
    for seed in LATENCY_SEEDS:
        gr = _residual(seed, latency_s=0.04)
        fit, _, _ = gt.gls_whiteness_first(gr, gt.design_latency(gr))
        z.append((fit.theta[0] - 0.04) / np.sqrt(fit.cov[0, 0]))
        assert fit.lr > 10, f"seed {seed}: latency of 40 ms not detected (LR {fit.lr:.1f})"
    z, n = np.array(z), len(LATENCY_SEEDS)
    inside = int(np.sum(np.abs(z) < stats.norm.isf(0.025)))
    assert inside >= stats.binom.ppf(0.001, n, 0.95), f"95 % interval covered the truth on {inside} of {n} seeds"
    lo, hi = stats.chi2.ppf(0.001, n) / n, stats.chi2.isf(0.001, n) / n
    assert lo <= np.mean(z ** 2) <= hi, f"mean squared standardised error {np.mean(z ** 2):.2f} not in {lo:.2f}..{hi:.2f}"


def test_coloured_noise_is_not_taken_for_latency():
    white_model, whiteness_first, coloured = [], [], []
    for seed in range(60):
        gr = _residual(seed, colored_sigma=0.6)
        design = gt.design_latency(gr)
        psd = gt.model_psd(gr, np.fft.rfftfreq(len(gr.r), gr.dt))
        white_model.append(gt.gls(gr.r, design, psd, gr.dt).lr)
        fit, _, found = gt.gls_whiteness_first(gr, design)
        whiteness_first.append(fit.lr)
        coloured.append(found)
    threshold = 8.7  # chi-square(1) at 0.05 / 16, the uncalibrated latency threshold
    assert np.mean(coloured) > 0.95
    assert np.mean(np.array(whiteness_first) > threshold) <= 0.05
    assert np.mean(np.array(white_model) > threshold) >= 0.3


def test_lever_arm_z_is_not_identifiable_on_a_level_drive():
    gr = _residual(3, arm=(0.8, -0.5, 0.6))
    fit, _, _ = gt.gls_whiteness_first(gr, gt.design_lever_arm(gr))
    assert list(fit.used) == [0, 1]
    sd = np.sqrt(np.diag(fit.cov)[:2])
    assert np.all(np.abs(fit.theta[:2] - [0.8, -0.5]) < 4 * sd)


def test_a_lever_arm_and_a_latency_are_each_needed_given_the_other_on_a_car_at_speed():
    """At 16 m/s a latency's standard error (s) is over ten times smaller than a lever arm's (m): the joint fit of
    both compared them across units and dropped the whole arm, so the arm's LR given the latency was 0 on every seed
    and a forward antenna could only be named a latency (blind seed 9's tactical drive: 57 ms for an arm of
    (-0.76, 0.12, 0.92) m). Standard errors are compared within an effect: each is needed given the other only where
    it is the truth (10 seeds each; thresholds 13.8 for the arm's 3 degrees of freedom, 8.7 for the latency)."""
    for kw, need, other in (({"arm": (-0.76, 0.12, 0.92)}, "gps_lever_arm", "gps_latency"),
                            ({"latency_s": 0.057}, "gps_latency", "gps_lever_arm")):
        cond = [gt.conditional_lrs(_residual(seed, speed_mps=16.0, **kw)) for seed in range(10)]
        thr = {"gps_lever_arm": 13.8, "gps_latency": 8.7}
        assert sum(c[need] > thr[need] for c in cond) >= 9, (need, cond)
        assert sum(c[other] > thr[other] for c in cond) <= 1, (need, cond)


def test_colored_fit_finds_the_correlation_time():
    gr = _residual(5, colored_sigma=1.0)
    col = gt.colored_fit(gr.r, gr)
    assert col.tau_ci[0] <= 30.0 <= col.tau_ci[1] * 1.5 and col.lr > 100


def test_drop_one_share_is_what_the_joint_fit_loses_without_each_finding(monkeypatch):
    """Two findings that explain the same part of the residual each get only what the other cannot explain; a
    noise finding (no deterministic output) keeps its own energy; shares follow the drop-one energies."""
    from types import SimpleNamespace

    from nav_core.sensor_model import SensorModel, TriadModel

    from imu_sim.diagnose import case as case_mod, share
    from imu_sim.diagnose.candidate import Candidate

    rng = np.random.default_rng(3)
    n = 4000
    noise = rng.standard_normal((n, 6))
    step = np.zeros((n, 6))
    step[n // 2:, 0] = 0.5  # what both "effects" explain
    own = np.zeros((n, 6))
    own[:, 3] = 0.3 * np.sin(np.arange(n) / 50.0)  # what only the misalignment explains

    def fake_residual(case, model):
        phys = model.physics or {}
        out = noise + step + own
        if "scale_factor" in phys or "axis_misalignment" in phys:
            out = out - step  # either one alone explains the step
        if "axis_misalignment" in phys:
            out = out - own
        return out

    monkeypatch.setattr(case_mod, "residual", fake_residual)
    base = SensorModel(gyro=TriadModel(), accel=TriadModel(), sample_rate_hz=50.0, physics={})
    final = base.with_physics("scale_factor").with_physics("axis_misalignment").with_physics("gauss_markov_bias")
    cands = [Candidate("scale_factor", 1, 0, ""), Candidate("axis_misalignment", 1, 0, ""),
             Candidate("gauss_markov_bias", 1, 0, "", kind="noise")]
    findings = [{"mismatch_energy": 1000.0}, {"mismatch_energy": 400.0}, {"mismatch_energy": 50.0}]
    drops = share.drop_one(SimpleNamespace(), final, base, findings, cands)
    own_energy = np.sum(own[:, 3] ** 2)  # unit noise variance
    assert drops[0] == pytest.approx(0.0, abs=1e-6)  # the misalignment still explains the step without it
    assert drops[1] == pytest.approx(own_energy, rel=0.1)  # only its own part: the step is the scale factor's too
    assert drops[2] == 50.0
    assert share.shares(drops)[0] == 0.0 and share.shares(drops)[1] == pytest.approx(drops[1] / (drops[1] + 50.0))


def test_coloured_fix_error_a_smoothed_truth_can_carry_is_not_separable_and_motion_regressors_go_first():
    from imu_sim.diagnose import reference
    from imu_sim.diagnose.candidate import Candidate
    from imu_sim.diagnose.engine import _deterministic_first

    def coloured(lows):
        c = Candidate("colored_gps_noise", 100.0, 20.0, "", kind="gnss")
        for a, lo in zip("enu", lows):
            c.params[f"sigma_m[{a}]"], c.intervals[f"sigma_m[{a}]"] = lo + 0.1, [lo, lo + 0.2]
        return c

    # 0.5 m vertical at 95 % is inside a smoothed track's own height error (2 x 0.3 m); 0.4 m east is not
    assert "not separable from the reference" in reference.colored_fix_note(coloured([0.2, 0.25, 0.5]))
    assert reference.colored_fix_note(coloured([0.4, 0.1, 0.1])) == ""
    latency = Candidate("gps_latency", 30.0, 8.7, "", kind="gnss")
    assert _deterministic_first([coloured([1.0, 1.0, 1.0]), latency]) is latency


def test_rotation_of_the_truth_attitude_is_its_columns_times_the_angles():
    from types import SimpleNamespace

    from imu_sim.diagnose import reference

    rng = np.random.default_rng(5)
    gyro, accel = rng.normal(0, 0.3, (200, 3)), rng.normal(0, 2.0, (200, 3)) + [0, 0, 9.8]
    d = np.array([2e-4, -3e-4, 1e-3])  # rad
    cols = reference.rotation_columns(SimpleNamespace(gyro_true=gyro, accel_true=accel))
    for c in range(6):
        x = (gyro, accel)[c // 3]
        rotated = Rotation.from_rotvec(d).apply(x)[:, c % 3]
        np.testing.assert_allclose(cols[c] @ d, rotated - x[:, c % 3], atol=1e-5 * np.abs(x).max())


def test_known_constant_is_scored_held_out_at_its_value_not_trained():
    from imu_sim.diagnose import metrics

    rng = np.random.default_rng(9)
    n, dt = 2400, 0.1  # 240 s, 1-s blocks
    x = np.where((np.arange(n) // 300) % 2 == 0, 1.0, -1.0)[:, None]  # the constant's regressor
    resid = np.column_stack([x[:, 0] * 1.0 + 0.3 + rng.normal(0, 1.0, n)])
    before, fixed = metrics.heldout_rms(resid, {0: x}, dt, 1.0, fixed=[1.0])
    m = 10
    yb, xb = resid[:, 0].reshape(-1, m).mean(axis=1), x[:, 0].reshape(-1, m).mean(axis=1)
    chunk = (np.arange(len(yb)) * 10) // len(yb)
    train, test = chunk % 2 == 0, chunk % 2 == 1
    bias = np.mean(yb[train] - xb[train])
    expected = np.sqrt(np.mean((yb[test] - xb[test] - bias) ** 2) / metrics.robust_var(yb))
    assert fixed == pytest.approx(expected)
    assert fixed < before


def _wandering_truth_case(seed: int = 4, n: int = 12000, dt: float = 0.02):
    """A car-like truth (turns, speed changes) whose attitude the reference gets wrong by a slow rotation d(t) of a
    few hundredths of a degree: (case, residual of that error plus white noise, the true rates and forces)."""
    from types import SimpleNamespace
    rng = np.random.default_rng(seed)
    t = dt * np.arange(1, n + 1)
    yaw_rate = 0.15 * np.sin(2 * np.pi * t / 23.0) ** 3
    gyro = np.column_stack([0.01 * np.sin(t / 3.0), 0.005 * np.cos(t / 5.0), yaw_rate])
    accel = np.column_stack([1.5 * np.sin(2 * np.pi * t / 17.0), 10.0 * yaw_rate, np.full(n, 9.81)])
    d = np.column_stack([np.radians(0.03) * np.sin(2 * np.pi * t / p + ph) for p, ph in ((140, 0), (90, 1), (200, 2))])
    err = np.column_stack([np.cross(d, gyro), np.cross(d, accel)])
    sd = np.array([1.5e-6, 1.5e-6, 1.5e-6, 2e-5, 2e-5, 2e-5]) / np.sqrt(dt)
    resid = err + rng.standard_normal((n, 6)) * sd
    case = SimpleNamespace(t=t, n=n, dt=dt, gyro_true=gyro, accel_true=accel, cache={"moving_file_truth": True},
                           scenario=SimpleNamespace(source="trajectory"))
    return case, resid, sd


def _ctx(case, resid, sd):
    from types import SimpleNamespace

    from imu_sim.diagnose.spectral import Whitener
    from imu_sim.diagnose import reference
    psd = np.repeat((sd**2 * case.dt)[:, None], case.n // 2 + 1, axis=1)
    psd = reference.with_reference_error(case, resid, psd)  # as the tests weight a moving truth's residual
    model = SensorModel(gyro=TriadModel(white_noise=sd[:3] * np.sqrt(case.dt)),
                        accel=TriadModel(white_noise=sd[3:] * np.sqrt(case.dt)), sample_rate_hz=1.0 / case.dt)
    return SimpleNamespace(case=case, model=model, resid=resid, wh=Whitener.from_psd(psd, resid, case.dt),
                           resid_f=np.fft.rfft(resid, axis=0))


def test_a_reference_whose_attitude_wanders_is_not_a_scale_factor_and_leaves_a_known_constant_at_its_value():
    """A navigation-grade drive against a truth smoothed from GNSS: the truth's slowly varying attitude error makes
    scale-factor-shaped residuals far above their threshold; given the slow reference error they are not separable,
    a real scale factor still is, and a known constant fitted with it comes back at its value."""
    from types import SimpleNamespace

    from imu_sim.diagnose import reference
    from imu_sim.diagnose.spectral import gls
    case, resid, sd = _wandering_truth_case()
    true = np.column_stack([case.gyro_true, case.accel_true])  # scale factors of 5 channels (az is constant)
    cols = {c: np.column_stack([true[:, c] if j == c else np.zeros(case.n) for j in range(5)]) for c in range(5)}
    sf = SimpleNamespace(effect="scale_factor", significant=True, columns=cols, threshold=22.4)
    ctx = _ctx(case, resid, sd)
    assert gls(ctx.wh, ctx.resid_f, cols, 5).lr > 1000  # alone: the truth's attitude error looks like scale factors
    assert "not separable from the reference" in reference.slow_reference_note(ctx, sf)
    real = resid + np.column_stack([np.zeros((case.n, 2)), 5e-4 * case.gyro_true[:, 2], np.zeros((case.n, 3))])
    assert reference.slow_reference_note(_ctx(case, real, sd), sf) == ""
    # a known constant (regressor: a shaped horizontal force, like 2 Omega x v) left out of the model
    shape = 2e-3 * np.column_stack([np.sin(2 * np.pi * case.t / 17.0), np.cos(2 * np.pi * case.t / 29.0)])
    known = resid + np.column_stack([np.zeros((case.n, 3)), shape, np.zeros(case.n)])
    kc = SimpleNamespace(effect="coriolis", constant_scale=0.0, identifiable=True, stat=0.0, threshold=8.7,
                         reason="", columns={3: shape[:, [0]], 4: shape[:, [1]]})
    reference.constant_given_slow_reference(_ctx(case, known, sd), kc)
    lo, hi = kc.intervals["coriolis_scale"]
    assert lo < 1.0 < hi and hi - lo < 1.0 and kc.stat > kc.threshold and "given it" in kc.reason


def test_a_mounting_tilt_on_a_rate_table_is_not_an_axis_misalignment_but_a_larger_misalignment_is():
    """On a level one-axis table a tilt of the unit's mounting (within attitude_tolerance_deg) makes the residual of a
    gyro x-z misalignment; it is not separable from the reference, a misalignment beyond the tolerance still is."""
    from types import SimpleNamespace

    from imu_sim.diagnose import mounting
    rng = np.random.default_rng(5)
    n, dt = 8000, 0.02
    t = dt * np.arange(1, n + 1)
    rate = np.radians(30.0) * np.sign(np.sin(2 * np.pi * t / 12.0))
    gyro = np.column_stack([np.zeros(n), np.zeros(n), rate])
    accel = np.column_stack([np.zeros(n), np.zeros(n), np.full(n, 9.81)])
    spec = [{"t0": 0.0, "t1": 160.0, "rate_dps": 30.0}]
    case = SimpleNamespace(t=t, n=n, dt=dt, gyro_true=gyro, accel_true=accel, cache={"moving_file_truth": False},
                           scenario=SimpleNamespace(source="static_segments", spec=spec, attitude_tolerance_deg=0.05))
    sd = np.array([2e-6, 2e-6, 2e-6, 2e-5, 2e-5, 2e-5]) / np.sqrt(dt)
    noise = rng.standard_normal((n, 6)) * sd
    cols = {0: np.column_stack([rate, np.zeros(n)]), 1: np.column_stack([np.zeros(n), rate])}  # gyro x-z, y-z
    for tilt, separable in ((np.radians(0.04), False), (np.radians(0.2), True)):
        mis = SimpleNamespace(effect="axis_misalignment", significant=True, identifiable=True, columns=dict(cols),
                              threshold=38.5, params={"gyro[xz]": 0.0, "gyro[yz]": 0.0}, reason="", design=None,
                              channels=[], rank=None, stat_alone=None, mounting_theta=None, stat=1e6)
        d = np.array([0.3 * tilt, tilt, 0.0])  # a tilt about y and a little about x
        resid = noise + np.column_stack([np.cross(d, gyro), np.cross(d, accel)])
        ctx = _ctx(case, resid, sd)
        ctx.m_tests, ctx.factor = 14, lambda e: 1.0
        mounting.mounting_fit(ctx, mis)  # a hand-mounted table: the mounting is fitted with the candidate
        assert mis.identifiable == separable, mis.reason
        if not separable:
            assert "mounting" in mis.reason and "attitude_tolerance_deg" in mis.reason


def _mounted_table(mis, tilts, seed=3, table_tilt=0.0, accel_wander=0.0, off_axis=None):
    """A consumer unit on a one-axis table in three mountings (body z, x, y up; 60 s each, +-30/60 deg/s), each
    tilted by its own small rotation, the table's axis tilted from the vertical by ``table_tilt`` rad (gravity in the
    body axes turns with the table angle) and each mounting's accelerometer bias off by ``accel_wander`` m/s^2 (sd,
    stated as the model's bias instability), each mounting's sensing centre ``off_axis`` (3, 3) m off the table's axis
    (body axes: dw/dt x r + w x (w x r) on the accelerometers); residual = the tilts (w x d, f x d) + the gyro
    misalignment ``mis`` (3, 3) + one accelerometer turn-on bias + white noise. Returns (case, resid, sd, candidate of
    both triads)."""
    from types import SimpleNamespace
    rng = np.random.default_rng(seed)
    dt, per = 0.02, 3000
    t = dt * np.arange(1, 3 * per + 1)
    w = np.radians(np.tile(np.repeat([30.0, -30.0, 60.0, -60.0, 30.0], per // 5), 3))
    psi = np.cumsum(w) * dt
    table = Rotation.from_rotvec([table_tilt * 0.6, table_tilt * 0.8, 0.0]).as_matrix()
    nominal = Rotation.from_euler("z", psi[:, None]).as_matrix() @ np.repeat(
        Rotation.from_euler("xyz", [[0, 0, 0], [0, -90, 0], [90, 0, 0]], degrees=True).as_matrix(), per, axis=0)
    up = np.array([0.0, 0.0, 1.0])
    gyro = np.einsum("nji,j->ni", nominal, up) * w[:, None]  # the spin (up) axis in body axes, times the rate
    accel = np.einsum("nji,j->ni", nominal, 9.81 * up)
    spec = [{"t0": 60.0 * k, "t1": 60.0 * (k + 1), "roll_deg": r, "pitch_deg": p, "rate_dps": 30.0}
            for k, (r, p) in enumerate([(0.0, 0.0), (0.0, -90.0), (90.0, 0.0)])]
    model = SimpleNamespace(accel=SimpleNamespace(bias_instability=accel_wander, rate_random_walk=0.0))
    case = SimpleNamespace(t=t, n=len(t), dt=dt, gyro_true=gyro, accel_true=accel, cache={"body_to_enu": nominal},
                           unstated=None, model=model,
                           scenario=SimpleNamespace(source="static_segments", spec=spec, attitude_tolerance_deg=1.0))
    sd = np.array([1e-3, 1e-3, 1e-3, 5e-3, 5e-3, 5e-3]) / np.sqrt(dt)
    d = np.repeat(tilts, per, axis=0)
    resid = rng.standard_normal((len(t), 6)) * sd + np.column_stack([np.cross(d, gyro), np.cross(d, accel)])
    resid[:, 3:] += np.einsum("nji,j->ni", nominal, table.T @ (9.81 * up)) - accel  # gravity off the table's axis
    resid[:, 3:] += np.repeat(rng.standard_normal((3, 3)) * accel_wander, per, axis=0)
    resid[:, :3] += gyro @ mis.T
    resid[:, 3:] += [0.05, -0.08, 0.03]
    if off_axis is not None:
        r = np.repeat(off_axis, per, axis=0)
        resid[:, 3:] += np.cross(np.gradient(gyro, dt, axis=0), r) + np.cross(gyro, np.cross(gyro, r))
    names, cols = [], {c: np.zeros((len(t), 12)) for c in range(6)}
    for tri, true in enumerate((gyro, accel)):
        for i in range(3):
            for j in [j for j in range(3) if j != i]:
                cols[3 * tri + i][:, len(names)] = true[:, j]
                names.append(f"{('gyro', 'accel')[tri]}[{'xyz'[i]}{'xyz'[j]}]")
    cand = SimpleNamespace(effect="axis_misalignment", identifiable=True, significant=True, columns=cols,
                           params=dict.fromkeys(names, 0.0), stat=1e6, threshold=40.0, reason="", design=None,
                           refit=None, stat_alone=None, mounting_theta=None, contrib=None, physics=None, channels=[],
                           rank=None)
    return case, resid, sd, cand


def test_a_mounted_tables_intervals_carry_each_mountings_tilt_and_the_accelerometers_pin_it():
    """Three hand mountings, each tilted by up to 1 deg, on a table whose axis is off the vertical, the
    accelerometers' bias wandering between mountings: the gyro misalignment (5 mrad) is fitted jointly with each
    mounting's rotation, the table's tilt and each mounting's accelerometer offset - the accelerometers'
    misalignment taken as the model's, their view of each mounting's tilt (against one turn-on bias, within the
    stated wander) separates it - so its intervals cover; the tilts alone (a null) are not separable."""
    from types import SimpleNamespace

    from imu_sim.diagnose import mounting
    tilts = np.radians([[0.8, -0.6, 0.3], [-0.7, 0.9, -0.5], [0.6, 0.4, -0.9]])
    mis = np.array([[0, 5e-3, -4e-3], [4.5e-3, 0, 5.5e-3], [-5e-3, 3.5e-3, 0]])
    for m, effect in ((mis, True), (np.zeros((3, 3)), False)):
        # the table's axis 0.25 deg off the vertical, the accelerometers wandering 0.02 m/s^2 between mountings: each
        # took the null's gyro misalignment above its threshold (the accelerometers' mean over a mounting pins its tilt)
        case, resid, sd, cand = _mounted_table(m, tilts, table_tilt=np.radians(0.25), accel_wander=0.02)
        ctx = _ctx(case, resid, sd)
        ctx.m_tests, ctx.factor = 14, lambda e: 1.0
        mounting.mounting_fit(ctx, cand)
        assert list(cand.params) == [nm for nm in cand.params if nm.startswith("gyro")] and len(cand.params) == 6
        assert (cand.stat > cand.threshold) == effect and cand.identifiable == effect, (cand.stat, cand.reason)
        if effect:
            true = {f"gyro[{'xyz'[i]}{'xyz'[j]}]": m[i, j] for i in range(3) for j in range(3) if i != j}
            assert all(lo <= true[k] <= hi for k, (lo, hi) in cand.intervals.items()), (cand.params, cand.intervals)
        else:
            assert "not separable" in cand.reason and "mountings" in cand.reason


def test_a_unit_off_the_tables_axis_is_no_gyro_misalignment_and_a_true_one_still_covers():
    """Each hand mounting's sensing centre 5 cm off the table's axis: the centripetal acceleration w x (w x r) is a
    different step on the accelerometers at each dwell rate, which pulled each mounting's tilt (pinned by the
    accelerometers) away from the gyros' and was fitted as a gyro misalignment (own short tables 5 cm off: the
    industrial null's axis_misalignment at LR 3.7e4). With each mounting's offset a nuisance of the fit the null is
    not separable from the reference and a true misalignment's intervals still cover."""
    from imu_sim.diagnose import mounting
    tilts = np.radians([[0.8, -0.6, 0.3], [-0.7, 0.9, -0.5], [0.6, 0.4, -0.9]])
    off = np.array([[0.05, -0.04, 0.03], [-0.03, 0.05, 0.04], [0.04, 0.02, -0.05]])
    mis = np.array([[0, 5e-3, -4e-3], [4.5e-3, 0, 5.5e-3], [-5e-3, 3.5e-3, 0]])
    for m, effect in ((mis, True), (np.zeros((3, 3)), False)):
        case, resid, sd, cand = _mounted_table(m, tilts, off_axis=off)
        ctx = _ctx(case, resid, sd)
        ctx.m_tests, ctx.factor = 14, lambda e: 1.0
        mounting.mounting_fit(ctx, cand)
        assert (cand.stat > cand.threshold) == effect and cand.identifiable == effect, (cand.stat, cand.reason)
        if effect:
            true = {f"gyro[{'xyz'[i]}{'xyz'[j]}]": m[i, j] for i in range(3) for j in range(3) if i != j}
            assert all(lo <= true[k] <= hi for k, (lo, hi) in cand.intervals.items()), (cand.params, cand.intervals)


def test_a_one_axis_tables_scale_factor_is_refitted_with_its_mounting_without_the_axes_it_cannot_see(monkeypatch):
    """One mounting, spinning about z: the gyro x/y scale factors (seen only through the Earth rate's horizontal part)
    are not identifiable, and the engine refits without them - the joint fit with the mounting again, so gyro z's
    scale factor stays a finding (own long industrial table, seed 7002: significant at LR 2811, the whole effect was
    dropped because the joint fit had no refit) - and the fixture's per-hold tilt fit, which evaluate() applies
    before the mountings, does not overwrite that refit (own tactical long table 7001: 4.05e-5 [3.78e-5, 4.31e-5]
    for 7e-5 after the refit, 6.87e-5 [6.61e-5, 7.14e-5] before it)."""
    from types import SimpleNamespace

    from imu_sim.diagnose import engine, mounting
    from imu_sim.diagnose.candidate import Candidate
    rng = np.random.default_rng(11)
    n, dt = 8000, 0.02
    t = dt * np.arange(1, n + 1)
    rate = np.radians(30.0) * np.sign(np.sin(2 * np.pi * t / 16.0))
    psi = np.cumsum(rate) * dt
    gyro = np.column_stack([5e-5 * np.cos(psi), -5e-5 * np.sin(psi), rate])
    accel = np.column_stack([np.zeros(n), np.zeros(n), np.full(n, 9.81)])
    spec = [{"t0": 0.0, "t1": 160.0, "rate_dps": 30.0}]
    case = SimpleNamespace(t=t, n=n, dt=dt, gyro_true=gyro, accel_true=accel, cache={}, unstated=None,
                           scenario=SimpleNamespace(source="static_segments", spec=spec, attitude_tolerance_deg=0.5))
    sd = np.array([2e-4, 2e-4, 2e-4, 1e-3, 1e-3, 1e-3]) / np.sqrt(dt)
    d = np.radians([0.3, -0.2, 0.1])
    resid = rng.standard_normal((n, 6)) * sd + np.column_stack([np.cross(d, gyro), np.cross(d, accel)])
    resid[:, 2] += 7e-4 * rate
    true = np.column_stack([gyro, accel])
    names = [f"{tri}[{a}]" for tri in ("gyro", "accel") for a in "xyz"]
    cand = Candidate("scale_factor", 1e6, 40.0, "GLS likelihood ratio", params=dict.fromkeys(names, 0.0),
                     columns={c: np.column_stack([true[:, c] if j == c else np.zeros(n) for j in range(6)])
                              for c in range(6)})
    ctx = _ctx(case, resid, sd)
    ctx.m_tests, ctx.factor = 14, lambda e: 1.0
    mounting.mounting_fit(ctx, cand)
    assert list(cand.params) == ["gyro[x]", "gyro[y]", "gyro[z]"] and cand.significant
    vague = [{"parameter": p} for p in ("gyro[x]", "gyro[y]")]
    again = engine._refit_without(cand, vague, "industrial")
    assert again is not None and list(again.params) == ["gyro[z]"] and again.significant, again
    lo, hi = again.intervals["gyro[z]"]
    assert lo <= 7e-4 <= hi and hi - lo < 2e-4, again.intervals
    assert again.mounting_theta is not None and again.stat < cand.stat
    from imu_sim.diagnose import fixture, plausibility

    def tilts_refit(case_, cands, resid_):  # stands in for the tilts' joint fit taking the parameters over
        for c in cands:
            c.params, c.intervals = {"gyro[z]": 4e-4}, {"gyro[z]": [3.9e-4, 4.1e-4]}
    monkeypatch.setattr(fixture, "rank_given_tilts", tilts_refit)
    monkeypatch.setattr(plausibility, "below_reference", lambda c, case_: [])
    with_case = engine._refit_without(cand, vague, "industrial", case, resid)
    assert with_case.intervals == again.intervals


def test_a_short_drives_slow_gnss_error_is_not_a_lever_arm_under_its_exact_covariance():
    """240 fixes, five turns, a Gauss-Markov fix error of 1.4 m at tau 130 s (half the run): on the DFT's periodic
    weights a lever arm reached LR > 13.8 in 11 of 60 such runs (blind consumer drive: -1.6 m at LR 29 named before
    the coloured noise); under the exact covariance none of these 12, while a 0.35-m arm under a 0.3-m error is in 8 or more (9 found)."""
    from imu_sim.errors import gauss_markov
    n = 240
    t = np.arange(n, dtype=float)
    turns = np.zeros(n)
    turns[[30, 75, 120, 160, 200]] = 1.0
    yaw = np.cumsum(np.convolve(turns, np.full(8, np.pi / 16), "same"))
    vel = np.column_stack([6 * np.cos(yaw), 6 * np.sin(yaw), np.zeros(n)])
    rot = Rotation.from_euler("z", yaw[:, None]).as_matrix()
    thr, hits = stats.chi2.isf(1e-3, 2), {False: 0, True: 0}
    for seed in range(12):
        rng = np.random.default_rng(seed)
        for sigma, tau, arm, found in (([1.4, 1.4, 2.1], 130.0, (0.0, 0.0, 0.0), False),
                                       ([0.3, 0.3, 0.5], 30.0, (0.35, -0.25, 0.0), True)):
            r = rot @ np.array(arm) + rng.standard_normal((n, 3)) * [0.5, 0.5, 1.0]
            r += gauss_markov(n, 1.0, np.array(sigma), np.full(3, tau), rng)
            gr = gt.GnssResidual(t, r, 1.0, vel, rot, np.array([0.5, 0.5, 1.0]), np.zeros(3), 60.0, t)
            fit, _, _ = gt.gls_whiteness_first(gr, gt.design_lever_arm(gr))
            hits[found] += bool(fit.lr > thr)
            assert "exact covariance" in fit.whitened_by
    assert hits[False] == 0 and hits[True] >= 8, hits


def _short_drive(seed, colored: bool):
    """A 300-fix, four-turn drive at 3.1 m/s under a consumer receiver's white noise (1.5, 1.5, 3 m), with or without
    a Gauss-Markov error of half the record's correlation time (1.3, 1.3, 1.9 m, 150 s): blind seed 4's short drive."""
    from imu_sim.errors import gauss_markov
    n = 300
    t = np.arange(n, dtype=float)
    turns = np.zeros(n)
    turns[[50, 110, 170, 230]] = 1.0
    yaw = np.cumsum(np.convolve(turns, np.full(20, np.pi / 40), "same"))
    vel = np.column_stack([3.1 * np.cos(yaw), 3.1 * np.sin(yaw), np.zeros(n)])
    rot = Rotation.from_euler("z", yaw[:, None]).as_matrix()
    white = np.array([1.5, 1.5, 3.0])
    rng = np.random.default_rng(seed)
    r = rng.standard_normal((n, 3)) * white
    if colored:
        r += gauss_markov(n, 1.0, np.array([1.3, 1.3, 1.9]), np.full(3, 150.0), rng)
    return gt.GnssResidual(t, r, 1.0, vel, rot, white, np.zeros(3), 60.0, t)


def test_a_short_drives_slow_coloured_fix_error_gains_held_out_and_its_intervals_cover_it():
    """Blind seed 4: a coloured error of tau ~ half a 300-fix drive was significant (Whittle LR 183) but not kept - the
    second half's periodogram, DC dropped, showed no gain for the noise fitted on the first half (own generator, the
    same drive: 4 of 19 such cases). Held out as each half's one-step prediction from its neighbours under the noise
    fitted on the other half it gains on every such record (20 of 20 seeds; 0.09-0.74 per fix) and on white noise
    it does not (1 of 20 above 0.001, at 0.006); the exact (restricted) likelihood's intervals cover sigma and tau
    (60/60 and 19/20 over seeds 0-19; the Whittle fit's sigma came out low and its tau grid ended at 100 s)."""
    from imu_sim.diagnose import engine, gnss_candidates
    for seed in range(2):
        gr = _short_drive(seed, colored=True)
        before, after = gt.heldout_noise_deviance(gr)
        assert before - after > 50 * engine.MIN_DEVIANCE_GAIN, (seed, before, after)
        var, tau, tau_ci, var_ci = gnss_candidates._colored_estimate(gr, gt.colored_fit(gr.r, gr))
        sigma = np.sqrt([v[1] for v in var_ci]), np.sqrt([v[0] for v in var_ci])
        assert np.all((sigma[1] <= [1.3, 1.3, 1.9]) & ([1.3, 1.3, 1.9] <= sigma[0])), (seed, sigma)
        assert tau_ci[0] <= 150.0 <= tau_ci[1], (seed, tau_ci)
    for seed in range(2):
        before, after = gt.heldout_noise_deviance(_short_drive(seed, colored=False))
        assert before - after < engine.MIN_DEVIANCE_GAIN, (seed, before, after)


def test_a_weak_lever_arm_axis_states_the_scatter_of_its_joint_estimate_as_its_floor():
    # a vertical arm on a level drive shows only through the body's roll in the turns (0.02 rad here): z is left out
    # as weak, and the standard error stated for it (the joint fit's) is the scatter of z fitted with x and y
    zs, sds = [], []
    for seed in range(60):
        gr = _residual(seed)
        turning = np.r_[0.0, np.diff(np.unwrap(Rotation.from_matrix(gr.rot).as_euler("zyx")[:, 0]))] > 0
        gr.rot = Rotation.from_euler("zyx", np.column_stack([Rotation.from_matrix(gr.rot).as_euler("zyx")[:, 0],
                                                              np.zeros(N), 0.02 * turning])).as_matrix()
        gr.r = gr.r + gr.rot @ np.array([0.3, -0.2, 1.68])
        fit = gt.gls(gr.r, gt.design_lever_arm(gr), gt.model_psd(gr, np.fft.rfftfreq(N, DT)), DT)
        assert 2 not in fit.used and np.isfinite(fit.sd_joint[2])
        x = gt.design_lever_arm(gr) - gt.design_lever_arm(gr).mean(axis=0)
        y = (gr.r - gr.r.mean(axis=0)) / gr.sigma_w
        x = x / gr.sigma_w[None, :, None]
        zs.append(np.linalg.solve(np.einsum("nai,naj->ij", x, x), np.einsum("nai,na->i", x, y))[2])
        sds.append(fit.sd_joint[2])
    ratio = np.var(zs) / np.mean(np.square(sds))
    lo, hi = stats.chi2.ppf(0.001, 59) / 59, stats.chi2.isf(0.001, 59) / 59
    assert lo <= ratio <= hi, f"scatter of z over its stated variance {ratio:.2f} not in {lo:.2f}..{hi:.2f}"


def test_joint_standard_errors_are_the_inverse_and_infinite_for_a_collinear_column():
    a = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 2.0]])
    assert np.allclose(gt.joint_sd(a), np.sqrt(np.diag(np.linalg.inv(a))))
    x = np.random.default_rng(0).standard_normal((50, 2))
    x = np.column_stack([x, x[:, 0] + x[:, 1]])
    assert np.all(np.isinf(gt.joint_sd(x.T @ x)))
    assert np.isinf(gt.joint_sd(np.diag([1.0, 0.0]))[1])


def test_a_known_constant_is_not_weighted_out_by_the_reference_error_estimated_with_its_own_power(monkeypatch):
    """The reference's error spectrum is estimated from the residual; with a known constant left out of the model
    its power is in that residual, so weighting by it takes the constant's own frequencies out of its fit. Estimated
    from the residual less the constant's fitted part, the constant keeps its evidence and its interval still covers
    its value."""
    from types import SimpleNamespace

    from imu_sim.diagnose import reference
    case, resid, sd = _wandering_truth_case()
    shape = 1e-2 * np.column_stack([np.sin(2 * np.pi * case.t / 17.0), np.cos(2 * np.pi * case.t / 29.0)])
    known = resid + np.column_stack([np.zeros((case.n, 3)), shape, np.zeros(case.n)])
    fits = {}
    for rounds in (0, reference.JOINT_ITERATIONS):
        monkeypatch.setattr(reference, "JOINT_ITERATIONS", rounds)
        kc = SimpleNamespace(effect="coriolis", constant_scale=0.0, identifiable=True, stat=0.0, threshold=8.7,
                             reason="", columns={3: shape[:, [0]], 4: shape[:, [1]]})
        reference.constant_given_slow_reference(_ctx(case, known, sd), kc)
        fits[rounds] = kc
    once, joint = fits[0], fits[max(fits)]
    assert joint.stat > 2 * once.stat  # measured 213 -> 570
    lo, hi = joint.intervals["coriolis_scale"]
    assert lo < 1.0 < hi and hi - lo < 0.75 * np.diff(once.intervals["coriolis_scale"])[0]  # 0.29 -> 0.17
