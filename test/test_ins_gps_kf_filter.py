"""The INS/GPS filter on synthetic drives: alignment, heading from course, accuracy, gating, consistency, resets."""


import math

import numpy as np
import pytest
from scipy.stats import chi2

from nav_core import frames
from nav_core.earth import LocalFrame
from nav_core.units import DEG, DEG_PER_H
from ins_gps_kf import alignment, config, error_model as em, synthetic as syn
from ins_gps_kf.filter import HEADING_PENDING, NAVIGATING, InsGpsFilter
from ins_gps_kf.offline import run

RATE = 32.0  # Hz: keeps the tests quick; the filter takes the rate from the stamps


def _noisy_model(gyro_white=0.02 * DEG, accel_white=2e-3, gyro_bi=20 * DEG_PER_H, accel_bi=1e-3):
    model = em.default_mems_model()
    model.gyro.white_noise[:] = gyro_white
    model.accel.white_noise[:] = accel_white
    model.gyro.bias_instability[:] = gyro_bi
    model.accel.bias_instability[:] = accel_bi
    model.gyro.rate_random_walk[:] = 0.0
    model.accel.rate_random_walk[:] = 0.0
    return model


def _drive(motion, seed, gps_std=1.0, model=None, params=None, gyro_bias=(2e-4, -1e-4, 3e-4),
           accel_bias=(0.005, -0.004, 0.003), fixes=None):
    rng = np.random.default_rng(seed)
    model = model or _noisy_model()
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, np.array(gyro_bias), np.array(accel_bias),
                             model.gyro.white_noise, model.accel.white_noise)
    gnss = fixes if fixes is not None else syn.gnss(motion, RATE, gps_std, rng)
    filt = InsGpsFilter(config.from_params(params or {}), model)
    return filt, run(filt, imu, gnss), gnss


def _truth_at(motion, times, filt):
    """Truth position in the filter's local frame (its datum is the first noisy fix), velocity, yaw."""
    t, pos, vel, yaw = syn.truth(motion, RATE)
    idx = np.clip(np.round(np.asarray(times) * RATE).astype(int), 0, len(t) - 1)
    origin = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m)
    pos_f = filt.frame.to_enu(*origin.to_geodetic(pos[idx]))
    return pos_f, vel[idx], yaw[idx]


@pytest.mark.parametrize("roll_deg, pitch_deg", [(0.0, 0.0), (5.0, -3.0), (-20.0, 10.0), (170.0, 30.0)])
def test_level_from_specific_force_recovers_roll_and_pitch(roll_deg, pitch_deg):
    mat_nb = frames.mat_nb_from_euler(roll_deg * DEG, pitch_deg * DEG, 1.0)
    f_b = mat_nb.T @ np.array([0.0, 0.0, 9.81])
    roll, pitch = alignment.level_from_specific_force(f_b)
    assert roll == pytest.approx(roll_deg * DEG, abs=1e-12)
    assert pitch == pytest.approx(pitch_deg * DEG, abs=1e-12)


def test_stationary_alignment_estimates_gyro_bias_when_yaw_is_known():
    motion = syn.stationary(duration_s=60.0, yaw0=0.4)
    imu = syn.ideal_imu(motion, RATE)
    bias = np.array([1e-3, -2e-3, 5e-4])
    aligner = alignment.StationaryAligner(45.0, 5.0, 2 * DEG, 0.5)
    k = 0
    while not aligner.add(imu.t[k], imu.gyro[k] + bias, imu.accel[k]):
        k += 1
    result = aligner.finish(motion.lat0_deg * DEG, yaw=0.4)
    assert 45.0 <= result.duration_s < 45.0 + 1.1  # judged in 1 s blocks
    np.testing.assert_allclose(result.gyro_bias, bias, atol=1e-9)
    assert not aligner.moving


