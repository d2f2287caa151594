"""The whole graph live, launch_testing style: node processes on DDS, an rclpy probe, exit codes.

scenario_player (emulator -> pty, GPS, /clock) -> bp3010_driver -> wmra_node -> ins_gps_kf_node,
with allan_node and bag_record, on the first 100 s of the paper drive at 2x real time.
"""
from pathlib import Path

import numpy as np
import pytest
from nav_msgs.msg import Odometry

from nav_bringup import demo
from nav_bringup.graph import PARAMS_FILE, REPO, Graph
from nav_bringup.live_status_ros import diag_values, graph_probe
from nav_bringup.truth import TruthTrack
from nav_core import recording
from nav_core.ros_node import stamp_to_s

pytestmark = [pytest.mark.ros, pytest.mark.slow]
MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
SIM_SECONDS = 100.0
RATE = 2.0


@pytest.fixture(scope="module")
def sim_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "run"
    demo.simulate_scenario(REPO / "config" / "scenarios" / "paper_drive.yaml", MODEL, 7, out,
                             duration_s=SIM_SECONDS + 2, fmt="csv")
    return out


def _specs(sim_dir: Path, run: Path) -> list:
    """nav-demo's graph for this simulation: the one description users start (launch file and nav-demo)."""
    args = demo.parse_args(["--rate", str(RATE), "--duration", str(SIM_SECONDS), "--model", str(MODEL)])
    return demo.graph_specs(args, run, sim_dir)


def test_graph_runs_the_paper_drive_and_every_node_exits_cleanly(sim_dir, tmp_path, ros_env):
    graph = Graph(_specs(sim_dir, tmp_path), ros_env, PARAMS_FILE, log_dir=tmp_path / "logs")
    try:
        with graph_probe({"odometry/filtered": Odometry}) as probe:
            graph.start(timeout_s=60)  # every node said it is ready
            finished = probe.spin_until(lambda p: "scenario_player" in graph.dead(), SIM_SECONDS / RATE + 90)
            assert finished, {k: v.output[-2000:] for k, v in graph.procs.items()}
            probe.spin_until(lambda p: False, 2.0)
            assert graph.dead() == {"scenario_player": 0}, "no other node may exit during the run"
    finally:
        codes = graph.stop()
    assert all(code == 0 for code in codes.values()), codes

    # Odometry at the 2 Hz filter rate once aligned (45 s stationary head, then navigation).
    odom = [m for _, m in probe.received["odometry/filtered"]]
    stamps = np.array([stamp_to_s(m.header.stamp) for m in odom])
    assert len(odom) > 80
    assert np.median(np.diff(stamps)) == pytest.approx(0.5, abs=1e-6)
    assert odom[0].header.frame_id == "map" and odom[0].child_frame_id == "base_link"
    assert odom[-1].pose.covariance[0] > 0 and odom[-1].twist.covariance[0] > 0

    # Position error against the simulator's truth, within what the filter issue measured for this drive.
    truth = TruthTrack.from_sim_dir(sim_dir)
    pos = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z] for m in odom])
    horizontal = np.hypot(*(pos - truth.at(stamps))[:, :2].T)
    gnss = recording.read_gnss(sim_dir / "gnss.csv")
    gps_err = np.hypot(*(truth.frame.to_enu(np.degrees(gnss.lat), np.degrees(gnss.lon), gnss.h)
                         - truth.at(gnss.t + truth.epoch_s))[:, :2].T)
    rms = np.sqrt(np.mean(horizontal**2))
    assert rms < 1.5, f"horizontal RMS {rms:.2f} m"
    assert rms < 1.5 * np.sqrt(np.mean(gps_err**2)) + 0.5

    # Diagnostics clean: no corrupt frames, no rejected fixes, the Allan node characterised the head.
    by_node = diag_values(probe)
    assert int(by_node["bp3010_driver"]["checksum_errors"]) == 0
    assert int(by_node["bp3010_driver"]["lost_frames"]) == 0
    assert int(by_node["ins_gps_kf_node"]["rejected_fixes"]) == 0
    assert by_node["ins_gps_kf_node"]["state"] == "navigating"
    assert (tmp_path / "allan" / "sensor_model.yaml").exists()
    recorded = recording.read_odometry(tmp_path / "bag")
    assert len(recorded) >= len(odom) - 2
