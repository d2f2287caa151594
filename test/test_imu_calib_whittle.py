"""imu_calib.whittle: the expected periodogram of each term matches simulation; the ML estimate and its Fisher sd."""
import numpy as np
import pytest

from imu_calib import synthetic
from imu_calib.whittle import expected_periodogram, fit_whittle, periodogram_of_differences

RATE_HZ = 10.0


@pytest.mark.parametrize("truth", [synthetic.NoiseTerms(N=1e-3), synthetic.NoiseTerms(K=1e-4),
                                   synthetic.NoiseTerms(B=5e-4), synthetic.NoiseTerms(B=5e-4, tau_c=20.0),
                                   # LSB about twice the per-sample angle noise, so the rounding error is white
                                   synthetic.NoiseTerms(Q=3e-5, N=1.6e-4)],
                         ids=["white", "random_walk", "flicker", "gauss_markov", "quantization"])
def test_expected_periodogram_matches_the_mean_of_simulated_periodograms(truth):
    n, runs = 2048, 300
    rng = np.random.default_rng(5)
    mean = np.mean([periodogram_of_differences(synthetic.noise(n, RATE_HZ, truth, rng)) for _ in range(runs)], axis=0)
    terms = [t for t in ("Q", "N", "B", "K") if getattr(truth, t) > 0]
    theta = np.array([getattr(truth, t) ** 2 for t in terms])
    expected = expected_periodogram(terms, n - 1, RATE_HZ, truth.tau_c) @ theta
    # band averages of 64 bins x 300 runs: relative sd about 0.7 %
    bands = lambda a: a[: len(a) // 64 * 64].reshape(-1, 64).mean(axis=1)
    assert np.allclose(bands(mean), bands(expected), rtol=0.05)


def test_whittle_estimate_is_unbiased_and_its_fisher_sd_matches_the_spread():
    truth = synthetic.NoiseTerms(N=5e-4, B=7.5e-4, K=1.2e-4)
    theta_true = np.array([truth.N ** 2, truth.B ** 2, truth.K ** 2])
    fits = [fit_whittle(synthetic.noise(36_000, RATE_HZ, truth, np.random.default_rng(seed)), RATE_HZ, "NBK",
                        theta_true * 1.2) for seed in range(30)]
    ratios = np.array([f.theta / theta_true for f in fits])
    predicted_sd = np.sqrt(np.diag(fits[0].cov)) / theta_true
    assert all(f.converged for f in fits)
    assert np.all(np.abs(ratios.mean(axis=0) - 1) < 3 * predicted_sd / np.sqrt(len(fits)))
    assert np.all((ratios.std(axis=0) > 0.6 * predicted_sd) & (ratios.std(axis=0) < 1.5 * predicted_sd))


def test_whittle_refuses_terms_it_does_not_model():
    with pytest.raises(ValueError, match="Whittle terms"):
        fit_whittle(np.zeros(100), RATE_HZ, ("N", "R"), [1.0, 1.0])