def test_alignment_stops_at_motion_and_restarts_if_too_short():
    motion = syn.straight(still_s=20.0, accel_s=5.0, cruise_s=5.0)
    imu = syn.ideal_imu(motion, RATE)
    aligner = alignment.StationaryAligner(45.0, 5.0, 0.5 * DEG, 0.05)
    done = [aligner.add(t, g, a) for t, g, a in zip(imu.t, imu.gyro, imu.accel)]
    first = done.index(True)
    assert aligner.moving and 20.0 <= imu.t[first] < 21.1  # motion shows in the first 1 s block after 20 s
    short = alignment.StationaryAligner(45.0, 25.0, 0.5 * DEG, 0.05)
    results = [short.add(t, g, a) for t, g, a in zip(imu.t, imu.gyro, imu.accel)]
    assert not any(results) and short.restarts >= 1


def test_heading_from_gps_course_then_filter_beats_raw_gps():
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=300.0, accel=1.0, yaw_rate=0.04)
    filt, est, gnss = _drive(motion, seed=3, gps_std=2.0)
    assert filt.status == NAVIGATING and filt.counters.resets == 0
    t = np.array([e.t for e in est])
    pos, _, yaw = _truth_at(motion, t, filt)
    nav = np.array([s == NAVIGATING for s in (e.status for e in est)])
    first = int(np.argmax(nav))
    assert t[first] < 70.0  # heading found within ~10 s of the start of motion
    yaw_est = np.array([frames.euler_from_quat_xyzw(e.quat_xyzw)[2] for e in est])
    yaw_err = frames.wrap_angle(yaw_est - yaw)[nav]
    assert np.sqrt(np.mean(yaw_err[120:] ** 2)) < 3 * DEG  # converged a minute after the course fix
    p_est = np.array([e.position_n for e in est])
    later = nav & (t > 100.0)
    filt_rms = np.sqrt(np.mean(np.sum((p_est[later] - pos[later])[:, :2] ** 2, axis=1)))
    assert filt_rms < 2.0 * np.sqrt(2.0) * 0.7  # below the raw horizontal GPS error (2.8 m rms)


def test_position_nees_is_within_chi_square_bounds():
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=500.0, accel=1.0, yaw_rate=0.04)
    filt, est, _ = _drive(motion, seed=11, gps_std=1.5, gyro_bias=(0, 0, 0), accel_bias=(0, 0, 0))
    t = np.array([e.t for e in est])
    pos, vel, _ = _truth_at(motion, t, filt)
    use = np.flatnonzero((t > 150.0) & np.array([e.status == NAVIGATING for e in est]))[::10]  # ~decorrelated
    nees = [float(d @ np.linalg.solve(est[i].cov[:3, :3], d)) for i, d in zip(use, (np.array(
        [est[i].position_n for i in use]) - pos[use]))]
    dof = 3 * len(use)
    lo, hi = chi2.ppf([0.005, 0.995], dof) / len(use)
    assert lo < np.mean(nees) < hi, (np.mean(nees), lo, hi)


def test_outlier_fix_is_rejected_and_counted():
    motion = syn.straight(still_s=50.0, accel_s=10.0, cruise_s=60.0)
    rng = np.random.default_rng(5)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    k = int(np.searchsorted(gnss.t, 100.0))
    gnss.lat[k] += 200.0 / 6.4e6  # a 200 m jump north
    filt, est, _ = _drive(motion, seed=5, fixes=gnss)
    assert filt.counters.fixes_rejected == 1
    t = np.array([e.t for e in est])
    pos, _, _ = _truth_at(motion, t, filt)
    err = np.linalg.norm(np.array([e.position_n for e in est]) - pos, axis=1)
    assert err[(t > 100.0) & (t < 102.0)].max() < 5.0


def test_no_fix_and_nan_fixes_are_counted_and_ignored():
    motion = syn.stationary(duration_s=80.0)
    rng = np.random.default_rng(2)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    gnss.status[10:20] = -1
    gnss.lat[30:35] = np.nan
    filt, est, _ = _drive(motion, seed=2, fixes=gnss)
    assert filt.counters.fixes_invalid == 15
    assert filt.status == HEADING_PENDING  # stationary: no course, heading still pending
    assert np.linalg.norm(est[-1].position_n) < 2.0


