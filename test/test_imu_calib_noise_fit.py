"""imu_calib.noise_fit: five-term WLS fit, Whittle refinement, intervals, term selection, Gauss-Markov, IEEE readings."""
import numpy as np
import pytest

from imu_calib import synthetic
from imu_calib.allan import overlapping_adev
from imu_calib.noise_fit import TERMS, fit_noise

RATE_HZ = 20.0
TWO_HOURS = int(2 * 3600 * RATE_HZ)
SEPARATED = synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.2e-4)
"""White, flicker and random walk that each dominate a decade or more within 2 h."""
K_TARGET_CASE = synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.8e-4)
"""Same N and B, K raised until the Cramer-Rao bound lets K within 15 % in 90 % of seeds (README, Allan fit):
at SEPARATED's K the bound on the relative sd of K is 10.5 %, so no estimator gets there in more than ~85 %."""
TABLE1_GYRO = synthetic.NoiseTerms(Q=1e-5, N=8.7e-4, B=1.5e-4, K=2e-5)
TABLE1_ACCEL = synthetic.NoiseTerms(N=1.2e-3, B=5e-4, K=5e-5)
"""Stand-ins for the paper's Table 1 (BP3010 / ADXRS300-grade; see src/imu_calib/README.md)."""


def _fit(terms, seed, n=TWO_HOURS, rate=RATE_HZ, whittle=True):
    """Fit of synthetic noise; ``whittle``: with the samples (the pipeline's path), else the Allan fit alone."""
    x = synthetic.noise(n, rate, terms, np.random.default_rng(seed))
    return fit_noise(overlapping_adev(x, rate), samples=x if whittle else None)


def _relative_errors(fits, truth, term):
    return np.array([abs(f.values[term] / getattr(truth, term) - 1) for f in fits])


@pytest.mark.slow
def test_two_hours_recover_n_within_3_percent_and_b_k_within_15_percent_in_90_percent_of_seeds():
    fits = [_fit(K_TARGET_CASE, seed) for seed in range(30)]
    assert all(f.kept == ("N", "B", "K") and f.estimator == "likelihood" for f in fits)
    assert np.all(_relative_errors(fits, K_TARGET_CASE, "N") < 0.03)
    for term in ("B", "K"):
        within = np.mean(_relative_errors(fits, K_TARGET_CASE, term) < 0.15)
        assert within >= 0.9, (term, within)


def test_two_hours_of_the_separated_case_recover_n_within_3_percent_and_b_within_15_percent():
    fits = [_fit(SEPARATED, seed) for seed in range(6)]
    assert np.all(_relative_errors(fits, SEPARATED, "N") < 0.03)
    assert np.all(_relative_errors(fits, SEPARATED, "B") < 0.15)
    # K's spread here is about its Cramer-Rao bound (10.5 %): a median, not every seed
    assert np.median(_relative_errors(fits, SEPARATED, "K")) < 0.15
    assert all(f.kept == ("N", "B", "K") for f in fits)


def _coverage(truth, seeds, whittle):
    inside = {t: 0 for t in ("N", "B", "K")}
    for seed in seeds:
        fit = _fit(truth, seed, whittle=whittle)
        for t in inside:
            lo, hi = fit.intervals[t]
            inside[t] += lo <= getattr(truth, t) <= hi
    return {t: count / len(seeds) for t, count in inside.items()}


@pytest.mark.slow
def test_fitted_values_fall_inside_their_95_percent_intervals_in_90_percent_of_seeds():
    # intervals from the Whittle Fisher information, no tuned factor
    for t, share in _coverage(SEPARATED, range(100, 130), whittle=True).items():
        assert share >= 0.9, (t, share)


@pytest.mark.slow
def test_allan_fit_alone_intervals_cover_the_truth_in_90_percent_of_seeds():
    # the path without samples (imu_sim's real-data check): sandwich covariance from the edf and the spectral
    # correlation of the Allan points, no tuned factor (was a Monte Carlo factor of 4)
    for t, share in _coverage(SEPARATED, range(100, 130), whittle=False).items():
        assert share >= 0.9, (t, share)


