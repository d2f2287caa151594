"""Wheel speeds from a bag and through the node's intake (issue 25): the replay reads odom/wheel from a rosbag2 bag
(nav_msgs/Odometry or geometry_msgs/TwistStamped) exactly as from the CSV, and the node's stamp-order intake gives
the offline replay's numbers and bad-input counts with wheel speeds arriving late."""
import numpy as np
import pytest

from nav_core import bagio, recording
from ins_gps_kf import config
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.intake import StampOrderIntake
from ins_gps_kf.offline import run
from ins_gps_kf.replay import replay_files, wheel_speeds

PARAMS = {"alignment_time_s": 15.0, "imu_rate_hz": 32.0}


def _counts(filt):
    return ({k: v for k, v in filt.input_counters.items() if k.startswith("odometer")},
            filt.counters.odometer_updates, filt.counters.odometer_rejected)


def test_replay_reads_wheel_speeds_from_a_bag_as_from_the_csv(wheel_drive, tmp_path):
    imu, gnss, wheel = wheel_drive
    csv = recording.write_wheel_speed_csv(tmp_path / "odom.csv", wheel)
    plain = recording.write_bag(tmp_path / "plain", imu, gnss, imu_topic="imu/data_corrected")
    ref, ref_filt = replay_files(plain, None, "default", tmp_path / "csv.csv", PARAMS, plot=False, progress=False,
                                 odometry_path=csv)
    counts = _counts(ref_filt)
    stuck = counts[0].pop("odometer_stuck")
    assert counts[0] == {"odometer_nonfinite": 1, "odometer_duplicate": 1, "odometer_out_of_order": 1}
    assert stuck >= 2  # the stuck zeros that were the latest speed at a 2-Hz epoch
    counts[0]["odometer_stuck"] = stuck
    assert counts[1] > 40  # the good speeds are used: 2 Hz once the heading is known (about 30 s)
    bag = recording.write_bag(tmp_path / "bag", imu, gnss, imu_topic="imu/data_corrected", wheel=wheel)
    traj, filt = replay_files(bag, None, "default", tmp_path / "bag.csv", {**PARAMS, "odometer_enabled": True},
                              plot=False, progress=False)
    # the same numbers up to the stamps' last bit (a bag holds ns, the CSV 15 digits)
    np.testing.assert_allclose(traj.extra["e_m"], ref.extra["e_m"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.extra["n_m"], ref.extra["n_m"], rtol=0, atol=1e-9)
    assert _counts(filt) == counts


def test_a_twist_stamped_bag_gives_the_odometry_bags_speeds_and_the_replay_says_what_it_used(wheel_drive, tmp_path,
                                                                                             capsys):
    imu, gnss, wheel = wheel_drive
    speeds = {}
    for msg_type in bagio.WHEEL_TYPES:
        bag = recording.write_bag(tmp_path / msg_type.split("/")[-1], None, gnss, wheel=wheel, wheel_type=msg_type)
        assert bagio.topics(bag)["odom/wheel"] == msg_type
        assert bagio.offered_qos(bag)["odom/wheel"][0].reliability.name == "BEST_EFFORT"  # a sensor's topic
        speeds[msg_type] = recording.read_wheel_speed(bag)
    odo, twist = speeds.values()
    np.testing.assert_array_equal(twist.t, odo.t)
    np.testing.assert_array_equal(twist.speed_mps, odo.speed_mps)  # NaN included, file order kept
    np.testing.assert_allclose(odo.t, wheel.t, rtol=0, atol=1e-9)
    p = {**config.defaults(), **PARAMS}
    assert wheel_speeds(bag, None, p) is None  # the odometer off: not used, and said
    assert "has wheel speeds on odom/wheel, not used: --param odometer_enabled=true" in capsys.readouterr().err
    plain = recording.write_bag(tmp_path / "plain", None, gnss)
    with pytest.raises(recording.RecordingError, match="no messages on topic 'odom/wheel'.*gps/fix"):
        wheel_speeds(plain, None, {**p, "odometer_enabled": True})
    with pytest.raises(recording.RecordingError, match="odometer_enabled but no wheel speeds"):
        wheel_speeds(recording.write_imu_csv(tmp_path / "imu.csv", imu.select(slice(0, 10))), None,
                     {**p, "odometer_enabled": True})


def test_the_nodes_intake_gives_the_replays_numbers_with_wheel_speeds_arriving_late(wheel_drive):
    imu, gnss, wheel = wheel_drive
    cfg = config.from_params({**PARAMS, "odometer_enabled": True})
    offline = InsGpsFilter(cfg)
    expected = run(offline, imu, gnss, odometry=(wheel.t, wheel.speed_mps))
    live = InsGpsFilter(cfg)
    got = []
    intake = StampOrderIntake(live, 0.1, cfg.time_jump, cfg.imu_rate_hz, on_run=lambda est, *_: got.extend(est))
    # arrival order: fixes 30 ms and wheel speeds 60 ms after their stamps (file order kept), taken every 10 ms
    arrivals = sorted([(t, 2, i) for i, t in enumerate(imu.t)] + [(t + 0.03, 0, i) for i, t in enumerate(gnss.t)]
                      + [(np.nanmax(wheel.t[:i + 1]) + 0.06, 1, i) for i in range(len(wheel))])
    next_take = 0.01
    for arrived, kind, i in arrivals:
        if arrived >= next_take:
            intake.release()
            next_take = arrived + 0.01
        if kind == 2:
            intake.add_imu(imu.t[i], imu.gyro[i], imu.accel[i])
        elif kind == 0:
            intake.add_fix(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i], 0)
        else:
            intake.add_odometry(wheel.t[i], wheel.speed_mps[i])
    intake.flush()
    assert len(got) == len(expected) > 60
    np.testing.assert_array_equal([e.position_n for e in got], [e.position_n for e in expected])
    assert _counts(live) == _counts(offline)
    assert intake.counters.late_odometer == 0 and intake.counters.wheel_speeds == len(wheel)
    # a newer wheel speed whose place the IMU already passed is late: dropped and counted by the intake
    intake.add_odometry(0.5 * (wheel.t[-1] + imu.t[-1]), 5.0)
    intake.flush()
    assert intake.counters.late_odometer == 1 and _counts(live) == _counts(offline)
