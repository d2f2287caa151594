"""A rate table's yaw per dwell as a nuisance: the Earth rate's horizontal part rotated by a typed start's yaw error."""
from types import SimpleNamespace

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core.earth import RATE as EARTH_RATE

from imu_sim.diagnose import reference

LAT = np.radians(51.0)
DT = 0.02


def _table_case(rate_dps=(60.0, -40.0, 10.0), dwell_s=6.0, yaw_error_deg=(0.0, 0.0, 0.0)):
    """A level one-axis table dwelling at ``rate_dps`` (deg/s) in turn; the truth's yaw is off by ``yaw_error_deg``
    per dwell. Returns (case, gyro residual (n, 3) the yaw errors make: simulated Earth rate less the real one)."""
    t, yaw, segs, err = [], [], [], []
    t0, psi = 0.0, 0.0
    for r, e in zip(rate_dps, yaw_error_deg):
        tk = t0 + DT * np.arange(1, int(dwell_s / DT) + 1)
        t.append(tk)
        yaw.append(psi + np.radians(r) * (tk - t0))
        err.append(np.full(len(tk), np.radians(e)))
        segs.append({"t0": t0, "t1": t0 + dwell_s, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0, "rate_dps": r})
        t0, psi = t0 + dwell_s, yaw[-1][-1]
    t, yaw, err = np.concatenate(t), np.concatenate(yaw), np.concatenate(err)
    w_enu = EARTH_RATE * np.array([0.0, np.cos(LAT), np.sin(LAT)])
    true_rot, sim_rot = Rotation.from_euler("z", yaw[:, None]), Rotation.from_euler("z", (yaw + err)[:, None])
    resid = sim_rot.inv().apply(w_enu) - true_rot.inv().apply(w_enu)
    traj = SimpleNamespace(attitude=SimpleNamespace(rotation=lambda ts: Rotation.from_euler("z", np.interp(ts, t, yaw)[:, None])),
                           geodetic=lambda ts: (np.full(len(ts), LAT), np.zeros(len(ts)), np.zeros(len(ts))))
    case = SimpleNamespace(n=len(t), t=t, sim_t_abs=t, unstated=None, cache={"traj": traj},
                           scenario=SimpleNamespace(source="static_segments", spec=segs))
    return case, resid


def test_a_dwells_yaw_error_is_fitted_out_and_a_constant_offset_is_left_to_the_tests():
    case, yaw_resid = _table_case(yaw_error_deg=(15.0, -10.0, 3.0))
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 1.4e-5, (case.n, 6))  # a navigation-grade gyro at 50 Hz
    offset = np.zeros((case.n, 6))
    offset[:, 0] = 5e-6 * np.sign(np.repeat([60.0, -40.0, 10.0], case.n // 3))  # a misalignment x-z: constant a dwell
    resid = np.hstack([yaw_resid, np.zeros((case.n, 3))]) + offset + noise
    left = reference.clean(case, resid)
    def turning(x):  # the part of gyro x/y that varies within each dwell (its mean is left to the tests)
        parts = np.split(x[:, :2], 3)
        return np.sqrt(np.mean(np.concatenate([p - p.mean(axis=0) for p in parts]) ** 2))
    before, after = turning(resid - offset - noise), turning(left - offset - noise)
    assert after < 0.2 * before, (before, after)  # the rotated Earth rate, down to the fit's noise
    for k in range(3):  # each dwell's mean (the misalignment's constant) is kept
        part = slice(k * case.n // 3, (k + 1) * case.n // 3)
        np.testing.assert_allclose(left[part, 0].mean(), resid[part, 0].mean(), atol=1e-9)
    np.testing.assert_array_equal(left[:, 3:], resid[:, 3:])


def test_a_fixture_of_still_holds_is_left_unchanged():
    case, _ = _table_case()
    for seg in case.scenario.spec:
        seg["rate_dps"] = 0.0
    resid = np.random.default_rng(2).normal(0.0, 1e-5, (case.n, 6))
    np.testing.assert_array_equal(reference.clean(case, resid), resid)
