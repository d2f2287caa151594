"""imu_calib.noise_fit: five-term WLS fit, intervals, term selection, Gauss-Markov alternative, IEEE readings."""
import numpy as np
import pytest

from imu_calib import synthetic
from imu_calib.allan import overlapping_adev
from imu_calib.noise_fit import TERMS, fit_noise

RATE_HZ = 20.0
TWO_HOURS = int(2 * 3600 * RATE_HZ)
SEPARATED = synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.2e-4)
"""White, flicker and random walk that each dominate a decade or more within 2 h."""
TABLE1_GYRO = synthetic.NoiseTerms(Q=1e-5, N=8.7e-4, B=1.5e-4, K=2e-5)
TABLE1_ACCEL = synthetic.NoiseTerms(N=1.2e-3, B=5e-4, K=5e-5)
"""Stand-ins for the paper's Table 1 (BP3010 / ADXRS300-grade; see src/imu_calib/README.md)."""


def _fit(terms, seed, n=TWO_HOURS, rate=RATE_HZ):
    x = synthetic.noise(n, rate, terms, np.random.default_rng(seed))
    return fit_noise(overlapping_adev(x, rate))


def test_two_hours_recover_n_within_3_percent_and_b_k_within_15_percent():
    fits = [_fit(SEPARATED, seed) for seed in range(8)]
    n_err = [abs(f.values["N"] / SEPARATED.N - 1) for f in fits]
    b_err = [abs(f.values["B"] / SEPARATED.B - 1) for f in fits]
    k_err = [abs(f.values["K"] / SEPARATED.K - 1) for f in fits]
    assert max(n_err) < 0.03
    assert np.median(b_err) < 0.15 and np.median(k_err) < 0.15
    assert all(f.kept == ("N", "B", "K") for f in fits)


@pytest.mark.slow
def test_fitted_values_fall_inside_their_95_percent_intervals_in_90_percent_of_seeds():
    seeds = range(100, 130)
    inside = {t: 0 for t in ("N", "B", "K")}
    for seed in seeds:
        fit = _fit(SEPARATED, seed)
        for t in inside:
            lo, hi = fit.intervals[t]
            inside[t] += lo <= getattr(SEPARATED, t) <= hi
    for t, count in inside.items():
        assert count / len(seeds) >= 0.9, (t, count)


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
