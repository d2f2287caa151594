"""The forward-backward (RTS) smoother of the closed-loop filter (issue 25): on a linear system it equals the
textbook open-loop RTS smoother; on the simulated paper drive with 60-s GNSS outages it shrinks the error and
the covariance, with NHC on too; ``ins-gps-kf replay --smooth`` writes both trajectories."""
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import chi2

from imu_sim.models import bp3010_grade_model
from nav_core import recording
from nav_core.earth import LocalFrame
from nav_eval.metrics import truth_at
from ins_gps_kf import config
from ins_gps_kf import synthetic as syn
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from ins_gps_kf.replay import forward_path, main
from ins_gps_kf.smoother import ForwardStore, backward, run_smoothed



def _linear_closed_loop(ram_rows, block_rows, seed=0, steps=60):
    """A 1-D constant-velocity track measured in position, run closed loop (nominal corrected, error reset) into
    a ForwardStore, and open loop (textbook KF + RTS); returns (closed-loop smoothed, RTS smoothed) states."""
    rng = np.random.default_rng(seed)
    dt, q, r = 0.5, 0.2, 1.0
    f = np.array([[1.0, dt], [0.0, 1.0]])
    qd = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    h = np.array([[1.0, 0.0]])
    x_true = np.array([0.0, 1.0])
    x, p = np.array([0.5, 0.0]), np.diag([4.0, 4.0])
    store = ForwardStore(2, ram_rows=ram_rows)
    post, prior, post_cov, prior_cov = [], [], [], []
    for k in range(steps):
        if k:
            x_true = f @ x_true + rng.multivariate_normal(np.zeros(2), qd)
            x, p = f @ x, f @ p @ f.T + qd
            store.predicted(f, p)
        prior.append(x.copy()), prior_cov.append(p.copy())
        if k % 7 < 5:  # outages of two steps
            z = h @ x_true + rng.normal(0.0, np.sqrt(r))
            s = h @ p @ h.T + r
            gain = p @ h.T / s
            dx = (gain @ (h @ x - z)).ravel()  # estimate minus truth, fed back
            store.corrected(dx)
            x, p = x - dx, (np.eye(2) - gain @ h) @ p
        post.append(x.copy()), post_cov.append(p.copy())
        store.epoch(SimpleNamespace(cov=p))
    e_s, p_s = np.zeros((steps, 2)), np.zeros((steps, 2, 2))
    for lo, e, p in backward(store, block_rows):
        e_s[lo:lo + len(e)], p_s[lo:lo + len(e)] = e, p
    closed = np.array(post) - e_s
    store.close()
    xs, ps = [post[-1]], [post_cov[-1]]
    for k in range(steps - 2, -1, -1):
        c = post_cov[k] @ f.T @ np.linalg.inv(prior_cov[k + 1])
        xs.insert(0, post[k] + c @ (xs[0] - prior[k + 1]))
        ps.insert(0, post_cov[k] + c @ (ps[0] - prior_cov[k + 1]) @ c.T)
    return closed, np.array(xs), p_s, np.array(ps)


@pytest.mark.parametrize("ram_rows, block_rows", [(1000, 1000), (7, 5)])  # in memory; spilled, in blocks
def test_closed_loop_smoother_equals_textbook_rts_on_a_linear_system(ram_rows, block_rows):
    closed, rts, cov_closed, cov_rts = _linear_closed_loop(ram_rows, block_rows)
    np.testing.assert_allclose(closed, rts, atol=1e-9)
    np.testing.assert_allclose(cov_closed, cov_rts, atol=1e-9)


@pytest.fixture
def drive(outage_drive):
    return outage_drive


def _smoothed_run(drive, **params):
    sim, windows, gnss = drive
    filt = InsGpsFilter(config.from_params({"imu_rate_hz": sim.rate_hz, **params}), bp3010_grade_model())
    forward, smoothed = run_smoothed(filt, run, sim.imu, gnss)
    t = np.array([e.t for e in forward])
    ref = truth_at(sim.truth, filt.frame, t).enu
    inside = np.zeros(len(t), bool)
    for t0, t1 in windows:
        inside |= (t >= t0) & (t <= t1)
    return forward, smoothed, ref, inside


def _horizontal(est, ref):
    return np.hypot(*(np.array([e.position_n for e in est]) - ref)[:, :2].T)


