"""The filter's gyro bias from odometry/filtered (sensor_health.odometry_bias): the raw gyro over each filter epoch
less the epoch's bias-corrected rate recovers the filter's bias, through turns, with the odometry arriving before or
after the raw samples of its epoch; spans that are not one epoch are skipped; a step shows within the average."""
import numpy as np

from sensor_health.odometry_bias import OdometryBias

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
