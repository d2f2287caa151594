"""The whole graph live, launch_testing style: node processes on DDS, an rclpy probe, exit codes.

scenario_player (emulator -> pty, GPS, /clock) -> bp3010_driver -> wmra_node -> ins_gps_kf_node,
with allan_node and bag_record, as nav-demo starts them (the one graph description), on the paper
drive's first 6 minutes at 8x (what the README claims: the filter's horizontal error below the raw
GPS's). A slower rate adds no check of its own: test_nav_bringup_busy_cpu runs this graph at 3x (live
odometry = offline replay, no stamp back, nothing dropped), and at 8x an intake chunk holds the most
samples (about five), the harder case for the twist and the live = offline equality below.
"""
from pathlib import Path

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from scipy.spatial.transform import Rotation

from nav_bringup import demo, report
from nav_bringup.graph import PARAMS_FILE, REPO, Graph
from nav_bringup.live_status_ros import diag_values, graph_probe
from nav_bringup.truth import TruthTrack
from nav_core import recording
from nav_core.ros_node import stamp_to_s

pytestmark = [pytest.mark.ros, pytest.mark.slow]
MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
RUNS = {8.0: 360.0}  # replay rate -> simulated seconds played
SETTLED_S = 120.0
"""From here on the heading taken from the course (at ~50 s, after the 45-s stationary alignment) has settled:
before, its few-degree error puts up to 0.9 m/s of the 9.5 m/s into the body's y axis."""


@pytest.fixture(scope="module")
def sim_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "run"
    demo.simulate_scenario(REPO / "config" / "scenarios" / "paper_drive.yaml", MODEL, 7, out,
                           duration_s=max(RUNS.values()) + 2, fmt="csv")
    return out


def _specs(sim_dir: Path, run: Path, rate: float) -> list:
    """nav-demo's graph for this simulation: the one description users start (launch file and nav-demo)."""
    args = demo.parse_args(["--rate", str(rate), "--duration", str(RUNS[rate]), "--model", str(MODEL)])
    return demo.graph_specs(args, run, sim_dir)


def _truth_velocity_b(truth: TruthTrack, t) -> np.ndarray:
    """The truth's body velocity (n, 3) m/s at stamps ``t``."""
    vel_n = np.column_stack([np.interp(t, truth.t, truth.velocity_n[:, i]) for i in range(3)])
    rpy = np.column_stack([np.interp(t, truth.t, np.unwrap(truth.rpy[:, i])) for i in range(3)])
    mat_bn = Rotation.from_euler("ZYX", rpy[:, ::-1]).as_matrix().transpose(0, 2, 1)
    return np.einsum("nij,nj->ni", mat_bn, vel_n)


