"""A flicker bias instability as a sum of Gauss-Markov states per axis (``bias_gm_states_per_axis``, issue 25): the
sum's Allan deviation is the flicker's 0.664 B over the fitted band, the filter's extra states are that sum seen
through its total-bias states, and the filter runs with them."""
import numpy as np
import pytest
from scipy.integrate import quad

from ins_gps_kf import config, error_model as em, synthetic as syn
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from ins_gps_kf.smoother import ForwardStore, smooth

B = 1e-3  # m/s^2, the BP3010-grade accel's bias instability


def _allan_from_psd(psd_one_sided, tau: float) -> float:
    """Allan variance at ``tau`` s from a one-sided PSD (unit^2/Hz): 2 int S(f) sin^4(pi f tau) / (pi f tau)^2 df,
    by quadrature over log f (independent of the closed forms in error_model)."""
    def integrand(log_f):
        f = np.exp(log_f)
        x = np.pi * f * tau
        return 2.0 * psd_one_sided(f) * np.sin(x) ** 4 / x**2 * f
    return quad(integrand, np.log(1e-7 / tau), np.log(1e3 / tau), limit=400)[0]


def _gm_sum_psd(corr, sigma):
    """One-sided PSD of independent Gauss-Markov processes (correlation times s, stationary sigmas)."""
    return lambda f: sum(4.0 * s**2 * t / (1.0 + (2.0 * np.pi * f * t) ** 2) for t, s in zip(corr, sigma))


def test_the_flicker_psd_has_the_stated_plateau():
    adev = np.sqrt(_allan_from_psd(lambda f: B**2 / (np.pi * f), 30.0))
    assert adev == pytest.approx(em.ALLAN_PLATEAU * B, rel=1e-3)


@pytest.mark.parametrize("n, band_max_s, tolerance", [(2, 300.0, 0.10), (3, 300.0, 0.02), (3, 1000.0, 0.03),
                                                       (4, 1000.0, 0.02)])
def test_gauss_markov_sum_has_the_flicker_allan_deviation_over_the_band(n, band_max_s, tolerance):
    corr, sigma = em.flicker_gm_sum(B, n, band_max_s)
    assert len(corr) == n and np.all(np.diff(corr) > 0) and np.all(sigma > 0)
    taus = np.geomspace(em.FLICKER_BAND_MIN_S, band_max_s, 12)
    adev = np.sqrt([_allan_from_psd(_gm_sum_psd(corr, sigma), tau) for tau in taus])
    assert np.max(np.abs(adev / (em.ALLAN_PLATEAU * B) - 1.0)) < tolerance
    # one Gauss-Markov state (today's filter) is far from it at the outage time scales
    one = np.sqrt(_allan_from_psd(_gm_sum_psd(*em.flicker_gm_sum(B, 1, 300.0)), 10.0))
    assert one < 0.6 * em.ALLAN_PLATEAU * B


def test_one_state_per_axis_is_the_single_gauss_markov_of_before():
    corr, sigma = em.flicker_gm_sum(B, 1, 300.0)
    assert corr.tolist() == [300.0] and sigma.tolist() == [B]
    noise = em.noise_from_sensor_model(em.default_mems_model(), 300.0, 1)
    assert noise.n_extra == 0


