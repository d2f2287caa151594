"""The filter's gyro bias from odometry/filtered (sensor_health.odometry_bias): the calibrated raw gyro over each
filter epoch less the epoch's bias-corrected rate is ins_gps_kf's own bias state on a drive; it is recovered through
turns, with the odometry arriving before or after the raw samples of its epoch; spans that are not one epoch are
skipped, odometry the IMU never reaches is not held without bound; a step shows within the average."""
import numpy as np

from ins_gps_kf import config, synthetic
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from nav_core.sensor_model import TriadModel, corrector
from sensor_health.odometry_bias import MAX_QUEUED, OdometryBias

FS, EPOCH_S = 64.0, 0.5


def _run(bias_of_t, duration_s=30.0, odometry_first=False, seed=0):
    """A turning vehicle's raw gyro (white noise 0.01 rad/s per sample) and the filter's epoch rates less
    ``bias_of_t(t)`` (3,); pushed in 0.1-s batches, the odometry of each epoch before or after its samples."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration_s * FS)) / FS
    true = np.column_stack([0.05 * np.sin(0.7 * t), 0.02 * np.cos(1.3 * t), 0.3 * np.sin(0.2 * t)])
    raw = true + np.array([2e-3, -1e-3, 4e-3]) + rng.normal(0, 0.01, (len(t), 3))
    epochs = np.arange(EPOCH_S, duration_s, EPOCH_S)
    est = OdometryBias(average_s=10.0, max_epoch_s=1.0)
    k = 0
    for a in range(0, len(t), int(0.1 * FS)):
        b = min(a + int(0.1 * FS), len(t))
        if not odometry_first:
            est.push_imu(t[a:b], raw[a:b])
        while k < len(epochs) and epochs[k] <= t[b - 1]:  # the epochs these samples complete
            sel = (t > epochs[k] - EPOCH_S) & (t <= epochs[k])
            est.push_odometry(epochs[k], raw[sel].mean(axis=0) - bias_of_t(epochs[k]))
            k += 1
        if odometry_first:
            est.push_imu(t[a:b], raw[a:b])
    return est


def test_the_filter_bias_is_recovered_through_turns_whichever_comes_first():
    bias = np.array([1.5e-3, -0.5e-3, 3e-3])
    for first in (False, True):
        got = _run(lambda _t: bias, odometry_first=first).estimate()
        assert got is not None and got[2] == 20  # 10 s of 0.5-s epochs
        np.testing.assert_allclose(got[0], bias, atol=1e-9)  # the epochs' samples match exactly: no noise left


def test_a_step_of_the_filter_bias_shows_within_the_average_and_long_gaps_are_skipped():
    step = np.array([0.0, 0.0, 5e-3])
    est = _run(lambda t: step * (t > 15.0), duration_s=30.0)
    np.testing.assert_allclose(est.estimate()[0], step, atol=1e-9)
    gap = OdometryBias(max_epoch_s=1.0)
    t = np.arange(0, 10, 1 / FS)
    gap.push_imu(t, np.zeros((len(t), 3)))
    for te in (1.0, 3.0, 5.0, 5.5, 8.0):  # only 5.0 -> 5.5 is one epoch
        gap.push_odometry(te, np.zeros(3))
    assert gap.epochs == 1 and gap.estimate() is None
    other_clock = OdometryBias()  # odometry the IMU stamps never reach is held, but not without bound
    for k in range(5000):
        other_clock.push_odometry(1e9 + 0.5 * k, np.zeros(3))
    assert len(other_clock.queue) == MAX_QUEUED and other_clock.epochs == 0


def test_it_is_the_filters_own_gyro_bias_state_on_a_drive_with_a_calibrated_input():
    cfg = config.from_params({"alignment_time_s": 10.0})  # 64 Hz in, 2-Hz epochs
    motion = synthetic.circle(still_s=15.0, accel_s=5.0, straight_s=10.0, turn_s=30.0)
    rng = np.random.default_rng(3)
    imu = synthetic.add_imu_errors(synthetic.ideal_imu(motion, cfg.imu_rate_hz), rng, gyro_bias=2e-3,
                                   gyro_white=1e-3, accel_white=1e-3)  # what the filter's bias state must learn
    calib = TriadModel(bias=np.array([1e-2, -5e-3, 3e-3]), scale_factor=np.array([0.01, -0.02, 0.015]))
    raw = calib.apply(imu.gyro)  # imu/data_raw; the filter gets it calibrated (wmra_node, denoising aside)
    estimates = run(InsGpsFilter(cfg), imu, synthetic.gnss(motion, cfg.imu_rate_hz, 0.5, rng))
    view = OdometryBias(average_s=10.0)
    view.push_imu(imu.t, corrector(calib)(raw))
    for e in estimates:
        view.push_odometry(e.t, e.angular_rate_b)
    bias, interval, n = view.estimate()
    state = np.mean([e.gyro_bias for e in estimates if e.t > estimates[-1].t - 10.0], axis=0)
    assert n == 20 and estimates[-1].status == "navigating"
    np.testing.assert_allclose(bias, state, atol=1e-5)  # the state moves within the 10 s by a few 1e-6
    assert np.all(np.abs(state - 2e-3) < 5e-4)  # and it has learned the bias: the comparison is not of zeros