@pytest.mark.parametrize("rate", sorted(RUNS))
def test_graph_runs_the_paper_drive_and_every_node_exits_cleanly(sim_dir, tmp_path, ros_env, rate):
    seconds = RUNS[rate]
    graph = Graph(_specs(sim_dir, tmp_path, rate), ros_env, PARAMS_FILE, log_dir=tmp_path / "logs")
    try:
        with graph_probe({"odometry/filtered": Odometry}) as probe:
            graph.start(timeout_s=60)  # every node said it is ready
            finished = probe.spin_until(lambda p: "scenario_player" in graph.dead(), seconds / rate + 90)
            assert finished, {k: v.output[-2000:] for k, v in graph.procs.items()}
            probe.spin_until(lambda p: False, 2.0)
            # the Allan worker runs niced: on a loaded machine its result may come after the drive's end, and a
            # user waits for it too (the suite once stopped the graph first and found no sensor_model.yaml)
            probe.spin_until(lambda p: (tmp_path / "allan" / "sensor_model.yaml").exists(), 60.0)
            assert graph.dead() == {"scenario_player": 0}, "no other node may exit during the run"
    finally:
        codes = graph.stop()
    assert all(code == 0 for code in codes.values()), codes

    # Odometry at the 2 Hz filter rate once aligned (45 s stationary head, then navigation).
    odom = [m for _, m in probe.received["odometry/filtered"]]
    stamps = np.array([stamp_to_s(m.header.stamp) for m in odom])
    assert len(odom) > 2 * (seconds - 60.0)
    assert np.median(np.diff(stamps)) == pytest.approx(0.5, abs=1e-6)
    assert odom[0].header.frame_id == "map" and odom[0].child_frame_id == "base_link"
    assert odom[-1].pose.covariance[0] > 0 and odom[-1].twist.covariance[0] > 0

    # Position error against the simulator's truth: below the raw GPS's once the heading has settled, as the
    # README claims for the whole drive (0.56 m against 0.72 m).
    truth = TruthTrack.from_sim_dir(sim_dir)
    pos = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z] for m in odom])
    settled = stamps >= truth.epoch_s + SETTLED_S
    horizontal = np.hypot(*(pos - truth.at(stamps))[:, :2].T)
    gnss = recording.read_gnss(sim_dir / "gnss.csv")
    gps_settled = (gnss.t >= SETTLED_S) & (gnss.t <= seconds)
    gps_err = np.hypot(*(truth.frame.to_enu(np.degrees(gnss.lat), np.degrees(gnss.lon), gnss.h)
                         - truth.at(gnss.t + truth.epoch_s))[gps_settled, :2].T)
    rms, gps_rms = np.sqrt(np.mean(horizontal[settled] ** 2)), np.sqrt(np.mean(gps_err**2))
    print(f"rate {rate}: horizontal RMS {rms:.3f} m after {SETTLED_S:.0f} s over {settled.sum()} epochs, "
          f"raw GPS {gps_rms:.3f} m; all epochs {np.sqrt(np.mean(horizontal**2)):.3f} m")
    assert rms < gps_rms, f"horizontal RMS {rms:.2f} m, raw GPS {gps_rms:.2f} m"
    assert np.sqrt(np.mean(horizontal**2)) < 1.5

    # twist.linear against the truth's body velocity: rotated with the estimate's own attitude, however many
    # samples an intake chunk held (8x: about five per chunk)
    vel_b = np.array([[m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z] for m in odom])
    vel_err = vel_b - _truth_velocity_b(truth, stamps)
    vel_rms = np.sqrt(np.mean(vel_err[settled] ** 2, axis=0))
    print(f"rate {rate}: twist.linear RMS error forward/left/up {np.round(vel_rms, 3)} m/s")
    assert np.all(vel_rms < 0.3), vel_rms  # measured 0.17 / 0.24 / 0.05 at 8x: the heading's error at 9.5 m/s

    # Diagnostics clean: no corrupt frames, no rejected fixes, the Allan node characterised the head.
    by_node = diag_values(probe)
    assert int(by_node["bp3010_driver"]["checksum_errors"]) == 0
    assert int(by_node["bp3010_driver"]["lost_frames"]) == 0
    assert int(by_node["ins_gps_kf_node"]["rejected_fixes"]) == 0
    assert by_node["ins_gps_kf_node"]["state"] == "navigating"
    assert (tmp_path / "allan" / "sensor_model.yaml").exists()
    recorded = recording.read_odometry(tmp_path / "bag")
    assert len(recorded) >= len(odom) - 2

    # The node only converts: its odometry, twist included, is the offline replay's of the same recorded input
    # (a twist rotated by the attitude after the whole intake chunk differed by up to cm/s at 8x)
    specs = _specs(sim_dir, tmp_path, rate)
    off = report.compare_with_offline(tmp_path / "bag", recorded, demo.filter_params(PARAMS_FILE, specs),
                                      report.filter_status(report.last_diagnostics(tmp_path / "bag")))
    print(f"rate {rate}: live - offline {off['largest difference (m)']:.3g} m, twist.linear "
          f"{off['largest twist.linear difference (m/s)']:.3g} m/s over {off['common epochs']} epochs")
    assert off["common epochs"] >= len(recorded) - 2
    assert off["largest difference (m)"] < 1e-6 and off["largest twist.linear difference (m/s)"] < 1e-6, off