def test_outage_is_bridged_by_prediction_only():
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=200.0, accel=1.0, yaw_rate=0.04)
    rng = np.random.default_rng(8)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    keep = ~((gnss.t > 150.0) & (gnss.t <= 180.0))
    gnss = type(gnss)(gnss.t[keep], gnss.lat[keep], gnss.lon[keep], gnss.h[keep], gnss.std_enu[keep])
    filt, est, _ = _drive(motion, seed=8, fixes=gnss, model=_noisy_model(gyro_white=0.005 * DEG, accel_white=5e-4))
    t = np.array([e.t for e in est])
    pos, _, _ = _truth_at(motion, t, filt)
    err = np.linalg.norm(np.array([e.position_n for e in est]) - pos, axis=1)
    std = np.array([np.sqrt(np.trace(e.cov[:3, :3])) for e in est])
    gap = (t > 150.0) & (t <= 180.0)
    assert not any(e.gps_used for e, g in zip(est, gap) if g)
    assert std[gap][-1] > 2 * std[gap][0]  # uncertainty grows during the outage
    assert err[gap].max() < 30.0
    assert err[(t > 190.0) & (t < 200.0)].max() < 3.0  # pulled back after the outage


@pytest.mark.parametrize("jump_s", [-10.0, 100.0])  # backwards, or forward beyond max_bridged_gap_s (30 s)
def test_time_jump_resets_and_realigns(jump_s):
    motion = syn.stationary(duration_s=120.0)
    rng = np.random.default_rng(1)
    imu = syn.ideal_imu(motion, RATE)
    imu.t[len(imu) // 2:] += jump_s
    filt = InsGpsFilter(config.from_params({"alignment_time_s": 20.0}), _noisy_model())
    run(filt, imu, syn.gnss(motion, RATE, 1.0, rng))
    assert filt.counters.resets == 1 and "time jump" in filt.counters.reset_reasons[0]
    assert filt.navigating


def test_feeding_one_sample_at_a_time_gives_identical_estimates():
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=20.0)
    rng = np.random.default_rng(4)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    params = {"alignment_time_s": 15.0}
    batch = run(InsGpsFilter(config.from_params(params)), imu, gnss)
    single = InsGpsFilter(config.from_params(params))
    one = []
    events = sorted([(t, 0, i) for i, t in enumerate(gnss.t)] + [(t, 1, i) for i, t in enumerate(imu.t)])
    for _, kind, i in events:
        if kind == 0:
            single.process_gps(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i])
        else:
            one += single.process_imu(imu.t[i], imu.gyro[i][None], imu.accel[i][None])
    assert len(one) == len(batch) > 50
    for a, b in zip(one, batch):
        assert a.t == b.t
        np.testing.assert_array_equal(a.position_n, b.position_n)
        np.testing.assert_array_equal(a.cov, b.cov)


def test_reused_fix_option_counts_reuses():
    motion = syn.straight(still_s=50.0, accel_s=10.0, cruise_s=30.0)
    filt, _, _ = _drive(motion, seed=6, params={"reuse_last_fix": True})
    assert filt.counters.fixes_reused > 30


def test_gauss_markov_process_noise_follows_the_sensor_model():
    model = _noisy_model()
    model.gyro.bias_correlation_time[:] = [100.0, 0.0, 100.0]
    noise = em.noise_from_sensor_model(model, flicker_tau_s=300.0)
    sigma = 20 * DEG_PER_H
    np.testing.assert_allclose(noise.gyro_bias_drive, np.sqrt(2 * sigma**2 / np.array([100.0, 300.0, 100.0])))
    np.testing.assert_allclose(noise.gyro_bias_tau, [100.0, 300.0, 100.0])


def test_bad_parameters_raise_a_named_error():
    with pytest.raises(config.FilterConfigError, match="filter_rate_hz"):
        config.from_params({"filter_rate_hz": 0.0})
    with pytest.raises(config.FilterConfigError, match="datum"):
        config.from_params({"datum_lat_deg": 45.0})
    with pytest.raises(config.FilterConfigError, match="unknown parameter"):
        config.from_params({"no_such": 1})


