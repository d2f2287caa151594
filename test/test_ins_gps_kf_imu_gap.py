"""A lost serial port while driving: the filter bridges a forward IMU gap instead of re-aligning, and recovers."""


from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

pytest.importorskip("imu_sim")
from nav_eval import metrics as evaluate  # noqa: E402
from ins_gps_kf.filter import NAVIGATING  # noqa: E402
from nav_core.units import DEG  # noqa: E402

SCENARIO = Path(__file__).resolve().parents[1] / "config" / "scenarios" / "paper_drive.yaml"
GAP = (200.0, 205.0)  # s: the car is driving


@pytest.fixture(scope="module")
def drive():
    from imu_sim.models import bp3010_grade_model
    from imu_sim.simulate import simulate

    model = bp3010_grade_model()
    sim = simulate(str(SCENARIO), model=model, seed=3, with_bytes=False)
    imu = sim.imu.between(0.0, 300.0)
    cut = imu.select((imu.t < GAP[0]) | (imu.t >= GAP[1]))
    return sim, imu, cut, model


def _horizontal_error(est, sim, frame):
    t = np.array([e.t for e in est])
    pos = np.array([e.position_n for e in est])
    truth = frame.to_enu(sim.truth.lat / DEG, sim.truth.lon / DEG, sim.truth.h)
    ref = np.column_stack([np.interp(t, sim.truth.t, truth[:, i]) for i in range(3)])
    return t, np.hypot(*(pos - ref)[:, :2].T)


@pytest.mark.slow
def test_a_5_s_imu_gap_while_driving_is_bridged_and_the_error_recovers(drive):
    sim, imu, cut, model = drive
    params = {"imu_rate_hz": sim.rate_hz}
    est_ref, filt_ref = evaluate.run_case(imu, sim.gnss, model, params)
    est, filt = evaluate.run_case(cut, sim.gnss, model, params)
    assert filt.counters.resets == 0 and filt.counters.gaps_bridged == 1
    assert filt.status == NAVIGATING
    t, err = _horizontal_error(est, sim, filt.frame)
    t_ref, err_ref = _horizontal_error(est_ref, sim, filt_ref.frame)
    before = np.sqrt(np.mean(err_ref[(t_ref > 150) & (t_ref < GAP[0])] ** 2))
    # Back under 2x its pre-fault level within 20 s of the port coming back, and stays there.
    after = err[(t > GAP[1] + 20.0) & (t < 300.0)]
    assert np.sqrt(np.mean(after**2)) < 2.0 * before + 0.3, (before, np.sqrt(np.mean(after**2)))
    # Holding the last second's mean (not one noisy sample) keeps the bridged solution within metres.
    assert err[(t > GAP[0]) & (t < GAP[1] + 20.0)].max() < 5.0


@pytest.mark.slow
def test_with_bridging_off_the_same_gap_resets_the_filter(drive):
    sim, imu, cut, model = drive
    est, filt = evaluate.run_case(cut, sim.gnss, model, {"imu_rate_hz": sim.rate_hz, "max_bridged_gap_s": 0.0})
    assert filt.counters.resets == 1 and filt.counters.gaps_bridged == 0
