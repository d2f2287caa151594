"""A time jump in a replayed bag, live: bag_play loops (its clock jumps back), the nodes report it, none exits,
and the filter re-aligns and navigates again as well as on the first pass."""
import numpy as np
import pytest
from nav_msgs.msg import Odometry

from nav_bringup.demo import simulate_scenario
from nav_bringup.description import scenario_datum
from nav_bringup.graph import PARAMS_FILE, REPO, Graph, NodeSpec
from nav_bringup.live_status_ros import diag_values, graph_probe
from nav_bringup.truth import TruthTrack
from nav_core.ros_node import stamp_to_s

pytestmark = [pytest.mark.ros, pytest.mark.slow]
MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
SIM_S, RATE = 130.0, 8.0
SECOND_PASS_S = 120.0
"""Sensor seconds of the second pass to wait for: alignment (45 s) plus over a minute of driving."""


def test_a_bag_looping_back_in_time_is_reported_and_the_filter_navigates_again(tmp_path, ros_env):
    sim = tmp_path / "sim"
    scen = simulate_scenario(REPO / "config" / "scenarios" / "paper_drive.yaml", MODEL, 21, sim, duration_s=SIM_S,
                             fmt="bag")
    s, model = {"use_sim_time": True}, {"sensor_model_path": str(MODEL)}
    specs = [NodeSpec("wmra_node", dict(s, **model)),
             NodeSpec("ins_gps_kf_node", dict(s, **model, **scenario_datum(sim))),
             NodeSpec("bag_play", {"bag": str(sim / "bag"), "rate": RATE, "loop": True, "wait_for_subscribers": 1,
                                   "topics": ["imu/data_raw", "gps/fix"]})]
    graph = Graph(specs, ros_env, PARAMS_FILE, log_dir=tmp_path / "logs")

    def second_pass_done(p):
        stamps = [stamp_to_s(m.header.stamp) for _, m in p.received["odometry/filtered"]]
        jumps = np.flatnonzero(np.diff(stamps) < 0)
        return bool(jumps.size) and stamps[-1] - stamps[jumps[0] + 1] >= SECOND_PASS_S - 50.0

    try:
        with graph_probe({"odometry/filtered": Odometry}) as probe:
            graph.start(timeout_s=60)
            done = probe.spin_until(second_pass_done, (SIM_S + SECOND_PASS_S) / RATE + 90)
            probe.spin_until(lambda p: False, 2.0)  # a diagnostics period after the jump
            assert done, {k: v.output[-1500:] for k, v in graph.procs.items()}
            assert graph.dead() == {}, "no node may exit because of a time jump"
    finally:
        codes = graph.stop()
    assert all(c == 0 for c in codes.values()), codes

    values = diag_values(probe)
    assert int(values["wmra_node"]["restarts"]) >= 1 and "time jump" in values["wmra_node"]["last_restart"]
    assert "jumped back" in values["ins_gps_kf_node"]["last_reset"]

    truth = TruthTrack.from_sim_dir(sim)
    odom = [m for _, m in probe.received["odometry/filtered"]]
    t = np.array([stamp_to_s(m.header.stamp) for m in odom])
    pos = np.array([[m.pose.pose.position.x, m.pose.pose.position.y] for m in odom])
    err = np.hypot(*(pos - truth.at(t)[:, :2]).T)
    jump = np.flatnonzero(np.diff(t) < 0)[0] + 1
    rel = t - truth.epoch_s
    first = np.sqrt(np.mean(err[:jump][rel[:jump] > 70] ** 2))
    second = np.sqrt(np.mean(err[jump:][rel[jump:] > 70] ** 2))
    print(f"horizontal RMS after 70 s: first pass {first:.2f} m, after the jump {second:.2f} m")
    assert second < max(2.0 * first, 1.5)
