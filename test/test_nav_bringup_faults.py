"""Faults during a live run of the whole graph: each is reported in diagnostics, no node exits, the filter recovers.

On 300 s of the paper drive at 8x: a garbage burst on the serial line every 20 s, the port
unplugged for 5 s at 120 s (driving), a 60 s GPS outage from 150 s, a fix 500 m off at 230 s
and a NaN fix at 240 s (simulated seconds: the player's faults follow its /clock, so the rate only
shortens the wall time; the README's two-host drive runs the same nodes at 6x, test_nav_bringup_busy_cpu
at 3x). (A time jump in a replayed bag: test_nav_bringup_bag_time_jump.py.)
"""
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
SIM_S, RATE = 300.0, 8.0
UNPLUG_AT, OUTAGE, OFF_AT, NAN_AT = 120.0, (150.0, 60.0), 230.0, 240.0
RECOVERY_S = 40.0  # stated recovery time after the last fault


@pytest.fixture(scope="module")
def sim_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "run"
    scen = simulate_scenario(REPO / "config" / "scenarios" / "paper_drive.yaml", MODEL, 11, out,
                             duration_s=SIM_S + 2, fmt="csv")
    return out, scen


def test_faults_are_reported_no_node_exits_and_the_filter_recovers(sim_dir, tmp_path, ros_env):
    sim, scen = sim_dir
    link, s = tmp_path / "port", {"use_sim_time": True}
    model = {"sensor_model_path": str(MODEL)}
    specs = [NodeSpec("bp3010_driver", dict(s, port=str(link), reconnect_period_s=0.2)),
             NodeSpec("wmra_node", dict(s, **model)),
             NodeSpec("ins_gps_kf_node", dict(s, **model, **scenario_datum(sim))),
             NodeSpec("scenario_player", {"sim_dir": str(sim), "link": str(link), "rate": RATE, "duration_s": SIM_S,
                                          "garbage_every_s": 20.0, "disconnect_at_s": [UNPLUG_AT],
                                          "disconnect_for_s": 5.0, "gps_outage_start_s": OUTAGE[0],
                                          "gps_outage_duration_s": OUTAGE[1], "gps_offset_at_s": OFF_AT,
                                          "gps_offset_m": 500.0, "gps_nan_at_s": NAN_AT})]
    graph = Graph(specs, ros_env, PARAMS_FILE, log_dir=tmp_path / "logs")
    try:
        with graph_probe({"odometry/filtered": Odometry}) as probe:
            graph.start(timeout_s=60)
            assert probe.spin_until(lambda p: "scenario_player" in graph.dead(), SIM_S / RATE + 120), \
                {k: v.output[-1500:] for k, v in graph.procs.items()}
            probe.spin_until(lambda p: False, 2.0)
            assert graph.dead() == {"scenario_player": 0}, "no node may exit because of a fault"
    finally:
        codes = graph.stop()
    assert all(c == 0 for c in codes.values()), codes

    values = diag_values(probe)
    drv, kf = values["bp3010_driver"], values["ins_gps_kf_node"]
    assert int(drv["reconnects"]) >= 1 and drv["port_state"] == "connected"
    assert int(drv["bytes_discarded"]) > 0 and int(drv["resyncs"]) > 0  # garbage bursts
    assert int(kf["imu_gaps_bridged"]) >= 1  # the unplugged port, bridged while driving
    assert int(kf["rejected_fixes"]) >= 1  # the fix 500 m off
    assert int(kf["invalid_fixes"]) >= 1  # the NaN fix
    assert kf["state"] == "navigating"

    truth = TruthTrack.from_sim_dir(sim)
    odom = [m for _, m in probe.received["odometry/filtered"]]
    t = np.array([stamp_to_s(m.header.stamp) for m in odom]) - truth.epoch_s
    pos = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z] for m in odom])
    err = np.hypot(*(pos - truth.at(t + truth.epoch_s))[:, :2].T)
    pre = np.sqrt(np.mean(err[(t > 70) & (t < UNPLUG_AT)] ** 2))
    after = np.sqrt(np.mean(err[t > NAN_AT + RECOVERY_S] ** 2))
    print(f"horizontal RMS before the faults {pre:.2f} m; {RECOVERY_S:.0f} s after the last one {after:.2f} m; "
          f"max during the GPS outage {err[(t > OUTAGE[0]) & (t < sum(OUTAGE))].max():.1f} m")
    assert after < 2.0 * pre + 0.5, (pre, after)
    # The INS bridges the 60 s outage with the drift the filter's own evaluation measured (max 233 m for
    # 60 s outages on this drive): the earlier serial fault must not have corrupted the solution.
    assert err[(t > OUTAGE[0]) & (t < sum(OUTAGE))].max() < 300.0
