"""``nav-demo --recording``: the filter gets the bag from its first message, as the recorder does, and the
report's offline replay starts where the filter's input did.

Before the fix bag_play started playing 0.5 s after it counted one subscriber per topic; a node that had
subscribed before the player started (wmra_node, ins_gps_kf_node) counted the player's publisher up to
~2 s later and lost what was played before, while the recorder (subscribing once it sees the player) had
it all: the live odometry then differed from the offline replay of the run's own bag by up to 20.6 m.
Counting subscribers per topic then kept sensor_health_node out of this path (a third reader of imu/data_raw
met the count early); bag_play now waits for each reader by name, and the monitor runs here too.
"""
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nav_bringup import demo
from nav_bringup.graph import Graph
from nav_bringup.offline_runs import BAG_LATE_FIXES, BAG_LATE_IMU, MISSED_FIXES, MISSED_IMU, _from_filter_start
from nav_bringup.report import last_diagnostics, write_report
from nav_core import recording

SIM_S, RATE = 8.0, 2.0


def _recordings(t0=1.7e9, seconds=10):
    t = t0 + np.arange(1, seconds * 64 + 1) / 64.0
    imu = recording.ImuRecording(t, np.zeros((len(t), 3)), np.tile([0.0, 0.0, 9.8], (len(t), 1)))
    tf = t0 + np.arange(seconds, dtype=float)
    gnss = recording.GnssRecording(tf, np.full(seconds, 0.8), np.full(seconds, 0.1), np.zeros(seconds),
                                   np.ones((seconds, 3)), np.zeros(seconds, int))
    return imu, gnss


def test_the_offline_replay_starts_at_the_filters_first_received_stamps():
    imu, gnss = _recordings()
    diag = {"first_imu_stamp_s": f"{imu.t[70]:.6f}", "first_fix_stamp_s": f"{gnss.t[2]:.6f}"}
    imu2, gnss2, missed = _from_filter_start(imu, gnss, diag)
    assert missed == {MISSED_IMU: 70, MISSED_FIXES: 2, BAG_LATE_IMU: 0.0, BAG_LATE_FIXES: 0.0}
    assert imu2.t[0] == imu.t[70] and len(imu2) == len(imu) - 70
    assert gnss2.t[0] == gnss.t[2] and len(gnss2) == len(gnss) - 2


@pytest.mark.parametrize("diag", [{}, {"first_imu_stamp_s": "", "first_fix_stamp_s": ""},
                                  {"first_imu_stamp_s": "1699999999.0", "first_fix_stamp_s": "1700000000.000000"}])
def test_a_filter_that_had_the_bags_start_or_no_stamps_replays_the_whole_bag(diag):
    imu, gnss = _recordings()
    imu2, gnss2, missed = _from_filter_start(imu, gnss, diag)
    assert missed[MISSED_IMU] == 0 and missed[MISSED_FIXES] == 0 and len(imu2) == len(imu) and len(gnss2) == len(gnss)


@given(offset_ns=st.integers(0, 15_624_999))
@settings(max_examples=200, deadline=None)
def test_the_filters_printed_first_stamps_match_the_bags_first_message_at_any_sub_microsecond_offset(offset_ns):
    # the node prints its first stamps to 1 us, a float64 near 1.7e9 s resolves 0.24 us: a run whose filter
    # had the bag's first message must not be read as one that missed it (a 1e-7 s tolerance made the report
    # skip the first sample and show 1.6-1.8 cm between live and offline)
    imu, gnss = _recordings(t0=1.7e9 + offset_ns * 1e-9)
    diag = {"first_imu_stamp_s": f"{imu.t[0]:.6f}", "first_fix_stamp_s": f"{gnss.t[0]:.6f}"}
    _, _, missed = _from_filter_start(imu, gnss, diag)
    assert missed[MISSED_IMU] == 0 and missed[MISSED_FIXES] == 0, diag
    diag = {"first_imu_stamp_s": f"{imu.t[1]:.6f}", "first_fix_stamp_s": f"{gnss.t[1]:.6f}"}
    _, _, missed = _from_filter_start(imu, gnss, diag)
    assert missed[MISSED_IMU] == 1 and missed[MISSED_FIXES] == 1, diag


