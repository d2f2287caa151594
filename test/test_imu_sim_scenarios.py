"""imu_sim trajectories and scenario files: paper drive, GNSS-track fit, truth CSV round trip, clear errors."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from nav_core import recording
from nav_core.frames import wrap_angle
from nav_core.units import DEG

from imu_sim import scenario as scenario_mod, trajectory
from imu_sim.scenario import ScenarioError
from imu_sim.simulate import simulate, write_outputs

from conftest import REPO, shared_data


def test_paper_drive_is_45_s_still_then_about_12_minutes_and_5_km_of_driving():
    traj = trajectory.paper_drive()
    t = np.arange(0.0, traj.t1, 0.1)
    speed = np.linalg.norm(traj.velocity_n(t), axis=1)
    assert speed[t < 45.0].max() < 1e-5  # the interpolating spline rings by a few um/s just before the start
    assert speed[(t > 46) & (t < 60)].max() > 5.0
    assert 11.0 * 60 <= traj.duration - 45 <= 13.0 * 60
    assert 4500 <= np.sum(speed) * 0.1 <= 5500


def test_paper_drive_yaml_is_the_built_in_default_scenario():
    sc = scenario_mod.load(REPO / "config" / "scenarios" / "paper_drive.yaml")
    assert sc.source == "trajectory" and sc.spec == "paper_drive"
    assert scenario_mod.build_trajectory(sc).duration == pytest.approx(trajectory.paper_drive().duration)


def test_car_yaw_follows_the_course_and_roll_leans_into_left_turns():
    traj = trajectory.segments_trajectory([{"type": "accelerate", "duration_s": 5, "speed_mps": 10},
                                           {"type": "turn", "duration_s": 10, "angle_deg": 90}], 40.0, 0.0)
    t = np.array([4.0, 10.0, 14.0])
    sample = traj.sample(t)
    course = np.arctan2(sample.velocity_n[:, 1], sample.velocity_n[:, 0])
    np.testing.assert_allclose(wrap_angle(sample.yaw - course), 0.0, atol=1e-3)
    assert sample.roll[1] > 0.5 * DEG  # 10 m/s at ~0.16 rad/s: ~1.6 m/s^2 to the left
    assert sample.yaw[-1] == pytest.approx(90 * DEG, abs=0.02)


def test_gnss_track_fit_passes_through_the_real_fixes_within_centimetres():
    path = shared_data("kfgins_gnss", "GNSS-RTK.txt")
    traj = trajectory.gnss_track_trajectory(path, duration_s=900.0)
    t, lat, lon, h, _ = trajectory.read_gnss_track(path)
    keep = t <= 900.0
    enu_fix = traj.frame.to_enu(lat[keep], lon[keep], h[keep])
    residual = traj.position.enu(t[keep]) - enu_fix
    assert np.sqrt(np.mean(residual[:, :2] ** 2)) < 0.05
    v = traj.velocity_n(t[keep])
    assert np.linalg.norm(v, axis=1).max() > 5.0  # it is a real drive, not a parked car


def test_truth_csv_round_trip_resimulates_the_same_motion(tmp_path):
    first = simulate(REPO / "config" / "scenarios" / "paper_drive.yaml", seed=0, terms=[], with_bytes=False)
    short = recording.Trajectory(*(getattr(first.truth, k)[:64 * 120] for k in
                                   ("t", "lat", "lon", "h", "roll", "pitch", "yaw")))
    recording.write_trajectory_csv(tmp_path / "truth.csv", short)
    (tmp_path / "s.yaml").write_text(yaml.safe_dump({
        "latitude_deg": 21.0285, "longitude_deg": 105.8542, "height_m": 10.0, "trajectory": "truth.csv",
        "physics": {"earth_rotation": {}, "coriolis": {}, "gravity_model": {}}, "gps": False}))
    second = simulate(tmp_path / "s.yaml", seed=0, terms=[], with_bytes=False)
    n = len(second.imu)
    # Vibration is a sensor effect of the first run only; compare low-passed (1 s) signals. The truth CSV
    # keeps 10 significant digits (~1 cm of longitude), so the refitted position spline's
    # acceleration is good to a few 0.01 m/s^2 only; attitude (and so the gyros) is far better.
    kernel = np.ones(64) / 64
    for a, b, tol in ((first.imu.accel[:n], second.imu.accel, 0.1), (first.imu.gyro[:n], second.imu.gyro, 1e-5)):
        for axis in range(3):
            smooth = [np.convolve(x, kernel, "valid") for x in (a[:, axis], b[:, axis])]
            assert np.abs(smooth[0] - smooth[1]).max() < tol


class _QuinticSpeedChange:
    """East position (m) of a car going v0 -> v1 m/s by a quintic smoothstep over [ta, ta + T] s, closed form."""

    def __init__(self, v0, v1, ta, T):
        self.v0, self.dv, self.ta, self.T = v0, v1 - v0, ta, T

    def enu(self, t, nu=0):
        t = np.atleast_1d(np.asarray(t, float))
        tau = np.clip((t - self.ta) / self.T, 0.0, 1.0)
        east = {0: self.v0 * t + self.dv * (self.T * tau**4 * (2.5 - 3 * tau + tau**2)
                                            + np.maximum(t - self.ta - self.T, 0.0)),
                1: self.v0 + self.dv * tau**3 * (10 - 15 * tau + 6 * tau**2),
                2: self.dv / self.T * 30 * tau**2 * (1 - tau) ** 2}[nu]
        return np.column_stack([east, np.zeros_like(t), np.zeros_like(t)])


def _rounded(x, digits):
    return np.array([float(f"{v:.{digits}g}") for v in np.ravel(x)]).reshape(np.shape(x))


@pytest.mark.parametrize("rate_hz,digits", [(10.0, 15), (50.0, 15), (10.0, 10)])
def test_truth_csv_of_a_quintic_speed_change_resimulates_its_analytic_specific_force(tmp_path, rate_hz, digits):
    from scipy.spatial.transform import Rotation

    from nav_core.earth import LocalFrame

    from imu_sim.attitude import QuatSplineAttitude
    from imu_sim.kinematics import FULL, true_rates

    frame = LocalFrame(51.0, -114.0, 1000.0)
    exact = trajectory.TruthTrajectory(frame, _QuinticSpeedChange(2.0, 7.0, 10.0, 3.0), None, 0.0, 30.0)  # 2.1 m/s^2
    rows = np.arange(0.0, 30.0 + 1e-9, 1.0 / rate_hz)
    exact.attitude = QuatSplineAttitude(rows, Rotation.from_euler("z", np.zeros((len(rows), 1))))
    rows_out = exact.sample(rows)
    if digits < 15:  # a user's CSV: ~7 mm steps of longitude, so its velocity columns give the acceleration
        rows_out.lat, rows_out.lon = (_rounded(x / DEG, digits) * DEG for x in (rows_out.lat, rows_out.lon))
        rows_out.h, rows_out.velocity_n = _rounded(rows_out.h, digits), _rounded(rows_out.velocity_n, digits)
    recording.write_trajectory_csv(tmp_path / "truth.csv", rows_out)
    again = trajectory.truth_csv_trajectory(recording.read_trajectory_csv(tmp_path / "truth.csv"), frame)
    t = np.arange(0.5, 29.5, 0.01)
    error = true_rates(again, t, FULL)[1] - true_rates(exact, t, FULL)[1]
    one_s = error.reshape(-1, 100, 3).mean(axis=1)
    # 2 Omega v at 7 m/s is 1e-3 m/s^2: the reference must be far better (the 3-mm smoothing spline was 0.07 off
    # in 1-s means, 0.14 at single instants; from the 10-digit positions alone, 0.04). At 10 Hz the step's ends (a
    # jump in the path's 4th derivative) read as ~1 um of row noise, so the spline smooths by that much: 3e-5 in
    # 1-s means, 9e-3 for an instant.
    assert np.abs(one_s).max() < 1e-4
    assert np.abs(error).max() < 0.015


def test_static_segments_yaml_key_gives_held_attitudes_with_moves_between():
    sc = scenario_mod.from_dict({"latitude_deg": 51.0784, "longitude_deg": -114.1, "height_m": 1100,
                                 "static_segments": trajectory.six_position_segments(hold_s=10, move_s=5)})
    res = simulate(sc, seed=0, terms=[], with_bytes=False)
    t, accel = res.imu.t, res.imu.accel
    up_axes = [(2, 1), (2, -1), (0, 1), (0, -1), (1, 1), (1, -1)]  # roll +90: body y (left) up
    for i, (axis, sign) in enumerate(up_axes):
        still = (t > i * 15 + 1) & (t < i * 15 + 9)
        assert np.all(sign * accel[still, axis] == pytest.approx(9.80665, abs=1e-9)), i


@pytest.mark.parametrize("data, field", [
    ({"latitude_deg": 30, "longitude_deg": 1}, "exactly one trajectory source"),
    ({"latitude_deg": 30, "longitude_deg": 1, "segments": [{"type": "fly", "duration_s": 3}]}, "segments[0].type"),
    ({"latitude_deg": 95, "longitude_deg": 1, "segments": [{"type": "stand", "duration_s": 3}]}, "latitude_deg"),
    ({"latitude_deg": 30, "longitude_deg": 1, "trajectory": "missing.csv"}, "file not found"),
    ({"latitude_deg": 30, "longitude_deg": 1, "trajectory": "paper_drive", "physics": {"gravity": {}}},
     "physics.gravity"),
    ({"latitude_deg": 30, "longitude_deg": 1, "trajectory": "paper_drive", "gps": {"outages": [[5, 2]]}},
     "gps.outages"),
    ({"latitude_deg": 30, "longitude_deg": 1, "trajectory": "paper_drive", "speed": 3}, "unknown key"),
])
def test_bad_scenarios_raise_errors_naming_the_file_and_field(tmp_path, data, field):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError) as err:
        scenario_mod.build_trajectory(scenario_mod.load(path))
    assert str(path) in str(err.value) and field in str(err.value)


def test_missing_scenario_file_is_named():
    with pytest.raises(ScenarioError, match="nowhere.yaml"):
        scenario_mod.load(Path("/nowhere.yaml"))
