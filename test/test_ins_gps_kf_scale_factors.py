"""Optional scale-factor states (21): estimated on a turning drive, and the 15-state filter is unchanged."""


import numpy as np
import pytest

from nav_core import frames
from nav_core.units import DEG
from ins_gps_kf import config, error_model as em, synthetic as syn
from ins_gps_kf.filter import NAVIGATING, InsGpsFilter
from ins_gps_kf.offline import run

RATE = 32.0
GYRO_SCALE = np.array([0.0, 0.0, 0.02])  # 2 % on the turning axis


def _circle_run(estimate, seed=11):
    motion = syn.circle(still_s=50.0, accel_s=10.0, straight_s=15.0, turn_s=240.0, yaw_rate=0.1)
    rng = np.random.default_rng(seed)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.005, 0.02 * DEG, 2e-3)
    imu.gyro = imu.gyro * (1.0 + GYRO_SCALE)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    filt = InsGpsFilter(config.from_params({"estimate_scale_factors": estimate, "init_scale_factor_std_pct": 3.0}))
    est = run(filt, imu, gnss)
    t_ref, _, _, yaw = syn.truth(motion, RATE)
    nav = [e for e in est if e.status == NAVIGATING]
    idx = np.clip(np.round(np.array([e.t for e in nav]) * RATE).astype(int), 0, len(t_ref) - 1)
    yaw_est = frames.euler_from_quat_xyzw(np.array([e.quat_xyzw for e in nav]))[2]
    return nav, frames.wrap_angle(yaw_est - yaw[idx])


@pytest.mark.slow
def test_gyro_scale_factor_is_estimated_on_a_turning_drive_and_improves_yaw():
    nav, yaw_err = _circle_run(True)
    last = nav[-1]
    assert last.cov.shape == (21, 21)
    sd = np.sqrt(last.cov[em.SG, em.SG][2, 2])
    assert last.scale_factors[2] == pytest.approx(GYRO_SCALE[2], abs=max(3 * sd, 2e-3))
    assert sd < 0.3 * 0.03  # the turn makes it observable: the std fell well below its initial 3 %
    _, yaw_err15 = _circle_run(False)
    late = slice(len(yaw_err) // 2, None)
    assert np.sqrt(np.mean(yaw_err[late] ** 2)) < np.sqrt(np.mean(yaw_err15[late] ** 2))


def test_without_scale_factor_states_the_filter_keeps_15_states():
    filt = InsGpsFilter(config.from_params({}))
    assert filt.n_states == em.N_STATES
    f, g = em.with_scale_factors(np.zeros((15, 15)), np.zeros((15, 12)), np.eye(3), [0.0, 0.0, 0.5], [0, 0, 9.8])
    assert f.shape == (21, 21) and g.shape == (21, 12)
    assert f[em.PHI, em.SG][2, 2] == pytest.approx(0.5)
    assert f[em.DV, em.SA][2, 2] == pytest.approx(-9.8)