def test_config_file_defaults_match_the_parameter_spec():
    from pathlib import Path
    params = config.load_params_yaml(Path(__file__).resolve().parents[1] / "config" / "navigation.yaml")
    for name, default in config.defaults().items():
        value = params[name]
        assert (math.isnan(value) and math.isnan(default)) if isinstance(default, float) and math.isnan(default) \
            else value == default, name


@pytest.mark.slow
def test_covariance_stays_symmetric_positive_definite_over_two_hours():
    rate = 8.0
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=2 * 3600.0, accel=1.0, yaw_rate=0.02)
    rng = np.random.default_rng(21)
    model = _noisy_model()
    imu = syn.add_imu_errors(syn.ideal_imu(motion, rate), rng, 1e-4, 0.01, model.gyro.white_noise,
                             model.accel.white_noise)
    gnss = syn.gnss(motion, rate, 2.0, rng)
    outage = (gnss.t % 600.0) > 540.0  # a 60 s outage every 10 minutes
    gnss = type(gnss)(gnss.t[~outage], gnss.lat[~outage], gnss.lon[~outage], gnss.h[~outage], gnss.std_enu[~outage])
    filt = InsGpsFilter(config.from_params({"imu_rate_hz": rate}), model)
    est = run(filt, imu, gnss)
    assert est[-1].t > 2 * 3600.0
    worst_asym, min_eig = 0.0, np.inf
    for e in est[::5]:
        worst_asym = max(worst_asym, np.max(np.abs(e.cov - e.cov.T)))
        min_eig = min(min_eig, np.linalg.eigvalsh(e.cov).min())
    assert worst_asym == 0.0
    assert min_eig > 0.0
    assert np.all(np.isfinite(est[-1].position_n))



def _model_with_gm_gyro():
    model = _noisy_model()
    model.gyro.bias_correlation_time[:] = 100.0
    return em.noise_from_sensor_model(model)


def test_compiled_dynamics_match_the_documented_error_equations():
    from nav_core.frames import skew
    noise = _model_with_gm_gyro()
    c = frames.mat_nb_from_euler(0.1, -0.2, 2.0)
    f_n, w_ie, w_en = np.array([1.5, -0.5, 9.8]), np.array([0, 5e-5, 5e-5]), np.array([1e-6, -2e-6, 3e-6])
    f, g = em.dynamics(c, f_n, w_ie, w_en, noise)
    ref = np.zeros((15, 15))
    ref[em.DP, em.DV] = np.eye(3)
    ref[em.DV, em.DV], ref[em.DV, em.PHI], ref[em.DV, em.BA] = -skew(2 * w_ie + w_en), skew(f_n), -c
    ref[em.PHI, em.PHI], ref[em.PHI, em.BG] = -skew(w_ie + w_en), c
    ref[em.BG, em.BG] = np.diag(-1.0 / noise.gyro_bias_tau)
    ref[em.BA, em.BA] = np.diag(-1.0 / noise.accel_bias_tau)
    np.testing.assert_array_equal(f, ref)
    np.testing.assert_array_equal(g[em.DV, 3:6], c * noise.accel_white)
    np.testing.assert_array_equal(g[em.PHI, 0:3], -c * noise.gyro_white)


def test_compiled_van_loan_series_matches_filterpy():
    from filterpy.common import van_loan_discretization
    from ins_gps_kf import kalman
    f, g = em.dynamics(frames.mat_nb_from_euler(0.1, -0.2, 2.0), np.array([1.5, -0.5, 9.8]),
                       np.array([0, 5e-5, 5e-5]), np.zeros(3), _model_with_gm_gyro())
    phi_s, q_s = kalman.van_loan_series(f, g, 0.5)
    phi_v, q_v = van_loan_discretization(f, g, 0.5)
    np.testing.assert_allclose(phi_s, phi_v, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(q_s, q_v, rtol=1e-9, atol=1e-12 * np.abs(q_v).max())
    cov = np.diag(np.linspace(0.1, 3.0, 15))
    np.testing.assert_allclose(kalman.propagate_series(cov, f, g, 0.5), kalman.propagate(cov, f, g, 0.5),
                               rtol=1e-10, atol=1e-14)
