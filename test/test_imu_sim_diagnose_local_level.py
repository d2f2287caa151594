"""The diagnosis's random-walk likelihood (Kalman filter on block means): exactness, estimate, null, GM background."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from imu_sim.diagnose import local_level as ll
from imu_sim.diagnose import noise_tests

TB = 1.8
N_WHITE = 2e-4


def _walk_plus_white(rng, n_blocks, k, m=9, dt=0.2, n_white=N_WHITE):
    """Block means of m samples (dt s) of white rate noise plus a sampled rate random walk K."""
    n = n_blocks * m
    x = rng.standard_normal(n) * n_white / np.sqrt(dt) + np.cumsum(rng.standard_normal(n) * k * np.sqrt(dt))
    return noise_tests.block_means(x[:, None], m)[:, 0] + 3e-3  # plus a turn-on bias


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 60), st.floats(1e-6, 10.0), st.integers(0, 2**31 - 1))
def test_concentrated_likelihood_equals_the_dense_gaussian_likelihood_of_the_differences(n, ratio, seed):
    # a diffuse initial level makes the local-level likelihood that of the first differences, MA(1) with
    # autocovariance (q + 2h, -h): the filter must reproduce it to rounding
    y = np.random.default_rng(seed).standard_normal(n).cumsum() * 0.1 + 5.0
    got, h = ll.loglik(y, np.array([ratio]))
    d = np.diff(y)
    cov = np.diag(np.full(n - 1, ratio + 2.0)) - np.eye(n - 1, k=1) - np.eye(n - 1, k=-1)
    quad = d @ np.linalg.solve(cov, d)
    m = n - 1
    dense = -0.5 * (m * np.log(2 * np.pi * quad / m) + np.linalg.slogdet(cov)[1] + m)
    assert h[0] == pytest.approx(quad / m, rel=1e-6)
    assert got[0] == pytest.approx(dense, rel=1e-7, abs=1e-6)


def test_walk_estimate_is_near_the_truth_and_its_interval_covers_it():
    rng = np.random.default_rng(7)
    k_true = 6e-7
    fits = [ll.fit(_walk_plus_white(rng, 4000, k_true), TB) for _ in range(60)]
    est = np.array([f.k for f in fits])
    cover = np.mean([f.k_interval[0] <= k_true <= f.k_interval[1] for f in fits])
    # only ~7 of the lowest bins hold more walk than white noise here, so the ML estimate runs ~10 % low
    # (as any variance from few degrees of freedom); the profile interval still covers
    assert abs(np.median(est) / k_true - 1) < 0.15
    assert cover >= 0.88
    assert np.median([f.lr for f in fits]) > 20


def test_white_noise_gives_no_walk():
    rng = np.random.default_rng(8)
    lrs = np.array([ll.fit(_walk_plus_white(rng, 4000, 0.0), TB).lr for _ in range(100)])
    # a boundary test: at most half chi-square(1) above zero; its 95 % point is 2.71
    assert np.mean(lrs > 2.71) <= 0.10
    assert np.max(lrs) < 15


def test_a_gauss_markov_bias_in_the_model_is_not_taken_for_a_walk():
    rng = np.random.default_rng(9)
    m, dt, tc, sigma = 9, 0.2, 60.0, 1e-4
    n = 4000 * m
    phi = np.exp(-dt / tc)
    from scipy.signal import lfilter
    gm = lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * sigma * np.sqrt(1 - phi**2))
    x = rng.standard_normal(n) * N_WHITE / np.sqrt(dt) + gm
    y = noise_tests.block_means(x[:, None], m)[:, 0]
    bg = ll.Background(gm_var=sigma**2 * ll.block_gm_variance(tc, TB) / (N_WHITE**2 / TB), phi=float(np.exp(-TB / tc)))
    assert ll.fit(y, TB).lr > 30
    assert ll.fit(y, TB, bg).lr < 6


def test_the_fitted_walk_predicts_held_out_blocks_better():
    rng = np.random.default_rng(10)
    y = _walk_plus_white(rng, 4000, 6e-7)
    half = len(y) // 2
    fit = ll.fit(y[:half], TB)
    _, h0 = ll.loglik(y[:half], np.array([0.0]))
    assert ll.predictive_deviance(y, fit.ratio, fit.h, half) < ll.predictive_deviance(y, 0.0, h0[0], half)


def test_walk_already_in_the_model_is_a_floor():
    rng = np.random.default_rng(11)
    y = _walk_plus_white(rng, 4000, 0.0)
    k_old = 1e-6
    fit = ll.fit(y, TB, ll.Background(rw_ratio=k_old**2 * TB / (N_WHITE**2 / TB)))
    assert fit.k >= k_old * 0.9 and fit.lr < 5


def _gm_plus_white(rng, n_blocks, sigma, tau_s, m=9, dt=0.2):
    from scipy.signal import lfilter
    n = n_blocks * m
    phi = np.exp(-dt / tau_s)
    gm = lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * sigma * np.sqrt(1 - phi**2))
    x = rng.standard_normal(n) * N_WHITE / np.sqrt(dt) + gm + 2e-3
    return noise_tests.block_means(x[:, None], m)[:, 0]


def test_gauss_markov_level_and_time_are_recovered_with_covering_intervals():
    rng = np.random.default_rng(12)
    taus = np.logspace(np.log10(5 * TB), np.log10(4000 * TB / 20), 8)
    sigma, tau = 4e-5, 20.0
    fits = [ll.fit_gauss_markov(_gm_plus_white(rng, 4000, sigma, tau), TB, taus) for _ in range(30)]
    assert np.median([f.lr for f in fits]) > 30
    assert np.mean([f.sigma_interval[0] <= sigma <= f.sigma_interval[1] for f in fits]) >= 0.85
    assert abs(np.median([f.sigma for f in fits]) / sigma - 1) < 0.2
    assert np.mean([f.tau_interval[0] <= tau * 1.5 and f.tau_interval[1] >= tau / 1.5 for f in fits]) >= 0.85


def test_white_noise_gives_no_gauss_markov_bias():
    rng = np.random.default_rng(13)
    taus = np.logspace(np.log10(5 * TB), np.log10(4000 * TB / 20), 8)
    lrs = np.array([ll.fit_gauss_markov(_gm_plus_white(rng, 4000, 0.0, 10.0), TB, taus).lr for _ in range(40)])
    # two parameters, one on its boundary and one profiled over 8 grid points: chi-square(2) 99 % is 9.2
    assert np.mean(lrs > 9.2) <= 0.05
