"""The report's driver-stamp check: each recorded sample found among the simulated frames by its values."""
import numpy as np

from imu_driver.bp3010_codec import DEFAULT_FORMAT, encode_counts
from nav_bringup.report import frame_time_errors
from nav_core.recording import ImuRecording

EPOCH_S = 1_700_000_000.0


def _sim_dir(tmp_path, n, seed=3):
    counts = np.random.default_rng(seed).integers(-3000, 3000, (n, 6))
    (tmp_path / "bp3010.bin").write_bytes(encode_counts(np.arange(n) % 256, counts))
    return counts


def _recorded(counts, frames, stamps):
    gyro = counts[frames, :3] * DEFAULT_FORMAT.dtheta_lsb_rad * 64
    accel = counts[frames, 3:] * DEFAULT_FORMAT.dv_lsb_mps * 64
    return ImuRecording(stamps, gyro, accel)


def test_stamps_are_compared_with_their_own_frames_times_despite_losses_and_slewing(tmp_path):
    n, lag_s = 3000, 0.004
    counts = _sim_dir(tmp_path, n)
    frames = np.setdiff1d(np.arange(5, n), [100, 101, 2000])  # the recorder missed the first 5 and three more
    stamps = EPOCH_S + (frames + 1) / 64.0 + lag_s
    stamps[:20] += 0.05 * np.linspace(1.0, 0.0, 20)  # a late start slewed out: steps shorter than a period
    errors = frame_time_errors(_recorded(counts, frames, stamps), tmp_path, EPOCH_S)
    # stamps near 1.7e9 s carry 0.24 us of float64 resolution
    assert abs(errors["driver stamp - frame time median (ms)"] - lag_s * 1e3) < 1e-3
    assert abs(errors["driver stamp - frame time p1 (ms)"] - lag_s * 1e3) < 1e-3
    assert abs(errors["driver stamp - frame time largest (ms)"] - (lag_s + 0.05) * 1e3) < 1e-3


def test_samples_that_match_no_frame_give_no_figure(tmp_path):
    counts = _sim_dir(tmp_path, 500)
    rec = _recorded(counts, np.arange(100), EPOCH_S + np.arange(1, 101) / 64.0)
    rec.gyro[:8] += 1.0
    assert frame_time_errors(rec, tmp_path, EPOCH_S) is None