def test_fit_refuses_samples_that_do_not_match_the_allan_deviation():
    x = synthetic.noise(4096, RATE_HZ, SEPARATED, np.random.default_rng(0))
    with pytest.raises(ValueError, match="samples"):
        fit_noise(overlapping_adev(x, RATE_HZ), samples=x[:-1])


@pytest.mark.slow
@pytest.mark.parametrize("truth", [TABLE1_GYRO, TABLE1_ACCEL], ids=["gyro", "accel"])
def test_table1_round_trip_recovers_present_terms_and_keeps_absent_ones_absent(truth):
    rate, n = 10.0, int(10 * 3600 * 10.0)  # 10 h: B and K of these values overlap near 100 s
    for seed in range(3):
        fit = _fit(truth, seed, n, rate)
        for term in TERMS:
            value = getattr(truth, term)
            shortest = overlapping_adev(np.zeros(n), rate).taus[0]
            visible = value > 0 and synthetic.true_avar(shortest, synthetic.NoiseTerms(**{term: value})) > \
                0.1 * synthetic.true_avar(shortest, truth)
            if value == 0:
                assert fit.values[term] == 0.0, (term, fit.values)
            elif term == "Q" and not visible:
                # Q = 1e-5 rad is below 10 % of the Allan variance at 10 Hz: the data cannot support it
                assert fit.values[term] == 0.0 and fit.intervals[term][1] > 0
            else:
                assert abs(fit.values[term] / value - 1) < 0.3, (term, fit.values[term], value)


def test_quantization_is_recovered_when_it_dominates_short_cluster_times():
    # LSB = Q sqrt(12) about twice the per-sample angle noise: quantization error is then white (an LSB
    # much coarser than the noise makes it correlated, and the 3 Q^2 / tau^2 law no longer holds)
    truth = synthetic.NoiseTerms(Q=3e-5, N=5e-4)
    fit = _fit(truth, 7, n=200_000, rate=100.0)
    assert "Q" in fit.kept
    assert abs(fit.values["Q"] / truth.Q - 1) < 0.1
    assert abs(fit.values["N"] / truth.N - 1) < 0.05


def test_gauss_markov_bias_is_preferred_for_gauss_markov_data_but_not_for_flicker():
    gm = synthetic.NoiseTerms(N=5e-4, B=1e-3, tau_c=100.0)
    gm_fits = [_fit(gm, seed) for seed in range(4)]
    assert sum(f.bias_correlation_time > 0 for f in gm_fits) >= 3
    for f in gm_fits:
        if f.bias_correlation_time > 0:
            assert 30.0 < f.bias_correlation_time < 300.0
            assert abs(f.values["B"] / gm.B - 1) < 0.3
    assert all(_fit(SEPARATED, seed).bias_correlation_time == 0.0 for seed in range(4))


def test_white_noise_only_keeps_only_n():
    fit = _fit(synthetic.NoiseTerms(N=1e-3), 11)
    assert fit.kept == ("N",)
    assert all(fit.values[t] == 0.0 for t in ("Q", "B", "K", "R"))


def test_rate_ramp_is_detected():
    truth = synthetic.NoiseTerms(N=1e-3, R=2e-6)
    fit = _fit(truth, 2)
    assert "R" in fit.kept and abs(fit.values["R"] / truth.R - 1) < 0.2


def test_ieee_slope_readings_are_reported_next_to_the_fit():
    fit = _fit(SEPARATED, 3)
    readings = fit.slope_readings
    assert abs(readings["N"] / SEPARATED.N - 1) < 0.2
    assert readings["B"] > 0 and readings["K"] > 0
    assert set(fit.summary()["ieee_slope_readings"]) >= {"N", "B", "K"}


def test_fit_refuses_multi_axis_input():
    x = np.random.default_rng(0).standard_normal((4096, 3))
    with pytest.raises(ValueError, match="one axis"):
        fit_noise(overlapping_adev(x, 10.0))
