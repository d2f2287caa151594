"""The replay's whole-run check of fixes against the INS (ins_gps_kf.track_check): its INS velocity changes, summed
in chunks and kept only at the windows' edges, are the whole-run sum's."""
import numpy as np
from scipy.spatial.transform import Rotation

from ins_gps_kf import track_check


def test_chunked_ins_velocity_changes_equal_the_whole_run_sum(monkeypatch):
    rng = np.random.default_rng(4)
    imu_t = np.cumsum(rng.uniform(0.005, 0.02, 300))
    imu_t[100] = imu_t[99]  # a repeated stamp, and a 2-s gap: intervals the sum skips
    imu_t[200:] += 2.0
    accel = rng.normal(0.0, 3.0, (300, 3))
    est_t = np.linspace(imu_t[0], imu_t[-1], 40)
    quats = Rotation.random(40, random_state=1).as_quat()
    bias = rng.normal(0.0, 0.1, (40, 3))
    k = np.clip(np.searchsorted(est_t, imu_t), 0, len(est_t) - 1)
    dt = np.diff(imu_t, prepend=imu_t[0])
    dt = np.where((dt > 0) & (dt < 1.0), dt, 0.0)
    f_n = Rotation.from_quat(quats[k]).apply(accel - bias[k])
    whole = np.vstack([np.zeros(2), np.cumsum(f_n[:, :2] * dt[:, None], axis=0)])  # before sample i: row i
    at = np.array([0, 1, 6, 7, 8, 99, 100, 101, 150, 200, 299, 300])
    monkeypatch.setattr(track_check, "CHUNK", 7)
    np.testing.assert_allclose(track_check._ins_velocity_changes(imu_t, accel, est_t, quats, bias, at), whole[at],
                               rtol=1e-12, atol=1e-12)
