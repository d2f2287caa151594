"""``nav-demo --recording``: the filter gets the bag from its first message, as the recorder does, and the
report's offline replay starts where the filter's input did.

Before the fix bag_play started playing 0.5 s after it counted one subscriber per topic; a node that had
subscribed before the player started (wmra_node, ins_gps_kf_node) counted the player's publisher up to
~2 s later and lost what was played before, while the recorder (subscribing once it sees the player) had
it all: the live odometry then differed from the offline replay of the run's own bag by up to 20.6 m.
Counting subscribers per topic then kept sensor_health_node out of this path (a third reader of imu/data_raw
met the count early); bag_play now waits for each reader by name, and the monitor runs there too. The live run
is the README's recipe (nav-demo --recording out/katwijk), checked by check_recording_run from test_readme_recipes.
"""
import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nav_bringup.offline_runs import BAG_LATE_FIXES, BAG_LATE_IMU, MISSED_FIXES, MISSED_IMU, _from_filter_start
from nav_bringup.report import last_diagnostics
from nav_core import recording


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


def recording_run(command: str):
    """``(recording, out)`` of a ``nav-demo --recording REC --out OUT`` command line; None for any other."""
    from test_nav_bringup_two_hosts import nav_demo_flags

    flags = nav_demo_flags(command) or {}
    return (flags["--recording"], flags["--out"]) if "--recording" in flags and "--out" in flags else None


def check_recording_run(stdout: str, played, out) -> None:
    """What a ``nav-demo --recording PLAYED --out OUT`` run must show: bag_play counted every reader by name before
    playing, the recorder, wmra_node and the filter each got the played bag from its first message, the health
    monitor got the sensors and the filter's odometry (its gyro bias beside its channels), and the live odometry
    equals the offline replay of the run's own bag. The README's recipe (the Katwijk rover bag) is that run:
    test_readme_recipes calls this on it (was this module's own 8-s drive at 2x)."""
    from pathlib import Path

    run_dir = next(Path(out).glob("run_*"))
    played = Path(played)
    player_log = (run_dir / "logs" / "bag_play.log").read_text()
    codes = json.loads((run_dir / "summary.json").read_text())["exit_codes"]
    assert all(c == 0 for c in codes.values()), codes
    assert "sensor_health_node" in codes and "playing without" not in player_log, player_log[-2000:]
    # the player counted each reader by name before playing (a count of 2 or 3 was met by the wrong ones)
    playing = next(line for line in player_log.splitlines() if "playing: subscribers" in line)
    for reader in ("wmra_node", "allan_node", "sensor_health_node", "bag_record", "ins_gps_kf_node"):
        assert f"'{reader}'" in playing, playing
    # the sensor data is reliable on one host too (nav_bringup.hosts.link_qos): best effort, a busy recorder lost
    # samples the filter received, and the offline replay of its bag could not match (CI at 180dd93: 62.8 m)
    record_log = (run_dir / "logs" / "bag_record.log").read_text()
    for topic in ("/imu/data_raw", "/imu/data_corrected", "/gps/fix"):
        assert re.search(rf"recording {topic} \(\S+, reliable\)", record_log), (topic, record_log[-2000:])
    bag = run_dir / "bag"
    played_imu = recording.read_imu(played / "bag" if (played / "bag").is_dir() else played, topic="imu/data_raw")
    raw, den = recording.read_imu(bag, topic="imu/data_raw"), recording.read_imu(bag, topic="imu/data_corrected")
    fixes = recording.read_gnss(bag)
    diags = last_diagnostics(bag)
    kf = next(v for n, (_, _, v) in diags.items() if n.startswith("ins_gps_kf"))
    assert raw.t[0] == played_imu.t[0], "the recorder missed the start of imu/data_raw"
    assert den.t[0] == raw.t[0], f"wmra_node missed {den.t[0] - raw.t[0]:.3f} s of imu/data_raw"
    assert float(kf["first_fix_stamp_s"]) == pytest.approx(fixes.t[0], abs=1e-6), (kf, fixes.t[:3])
    assert float(kf["first_imu_stamp_s"]) == pytest.approx(den.t[0], abs=1e-6), (kf, den.t[:3])
    health = diags["sensor_health_node: summary"][2]
    assert int(health["received"]) > 0 and int(health["gps_fix"]) > 0, health
    # the filter's odometry reached the monitor: its gyro bias beside the monitor's channels (sensor_health_node)
    gz = diags["sensor_health_node: gz"][2]
    assert int(health["odometry"]) > 0 and int(health["filter_bias_epochs"]) >= 2, health
    assert abs(float(gz["filter_bias_rad_s"])) < 0.01, gz  # finite, and of a gyro bias's size (0.6 deg/s)
    # the monitor on the same input does not change the filter: live = offline on the run's own bag
    off = json.loads((run_dir / "summary.json").read_text())["offline"]
    assert off[MISSED_IMU] == 0 and off[MISSED_FIXES] == 0 and off["common epochs"] >= 5, off
    assert off["largest difference (m)"] < 1e-6 and off["largest twist.linear difference (m/s)"] < 1e-6, off
    assert "sensor health: " in stdout and "sensor_health_node" in stdout, stdout[-3000:]


def test_the_readme_plays_a_recording_through_nav_demo_which_the_recipe_test_checks():
    from test_readme_recipes import RECIPES

    runs = [recording_run(c) for r in RECIPES for c in r.commands if recording_run(c)]
    assert runs, "no README recipe runs nav-demo --recording: check_recording_run would check nothing"
    assert recording_run(".venv/bin/nav-demo --recording out/k --rate 8 --out out/k_live") == ("out/k", "out/k_live")
    assert recording_run(".venv/bin/nav-demo --rate 8 --out o") is None
