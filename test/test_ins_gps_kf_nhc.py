"""Non-holonomic constraints (issue 25, first part): a car cannot slide sideways nor take off. On the simulated
paper drive with 60-s GNSS outages they keep the drift to a fraction of the plain filter's; a constraint that does
not fit the vehicle (a wrong mounting) fails its gate and is counted, never applied."""
from pathlib import Path

import numpy as np
import pytest

from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_eval.metrics import drop_fixes, outage_drift, outage_windows, run_case

SCENARIO = Path(__file__).resolve().parents[1] / "config" / "scenarios" / "paper_drive.yaml"


@pytest.fixture
def drive(outage_drive):
    return outage_drive


def _drift(drive, **params):
    sim, windows, gnss = drive
    est, filt = run_case(sim.imu, gnss, bp3010_grade_model(), {"imu_rate_hz": sim.rate_hz, **params})
    return outage_drift(est, sim.truth, filt.frame, windows), filt


def test_constraints_cut_the_drift_through_gnss_outages(drive):
    plain, _ = _drift(drive)
    nhc, filt = _drift(drive, nhc_enabled=True)
    assert plain["windows"] >= 2
    assert nhc["drift_max_m"] < 0.3 * plain["drift_max_m"], (nhc, plain)
    c = filt.counters
    assert c.nhc_updates > 500 and c.nhc_rejected == 0
    assert c.zupts > 0  # at rest the constraint gives way to ZUPT


def test_a_constraint_that_does_not_fit_fails_its_gate_and_is_counted(drive):
    _, filt = _drift(drive, nhc_enabled=True, nhc_mounting="given", mounting_yaw_deg=30.0)  # 30 deg it is not mounted at
    assert filt.counters.nhc_rejected > 50
    status_counts = {k: v for k, v in vars(filt.counters).items() if k.startswith("nhc")}
    assert status_counts["nhc_rejected"] == filt.counters.nhc_rejected


def test_constraints_off_change_nothing(drive):
    sim, _, gnss = drive
    a, _ = run_case(sim.imu, gnss, bp3010_grade_model(), {"imu_rate_hz": sim.rate_hz})
    b, _ = run_case(sim.imu, gnss, bp3010_grade_model(), {"imu_rate_hz": sim.rate_hz, "nhc_enabled": False,
                                                          "mounting_yaw_deg": 10.0, "nhc_lever_arm_x_m": -1.0})
    assert len(a) == len(b) and all(np.array_equal(x.position_n, y.position_n) for x, y in zip(a, b))


@pytest.mark.slow
def test_the_mounting_is_estimated_from_the_drive():
    """The IMU mounted 1 deg rolled, 2 deg pitched and 3 deg yawed in the car, which the filter is not told (the
    whole paper drive): taken as zero the constraints fight the drive and fail their gate; estimated (the default,
    two filter states) they pass and the outages drift as little as with the true mounting given."""
    from nav_core import frames

    sim = simulate(SCENARIO, model=bp3010_grade_model(), seed=3, with_bytes=False)
    windows = outage_windows(60.0, sim.truth.t[-1], 180.0, 60.0, 120.0)
    gnss = drop_fixes(sim.gnss, windows)
    rpy = (1.0, 2.0, 3.0)
    mount = frames.mat_nb_from_euler(*np.radians(rpy))  # the IMU's attitude in the vehicle
    imu = sim.imu.select(slice(None))
    imu.gyro, imu.accel = sim.imu.gyro @ mount, sim.imu.accel @ mount  # body' = mount^T body
    true = {f"mounting_{a}_deg": v for a, v in zip(("roll", "pitch", "yaw"), rpy)}
    runs = {}
    for name, extra in (("plain", {}), ("given zero", {"nhc_enabled": True, "nhc_mounting": "given"}),
                        ("given true", {"nhc_enabled": True, "nhc_mounting": "given", **true}),
                        ("estimated", {"nhc_enabled": True})):
        est, filt = run_case(imu, gnss, bp3010_grade_model(), {"imu_rate_hz": sim.rate_hz, **extra})
        runs[name] = (outage_drift(est, sim.truth, filt.frame, windows)["drift_mean_m"], filt)
    pitch, yaw = runs["estimated"][1].nhc.mounting_deg()
    assert abs(pitch - 2.0) < 0.5 and abs(yaw - 3.0) < 1.0, (pitch, yaw)
    assert runs["given zero"][1].counters.nhc_rejected > 20 and runs["estimated"][1].counters.nhc_rejected == 0
    drifts = {k: v[0] for k, v in runs.items()}
    assert drifts["estimated"] < 1.5 * drifts["given true"] and drifts["estimated"] < 0.3 * drifts["plain"], drifts