def test_input_the_filter_had_before_the_bags_start_is_measured_in_seconds():
    imu, gnss = _recordings()
    diag = {"first_imu_stamp_s": f"{imu.t[0] - 0.5:.6f}", "first_fix_stamp_s": f"{gnss.t[0] - 2.0:.6f}"}
    _, _, missed = _from_filter_start(imu, gnss, diag)
    assert missed == {MISSED_IMU: 0, MISSED_FIXES: 0, BAG_LATE_IMU: 0.5, BAG_LATE_FIXES: 2.0}


@pytest.mark.ros
@pytest.mark.slow
def test_every_reader_gets_the_replayed_bag_from_its_first_message_and_live_equals_offline(tmp_path, ros_env):
    demo.simulate_scenario(demo.DEFAULT_SCENARIO, demo.DEFAULT_MODEL, 5, tmp_path / "sim", duration_s=SIM_S,
                           fmt="bag")
    run_dir = tmp_path / "run"
    # a 3-s alignment instead of 45 s: the filter publishes odometry within the short drive (live = offline)
    params = tmp_path / "navigation.yaml"
    params.write_text(demo.PARAMS_FILE.read_text().replace("alignment_time_s: 45.0", "alignment_time_s: 3.0")
                      .replace("min_alignment_time_s: 5.0", "min_alignment_time_s: 2.0"))
    args = demo.parse_args(["--recording", str(tmp_path / "sim" / "bag"), "--rate", str(RATE),
                            "--out", str(tmp_path), "--params", str(params)])
    graph = Graph(demo.graph_specs(args, run_dir, None), ros_env, args.params, log_dir=run_dir / "logs")
    try:
        graph.start(timeout_s=60)
        code = graph.wait_for_exit("bag_play", SIM_S / RATE + demo.PLAYER_SETTLE_S + 30)
        player_log = graph.procs["bag_play"].output
        assert code == 0, player_log[-2000:]
    finally:
        codes = graph.stop()
    assert all(c == 0 for c in codes.values()), codes
    assert "sensor_health_node" in codes and "playing without" not in player_log, player_log[-2000:]
    # the player counted each reader by name before playing (a count of 2 or 3 was met by the wrong ones)
    playing = next(line for line in player_log.splitlines() if "playing: subscribers" in line)
    for reader in ("wmra_node", "allan_node", "sensor_health_node", "bag_record", "ins_gps_kf_node"):
        assert f"'{reader}'" in playing, playing
    bag = run_dir / "bag"
    played = recording.read_imu(tmp_path / "sim" / "bag", topic="imu/data_raw")
    raw, den = recording.read_imu(bag, topic="imu/data_raw"), recording.read_imu(bag, topic="imu/data_corrected")
    fixes = recording.read_gnss(bag)
    kf = next(v for n, (_, _, v) in last_diagnostics(bag).items() if n.startswith("ins_gps_kf"))
    assert raw.t[0] == played.t[0], "the recorder missed the start of imu/data_raw"
    assert den.t[0] == raw.t[0], f"wmra_node missed {den.t[0] - raw.t[0]:.3f} s of imu/data_raw"
    assert float(kf["first_fix_stamp_s"]) == pytest.approx(fixes.t[0], abs=1e-6), (kf, fixes.t[:3])
    assert float(kf["first_imu_stamp_s"]) == pytest.approx(den.t[0], abs=1e-6), (kf, den.t[:3])
    health = last_diagnostics(bag)["sensor_health_node: summary"][2]
    assert int(health["received"]) > 0 and int(health["gps_fix"]) > 0, health
    # the filter's odometry reached the monitor: its gyro bias beside the monitor's channels (sensor_health_node)
    gz = last_diagnostics(bag)["sensor_health_node: gz"][2]
    assert int(health["odometry"]) > 0 and int(health["filter_bias_epochs"]) >= 2, health
    assert abs(float(gz["filter_bias_rad_s"])) < 0.01, gz  # finite, and of a gyro bias's size (0.6 deg/s)
    # the monitor on the same input does not change the filter: live = offline on the run's own bag
    summary = write_report(run_dir, exit_codes=codes, filter_params=demo.filter_params(args.params, graph.specs))
    assert (run_dir / "summary.json").is_file(), summary
    off = json.loads((run_dir / "summary.json").read_text())["offline"]
    assert off[MISSED_IMU] == 0 and off[MISSED_FIXES] == 0 and off["common epochs"] >= 5, off
    assert off["largest difference (m)"] < 1e-6 and off["largest twist.linear difference (m/s)"] < 1e-6, off
    assert "sensor health: " in summary and "sensor_health_node" in summary, summary
