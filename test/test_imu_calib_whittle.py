"""imu_calib.whittle: the sine-basis likelihood's expected power matches simulation and, for white noise plus a
random walk, is the exact eigen-decomposition; the ML estimate of K is unbiased and as precise as the Cramer-Rao
bound allows; the ramp is profiled out."""
import numpy as np
import pytest
from scipy import stats

from imu_calib import synthetic
from imu_calib.whittle import (WhittleProblem, cramer_rao_relative_sd, expected_power, fit_whittle,
                               sine_coefficients)

RATE_HZ = 10.0


@pytest.mark.parametrize("truth", [synthetic.NoiseTerms(N=1e-3), synthetic.NoiseTerms(K=1e-4),
                                   synthetic.NoiseTerms(B=5e-4), synthetic.NoiseTerms(B=5e-4, tau_c=20.0),
                                   # LSB about twice the per-sample angle noise, so the rounding error is white
                                   synthetic.NoiseTerms(Q=3e-5, N=1.6e-4)],
                         ids=["white", "random_walk", "flicker", "gauss_markov", "quantization"])
def test_expected_power_matches_the_mean_of_simulated_sine_coefficients(truth):
    n, runs = 2048, 300
    rng = np.random.default_rng(5)
    mean = np.mean([sine_coefficients(synthetic.noise(n, RATE_HZ, truth, rng)) ** 2 for _ in range(runs)], axis=0)
    terms = [t for t in ("Q", "N", "B", "K") if getattr(truth, t) > 0]
    theta = np.array([getattr(truth, t) ** 2 for t in terms])
    expected = expected_power(terms, n - 1, RATE_HZ, truth.tau_c) @ theta
    # band averages of 64 coefficients x 300 runs (each chi-square(1)): relative sd about 1 %
    bands = lambda a: a[: len(a) // 64 * 64].reshape(-1, 64).mean(axis=1)
    assert np.allclose(bands(mean), bands(expected), rtol=0.06)


def test_white_noise_and_random_walk_power_is_the_exact_eigenvalue_of_their_differences():
    # the differences' covariance is tridiagonal Toeplitz (2 N^2 fs + K^2 dt, -N^2 fs): DST-I eigenvalues
    m = 1000
    k = np.arange(1, m + 1)
    power = expected_power(("N", "K"), m, RATE_HZ)
    np.testing.assert_allclose(power[:, 0], 4.0 * RATE_HZ * np.sin(np.pi * k / (2 * (m + 1))) ** 2, rtol=1e-9)
    np.testing.assert_allclose(power[:, 1], 1.0 / RATE_HZ, rtol=1e-12)
    cov = 2.0 * RATE_HZ * np.eye(m) - RATE_HZ * (np.eye(m, k=1) + np.eye(m, k=-1)) + np.eye(m) / RATE_HZ
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(cov)), np.sort(power.sum(axis=1)), rtol=1e-9)


def test_random_walk_estimate_is_unbiased_and_as_precise_as_the_cramer_rao_bound():
    # issue 14's middle gyro axis; 2 h at 1 Hz holds the same low-frequency information on K as at 100 Hz
    # (the bound differs by < 0.1 %), at 1 % of the cost
    n_coef, k_coef, rate, seeds = 3.5e-4, 2.2e-6, 1.0, 200
    n = 7200
    bound = cramer_rao_relative_sd(n, rate, "NK", (n_coef, k_coef))[1]
    assert abs(bound / cramer_rao_relative_sd(720_000, 100.0, "NK", (n_coef, k_coef))[1] - 1) < 1e-3
    ratio = np.array([np.sqrt(fit_whittle(synthetic.noise(n, rate, synthetic.NoiseTerms(N=n_coef, K=k_coef),
                                                          np.random.default_rng(seed)), rate, "NK",
                                          [n_coef ** 2 * 1.5, k_coef ** 2 * 0.3]).theta[1]) for seed in range(seeds)]
                     ) / k_coef
    # sd of an sd from 200 draws ~ 5 %: efficiency (bound / spread)^2 between 0.7 and 1.3
    assert 0.87 * bound < ratio.std() < 1.15 * bound, (ratio.std(), bound)
    assert abs(np.median(ratio) - 1) < 3 * 1.25 * bound / np.sqrt(seeds), np.median(ratio)
    # the fraction within 25 % an efficient unbiased estimator reaches, with 3-sigma binomial bounds
    p = 2 * stats.norm.cdf(0.25 / bound) - 1
    within = np.mean(np.abs(ratio - 1) < 0.25)
    assert abs(within - p) < 3 * np.sqrt(p * (1 - p) / seeds), (within, p)


def test_fisher_sd_of_the_white_noise_matches_its_spread():
    truth = synthetic.NoiseTerms(N=5e-4, K=1e-4)
    theta = np.array([truth.N ** 2, truth.K ** 2])
    fits = [fit_whittle(synthetic.noise(20_000, RATE_HZ, truth, np.random.default_rng(seed)), RATE_HZ, "NK",
                        theta * 1.2) for seed in range(40)]
    assert all(f.converged for f in fits)
    ratios = np.array([f.theta / theta for f in fits])
    predicted = np.sqrt(np.diag(fits[0].cov)) / theta
    assert np.all(np.abs(ratios.mean(axis=0) - 1) < 3 * predicted / np.sqrt(len(fits)))
    assert 0.7 * predicted[0] < ratios[:, 0].std() < 1.4 * predicted[0]


def test_a_ramp_is_profiled_out_and_recovered_within_its_interval():
    truth = synthetic.NoiseTerms(N=1e-3, K=1e-5, R=2e-7)
    hits = 0
    for seed in range(20):
        x = synthetic.noise(36_000, RATE_HZ, truth, np.random.default_rng(seed))
        w = WhittleProblem(x, RATE_HZ).fit(("N", "K", "R"), [truth.N ** 2, truth.K ** 2])
        assert w.converged and w.ramp_sd > 0
        hits += abs(w.ramp - truth.R) < 1.96 * w.ramp_sd
    assert hits >= 16  # 95 % intervals: P(binomial(20, 0.95) < 16) < 0.3 %


def test_whittle_refuses_terms_it_does_not_model():
    with pytest.raises(ValueError, match="likelihood terms"):
        fit_whittle(np.zeros(100), RATE_HZ, ("N", "X"), [1.0, 1.0])
    with pytest.raises(ValueError, match="likelihood terms"):
        fit_whittle(np.zeros(100), RATE_HZ, ("R",), [])


def test_the_estimate_does_not_depend_on_the_start_even_a_zero_one():
    x = synthetic.noise(72_000, RATE_HZ, synthetic.NoiseTerms(N=3.5e-4, K=2.2e-6), np.random.default_rng(1))
    fits = [fit_whittle(x, RATE_HZ, "NK", start) for start in ([0.0, 0.0], [1e-6, 1e-14], [1e-8, 1e-9])]
    assert all(f.converged for f in fits)
    for f in fits[1:]:
        np.testing.assert_allclose(f.theta, fits[0].theta, rtol=1e-5)