@pytest.mark.parametrize("params", [{}, {"nhc_enabled": True}], ids=["plain", "nhc"])
def test_smoothed_covariance_is_never_larger_and_the_outage_error_shrinks(drive, params):
    forward, smoothed, ref, inside = _smoothed_run(drive, **params)
    var_f = np.array([np.diag(e.cov) for e in forward])
    var_s = np.array([np.diag(e.cov) for e in smoothed])
    assert np.all(var_s <= var_f * (1 + 1e-9) + 1e-15)
    h_f, h_s = _horizontal(forward, ref), _horizontal(smoothed, ref)
    assert inside.sum() > 200
    # through the outages the smoothed error is no larger in >= 95 % of epochs (measured 95.0 % plain, 98.3 % NHC)
    assert np.mean(h_s[inside] <= h_f[inside]) >= 0.95
    assert np.sqrt(np.mean(h_s**2)) < 0.2 * np.sqrt(np.mean(h_f**2))  # measured 0.06x plain, 0.05x NHC
    # with GNSS the smoothed RMS is lower too (measured 0.83x plain, 0.87x NHC)
    assert np.sqrt(np.mean(h_s[~inside] ** 2)) < np.sqrt(np.mean(h_f[~inside] ** 2))
    # position NEES beyond its chi-square 99 % point: measured 2.7 % / 1.2 % plain, 4.8 % / 1.1 % NHC (forward /
    # smoothed; 12.8 % / 5.6 % and 16.2 % / 9.1 % while ZUPTs were applied to a car pulling away)
    beyond = {k: np.mean(_nees(est, ref) > chi2.ppf(0.99, 3)) for k, est in (("f", forward), ("s", smoothed))}
    assert beyond["f"] < 0.07 and beyond["s"] < 0.03, beyond


@pytest.fixture(scope="module")
def true_model_drives():
    """Two synthetic circle drives (1-m GNSS throughout) whose IMU errors are what the filter's sensor model says
    (white noise, constant biases within the initial stds): per drive (forward, smoothed, truth ENU) after the
    heading is known. Where the model is right, forward and smoothed must both be consistent."""
    from nav_core import sensor_model as sm

    rate, gw, aw = 64.0, 1e-3, 2e-3
    motion = syn.circle(still_s=60.0, accel_s=10.0, straight_s=10.0, turn_s=300.0, yaw_rate=0.03)
    model = sm.SensorModel(sample_rate_hz=rate)
    model.gyro.white_noise, model.accel.white_noise = np.full(3, gw), np.full(3, aw)
    model.gyro.bias_instability = model.accel.bias_instability = np.zeros(3)
    model.gyro.rate_random_walk, model.accel.rate_random_walk = np.full(3, 1e-6), np.full(3, 1e-5)
    t_true, pos_true, _, _ = syn.truth(motion, rate)
    ideal = syn.ideal_imu(motion, rate)
    out = []
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        imu = syn.add_imu_errors(ideal, rng, rng.normal(0, 2e-4, 3), rng.normal(0, 0.02, 3), gw, aw)
        gnss = syn.gnss(motion, rate, 1.0, rng)
        filt = InsGpsFilter(config.from_params({"imu_rate_hz": rate, "init_accel_bias_std_mg": 3.0}), model)
        forward, smoothed = run_smoothed(filt, run, imu, gnss)
        t = np.array([e.t for e in forward])
        origin = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m).to_enu(
            *filt.frame.to_geodetic(np.zeros((1, 3))))[0]  # the filter's datum is the first (noisy) fix
        ref = np.column_stack([np.interp(t, t_true, pos_true[:, i]) for i in range(3)]) - origin
        keep = t > 90.0
        out.append(([e for e, k in zip(forward, keep) if k], [e for e, k in zip(smoothed, keep) if k], ref[keep]))
    return out


def _nees(est, ref):
    err = np.array([e.position_n for e in est]) - ref
    return np.array([d @ np.linalg.solve(e.cov[:3, :3], d) for d, e in zip(err, est)])


def test_forward_and_smoothed_nees_are_consistent_where_the_model_is_right(true_model_drives):
    """Position NEES (3 dof): mean near 3 and few epochs beyond the chi-square 99 % point, forward and smoothed
    alike (measured means 2.93 / 3.20 forward, 1.98 / 3.96 smoothed). On the paper drive, whose simulator has errors the
    model does not state, both are overconfident: bench_ins_gps_kf_outages prints them."""
    for kind in (0, 1):
        nees = np.concatenate([_nees(run_[kind], run_[2]) for run_ in true_model_drives])
        assert 2.0 < nees.mean() < 4.2, (kind, nees.mean())
        assert np.mean(nees > chi2.ppf(0.99, 3)) < 0.03, (kind, np.mean(nees > chi2.ppf(0.99, 3)))


