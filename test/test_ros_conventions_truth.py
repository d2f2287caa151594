"""scenario_player's truth/odometry: the simulation's truth at truth_rate_hz, in the filter's map (ENU at the datum)."""
import numpy as np
import yaml

from nav_core import frames
from nav_core.earth import LocalFrame
from nav_core.recording import Trajectory, write_trajectory_csv
from nav_core.units import DEG


def test_truth_is_taken_at_the_rate_in_enu_at_the_scenario_datum(tmp_path):
    from nav_bringup.scenario_player_node import ScenarioPlayer

    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(yaml.safe_dump({"latitude_deg": 21.0, "longitude_deg": 105.0, "height_m": 10.0,
                                        "trajectory": "paper_drive"}))  # a valid scenario: its datum is read through imu_sim.scenario.load
    (tmp_path / "sim_info.yaml").write_text(yaml.safe_dump({"scenario": str(scenario), "bag_epoch_s": 1.7e9}))
    t = np.arange(0, 20.0, 1 / 64)
    lat, lon = (21.0 + 1e-6 * t) * DEG, (105.0 + 2e-6 * t) * DEG
    yaw = 0.05 * t
    write_trajectory_csv(tmp_path / "truth.csv", Trajectory(t, lat, lon, 10.0 + 0 * t, 0 * t, 0 * t, yaw))

    t_out, enu, quat = ScenarioPlayer._load_truth(tmp_path, 10.0)
    assert len(t_out) == 200 and np.allclose(np.diff(t_out), 0.1, atol=1 / 64)  # one sample per 0.1 s period
    expected = LocalFrame(21.0, 105.0, 10.0).to_enu(21.0 + 1e-6 * t_out, 105.0 + 2e-6 * t_out, 10.0)
    np.testing.assert_allclose(enu, expected, atol=1e-6)
    assert np.allclose(frames.euler_from_quat_xyzw(quat)[2], frames.wrap_angle(0.05 * t_out), atol=1e-6)
    assert ScenarioPlayer._load_truth(tmp_path, 0.0) is None  # truth_rate_hz 0: none