def test_total_bias_states_are_the_sum_of_the_components():
    """The filter's ``BA``/``BG`` state is the total b = c_1 + ... + c_n, its extra states c_2..c_n: its F and G are
    the component system's (diag(-1/T_k), diag(q_k)) transformed by b = sum c_k; the initial covariance is the
    components' stationary one, transformed alike, with the total's own variance added."""
    model = em.default_mems_model()
    n = 3
    noise = em.noise_from_sensor_model(model, 300.0, n, 1000.0)
    assert noise.n_extra == 6 * (n - 1)
    f15, g15 = em.dynamics(np.eye(3), [0.0, 0.0, 9.8], np.zeros(3), np.zeros(3), noise)
    f, g = em.with_bias_components(f15, g15, noise, em.N_STATES)
    corr, sigma = em.flicker_gm_sum(model.accel.bias_instability[0], n, 1000.0)  # bias_gm_band_max_s
    q = np.sqrt(2.0 * sigma**2 / corr)
    q[-1] = np.hypot(q[-1], model.accel.rate_random_walk[0])  # the slowest also carries K
    to_total = np.eye(n)
    to_total[0, :] = 1.0  # (b, c_1 .. c_{n-1}) from the components, slowest last: b = sum
    comp_f = np.diag(-1.0 / corr)[[n - 1, *range(n - 1)]][:, [n - 1, *range(n - 1)]]
    comp_g = np.diag(q)[[n - 1, *range(n - 1)]][:, [n - 1, *range(n - 1)]]
    states = [em.BA.start, em.N_STATES + 3 * (n - 1), em.N_STATES + 3 * (n - 1) + 1]  # accel x's total, components
    np.testing.assert_allclose(f[np.ix_(states, states)], to_total @ comp_f @ np.linalg.inv(to_total), atol=1e-15)
    gram = g[states] @ g[states].T
    np.testing.assert_allclose(gram, to_total @ comp_g @ comp_g.T @ to_total.T, rtol=1e-12)
    cov = em.bias_component_covariance(noise, np.full(6, 1e-4))
    sub = cov[np.ix_([3, 6 + 3 * (n - 1), 7 + 3 * (n - 1)], [3, 6 + 3 * (n - 1), 7 + 3 * (n - 1)])]
    comp_cov = np.diag([1e-4, *(sigma[:-1] ** 2)])
    np.testing.assert_allclose(sub, to_total @ comp_cov @ to_total.T, rtol=1e-12)


@pytest.mark.parametrize("gyro_gm_s, extra", [(0.0, 12), (100.0, 6)], ids=["all_flicker", "gyro_gauss_markov"])
def test_filter_and_smoother_with_three_states_per_axis_keep_a_positive_definite_covariance(gyro_gm_s, extra):
    """Only flicker axes get further components (a Gauss-Markov gyro bias keeps its one state: zero-variance states
    made the smoother's P- singular)."""
    rate = 32.0
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=10.0, turn_s=100.0, yaw_rate=0.05)
    rng = np.random.default_rng(3)
    model = em.default_mems_model()
    model.gyro.bias_correlation_time[:] = gyro_gm_s
    imu = syn.add_imu_errors(syn.ideal_imu(motion, rate), rng, np.array([2e-4, -1e-4, 3e-4]),
                             np.array([0.005, -0.004, 0.003]), model.gyro.white_noise, model.accel.white_noise)
    gnss = syn.gnss(motion, rate, 1.0, rng)
    one = run(InsGpsFilter(config.from_params({"imu_rate_hz": rate}), model), imu, gnss)
    filt = InsGpsFilter(config.from_params({"imu_rate_hz": rate, "bias_gm_states_per_axis": 3}), model)
    filt.recorder = ForwardStore(filt.n_states)
    three = run(filt, imu, gnss)
    smoothed = smooth(filt.recorder, three)
    var_f, var_s = (np.array([np.diag(e.cov) for e in est]) for est in (three, smoothed))
    assert np.all(var_s <= var_f * (1 + 1e-9) + 1e-15)  # the smoother never claims more than the forward pass
    assert filt.n_states == em.N_STATES + extra and three[-1].cov.shape == (15 + extra, 15 + extra)
    assert np.linalg.eigvalsh(three[-1].cov).min() > 0.0
    assert len(three) == len(one)
    # with GNSS throughout the extra states change little: the solutions agree well within the fixes' noise
    diff = np.array([a.position_n - b.position_n for a, b in zip(one, three)])
    assert np.max(np.hypot(diff[:, 0], diff[:, 1])) < 0.5