def test_smoothed_error_is_no_larger_as_often_as_an_optimal_smoother_allows(true_model_drives):
    """The smoothed horizontal error is no larger than the forward one in the share of epochs the two covariances
    predict for an optimal smoother (smoother.no_worse_probability; measured 86.3 % against 86.2 %), which with GNSS
    throughout is well short of issue 25's 95 %: that target is out of reach of any smoother there."""
    from ins_gps_kf.smoother import no_worse_probability

    measured, expected = [], []
    for forward, smoothed, ref in true_model_drives:
        h_f, h_s = _horizontal(forward, ref), _horizontal(smoothed, ref)
        measured.append(h_s <= h_f)
        expected.append(no_worse_probability(np.array([e.cov[:2, :2] for e in forward]),
                                             np.array([e.cov[:2, :2] for e in smoothed]), draws=400))
    measured, expected = np.concatenate(measured).mean(), np.concatenate(expected).mean()
    assert abs(measured - expected) < 0.05 and expected < 0.95, (measured, expected)


def test_replay_smooth_writes_smoothed_and_forward_trajectories(tmp_path, capsys):
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=25.0)
    rng = np.random.default_rng(7)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, 32.0), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, 32.0, 1.0, rng)
    imu_csv = recording.write_imu_csv(tmp_path / "imu.csv", imu)
    gnss_csv = recording.write_gnss_csv(tmp_path / "gnss.csv", gnss)
    out = tmp_path / "traj.csv"
    code = main(["replay", "--recording", str(imu_csv), "--gnss", str(gnss_csv), "--model", "default", "--out",
                 str(out), "--quiet", "--no-plot", "--smooth", "--param", "alignment_time_s=15.0"])
    assert code == 0, capsys.readouterr()
    smoothed, forward = recording.read_trajectory_csv(out), recording.read_trajectory_csv(forward_path(out))
    assert forward_path(out).name == "traj.forward.csv"
    np.testing.assert_array_equal(smoothed.t, forward.t)
    assert np.all(smoothed.extra["std_e"] <= forward.extra["std_e"] * (1 + 1e-9))
    assert np.mean(smoothed.extra["std_e"] < 0.99 * forward.extra["std_e"]) > 0.5
    assert main(["replay", "--recording", str(imu_csv), "--gnss", str(gnss_csv), "--model", "default", "--out",
                 str(tmp_path / "other.csv"), "--quiet", "--no-plot", "--smooth"]) == 0
    code = main(["replay", "--recording", str(imu_csv), "--gnss", str(gnss_csv), "--model", "default", "--out",
                 str(out), "--quiet", "--no-plot", "--smooth"])
    assert code == 2  # existing outputs are refused without --force


def test_replay_smooth_writes_the_bytes_of_the_estimate_list_path(tmp_path, monkeypatch, capsys, wheel_drive):
    """``replay --smooth`` keeps compact rows (offline.EstimateTable) and smooths block by block (spilled to disk
    here, in blocks of 16 epochs); its CSVs are byte for byte what the Estimate-list path writes (run_smoothed,
    to_trajectory), with NHC, the odometer (bad speeds included) and scale-factor states on."""
    from ins_gps_kf import replay
    from ins_gps_kf.offline import to_trajectory

    imu, gnss, wheel = wheel_drive
    files = {"imu": recording.write_imu_csv(tmp_path / "imu.csv", imu),
             "gnss": recording.write_gnss_csv(tmp_path / "gnss.csv", gnss),
             "odo": recording.write_wheel_speed_csv(tmp_path / "odo.csv", wheel)}
    params = {"alignment_time_s": 15.0, "nhc_enabled": True, "estimate_scale_factors": True}
    monkeypatch.setattr(replay, "SMOOTH_BLOCK", 16)
    out = tmp_path / "traj.csv"
    code = main(["replay", "--recording", str(files["imu"]), "--gnss", str(files["gnss"]), "--odometry",
                 str(files["odo"]), "--model", "default", "--out", str(out), "--quiet", "--no-plot", "--smooth"]
                + [f"--param={k}={str(v).lower()}" for k, v in params.items()])
    assert code == 0, capsys.readouterr()
    filt = InsGpsFilter(config.from_params({**config.defaults(), **params, "odometer_enabled": True}),
                        replay.load_model("default"))
    odo = recording.read_wheel_speed(files["odo"])
    forward, smoothed = run_smoothed(filt, run, recording.read_imu(files["imu"]), recording.read_gnss(files["gnss"]),
                                     odometry=(odo.t, odo.speed_mps))
    assert len(forward) > 3 * 16 and forward[0].scale_factors is not None and filt.counters.odometer_updates > 0
    for est, path in ((smoothed, tmp_path / "list.csv"), (forward, tmp_path / "list.forward.csv")):
        recording.write_trajectory_csv(path, to_trajectory(est, filt.frame))
    assert (tmp_path / "list.csv").read_bytes() == out.read_bytes()
    assert (tmp_path / "list.forward.csv").read_bytes() == forward_path(out).read_bytes()
