"""GNSS-side diagnosis on synthetic fix residuals: latency recovered, coloured noise not taken for latency."""
import numpy as np
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from imu_sim.diagnose import gnss_tests as gt
from imu_sim.errors import gauss_markov

N, DT = 900, 1.0


def _residual(seed, latency_s=0.0, colored_sigma=0.0, arm=(0.0, 0.0, 0.0)):
    """A drive with turns and speed changes; residual = -v L + C_nb l + white (0.5 m) + Gauss-Markov (30 s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    speed = 8 + 4 * np.sin(2 * np.pi * t / 97.0) * (np.sin(2 * np.pi * t / 241.0) > -0.3)
    yaw = np.cumsum(np.where(np.sin(2 * np.pi * t / 61.0) > 0.7, 0.15, 0.0))
    vel = np.column_stack([speed * np.cos(yaw), speed * np.sin(yaw), np.zeros(N)])
    rot = Rotation.from_euler("z", yaw[:, None]).as_matrix()
    r = -vel * latency_s + rot @ np.asarray(arm, float) + rng.standard_normal((N, 3)) * [0.5, 0.5, 1.0]
    if colored_sigma:
        r += gauss_markov(N, DT, np.full(3, colored_sigma), np.full(3, 30.0), rng)
    return gt.GnssResidual(t, r, DT, vel, rot, np.array([0.5, 0.5, 1.0]), np.zeros(3), 60.0, t)


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 10_000))
def test_latency_interval_covers_the_truth(seed):
    gr = _residual(seed, latency_s=0.04)
    fit, _, _, _ = gt.gls_whiteness_first(gr, gt.design_latency(gr))
    sd = np.sqrt(fit.cov[0, 0])
    assert abs(fit.theta[0] - 0.04) < 3.5 * sd and fit.lr > 10


def test_coloured_noise_is_not_taken_for_latency():
    white_model, whiteness_first, coloured = [], [], []
    for seed in range(60):
        gr = _residual(seed, colored_sigma=0.6)
        design = gt.design_latency(gr)
        psd = gt.model_psd(gr, np.fft.rfftfreq(len(gr.r), gr.dt))
        white_model.append(gt.gls(gr.r, design, psd, gr.dt).lr)
        fit, _, found, _ = gt.gls_whiteness_first(gr, design)
        whiteness_first.append(fit.lr)
        coloured.append(found)
    threshold = 8.7  # chi-square(1) at 0.05 / 16, the uncalibrated latency threshold
    assert np.mean(coloured) > 0.95
    assert np.mean(np.array(whiteness_first) > threshold) <= 0.05
    assert np.mean(np.array(white_model) > threshold) >= 0.3


def test_lever_arm_z_is_not_identifiable_on_a_level_drive():
    gr = _residual(3, arm=(0.8, -0.5, 0.6))
    fit, _, _, _ = gt.gls_whiteness_first(gr, gt.design_lever_arm(gr))
    assert list(fit.used) == [0, 1]
    sd = np.sqrt(np.diag(fit.cov)[:2])
    assert np.all(np.abs(fit.theta[:2] - [0.8, -0.5]) < 4 * sd)


def test_colored_fit_finds_the_correlation_time():
    gr = _residual(5, colored_sigma=1.0)
    col = gt.colored_fit(gr.r, gr)
    assert col.tau_ci[0] <= 30.0 <= col.tau_ci[1] * 1.5 and col.lr > 100
