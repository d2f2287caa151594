"""Recordings: rosbag2 and CSV round trips, damaged bags read up to the damage, bag_play and bag_record nodes."""
import shutil
import time

import numpy as np
import pytest
import rclpy
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu, NavSatFix, Temperature

from nav_core import recording as rec_io
from nav_core.processes import NodeProcess
from nav_core.ros_node import Probe, stamp_to_s

T0 = 1_700_000_000.0


def _imu(n=640, rate=64.0, seed=0, temp=True):
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n) / rate
    return rec_io.ImuRecording(t, rng.normal(0, 0.01, (n, 3)), rng.normal(0, 0.1, (n, 3)) + [0, 0, 9.8],
                               temp_c=20 + 0.01 * np.arange(n) if temp else None)


def _gnss(n=10, seed=1):
    rng = np.random.default_rng(seed)
    return rec_io.GnssRecording(T0 + np.arange(n, dtype=float), np.radians(45 + rng.normal(0, 1e-5, n)),
                                np.radians(7 + rng.normal(0, 1e-5, n)), 100 + rng.normal(0, 1, n),
                                np.tile([1.5, 1.5, 3.0], (n, 1)), np.zeros(n, int))


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_bag_round_trip_keeps_every_imu_gnss_and_temperature_value(tmp_path, storage):
    imu, gnss = _imu(), _gnss()
    path = rec_io.write_bag(tmp_path / "bag", imu, gnss, storage=storage)
    back, gback = rec_io.read_imu(path), rec_io.read_gnss(path)
    assert back.damage is None and len(back) == len(imu)
    np.testing.assert_allclose(back.t, imu.t, atol=5e-7, rtol=0)  # float seconds at epoch scale
    np.testing.assert_array_equal(back.gyro, imu.gyro)
    np.testing.assert_array_equal(back.accel, imu.accel)
    np.testing.assert_allclose(back.temp_c, imu.temp_c)
    np.testing.assert_allclose(np.degrees(gback.lat), np.degrees(gnss.lat), atol=1e-12, rtol=0)
    np.testing.assert_allclose(gback.std_enu, gnss.std_enu)
    assert (path / "metadata.yaml").read_text().count("rosbag2_bagfile_information") == 1


def test_csv_round_trip_keeps_every_value(tmp_path):
    imu, gnss = _imu(), _gnss()
    back = rec_io.read_imu(rec_io.write_imu_csv(tmp_path / "imu.csv", imu))
    gback = rec_io.read_gnss(rec_io.write_gnss_csv(tmp_path / "gnss.csv", gnss))
    np.testing.assert_allclose(back.gyro, imu.gyro, rtol=1e-9)
    np.testing.assert_allclose(back.temp_c, imu.temp_c, rtol=1e-9)
    np.testing.assert_allclose(gback.lat, gnss.lat, rtol=1e-9)


def test_csv_with_a_bad_row_skips_it_and_names_the_line(tmp_path):
    path = rec_io.write_imu_csv(tmp_path / "imu.csv", _imu(n=50, temp=False))
    lines = path.read_text().splitlines()
    lines[21] = "1.0,2.0,oops,4,5,6,7"
    path.write_text("\n".join(lines) + "\n")
    back = rec_io.read_imu(path)
    assert len(back) == 49 and "line 22" in back.damage and str(path) in back.damage and back.skipped_rows == (22,)
    with pytest.raises(rec_io.RecordingError, match="line 22"):
        rec_io.read_imu(path, strict=True)


def test_missing_csv_column_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,gx,gy,gz,ax,ay\n0,0,0,0,0,0\n")
    with pytest.raises(rec_io.RecordingError, match="az"):
        rec_io.read_imu(path)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("keep", [0.4, 0.8])
def test_truncated_bag_is_read_up_to_the_damage(tmp_path, storage, keep):
    imu = _imu(n=20000, temp=False)
    path = rec_io.write_bag(tmp_path / "bag", imu, storage=storage)
    cut = tmp_path / "cut"
    shutil.copytree(path, cut)
    data_file = next(p for p in cut.iterdir() if p.suffix in (".db3", ".mcap"))
    with open(data_file, "r+b") as fh:
        fh.truncate(int(data_file.stat().st_size * keep))
    back = rec_io.read_imu(cut)
    assert back.damage and str(data_file) in back.damage
    # Everything before the damage, exactly; only the storage block cut in half is lost
    # (an sqlite page, or an MCAP chunk of about 1 MB, i.e. ~3,000 of these messages, plus its index).
    assert keep * 20000 - 4000 < len(back) <= keep * 20000 * 1.1
    np.testing.assert_array_equal(back.gyro, imu.gyro[:len(back)])
    with pytest.raises(rec_io.RecordingError, match=str(data_file.name)):
        rec_io.read_imu(cut, strict=True)


def test_unknown_topic_error_lists_the_topics_the_bag_has(tmp_path):
    path = rec_io.write_bag(tmp_path / "bag", _imu(n=10, temp=False))
    with pytest.raises(rec_io.RecordingError, match="imu/data_raw"):
        rec_io.read_imu(path, topic="imu/other")


# -- nodes -------------------------------------------------------------------------------------

@pytest.mark.ros
def test_bag_play_drives_a_sim_time_subscriber_with_the_bag_clock(tmp_path, ros_env, rclpy_context):
    imu, gnss = _imu(n=192), _gnss(n=3)
    bag = rec_io.write_bag(tmp_path / "bag", imu, gnss)
    probe = Probe({"imu/data_raw": Imu, "gps/fix": NavSatFix, "imu/temperature": Temperature})
    probe.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    sim_times = []
    probe.create_timer(0.1, lambda: sim_times.append(probe.get_clock().now().nanoseconds * 1e-9))
    player = NodeProcess("bag_play", env=ros_env, ros_args={"bag": str(bag), "rate": 2.0, "start_delay_s": 0.0,
                                                                "wait_for_subscribers": 1})
    try:
        assert player.wait_for_line("ready", 20), player.output
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= 1, 30), player.output
        t_start = time.monotonic()
        assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) == 192, 20), (
            sorted(set(range(192)) - {int(round((stamp_to_s(m.header.stamp) - T0) * 64)) for _, m in probe.received["imu/data_raw"]}), player.output)
        elapsed = time.monotonic() - t_start
        assert player.proc.wait(timeout=20) == 0, player.output
    finally:
        probe.destroy_node()
        player.stop()
    stamps = np.array([stamp_to_s(m.header.stamp) for _, m in probe.received["imu/data_raw"]])
    assert set(np.round(stamps, 6)) <= set(np.round(imu.t, 6))
    assert len(probe.received["gps/fix"]) == 3
    # 3 s of bag at 2x: about 1.5 s of wall time from the first message to the last.
    assert 1.3 < elapsed < 4.0
    in_bag = [t for t in sim_times if t > 0]
    assert in_bag and imu.t[0] - 0.01 <= min(in_bag) and max(in_bag) <= imu.t[-1] + 0.01
    assert "done: played" in player.output


@pytest.mark.ros
def test_bag_play_plays_a_damaged_bag_up_to_the_damage_and_names_it(tmp_path, ros_env):
    bag = rec_io.write_bag(tmp_path / "bag", _imu(n=6400, temp=False), storage="mcap")
    data_file = next(p for p in bag.iterdir() if p.suffix == ".mcap")
    with open(data_file, "r+b") as fh:
        fh.truncate(data_file.stat().st_size // 2)
    player = NodeProcess("bag_play", env=ros_env, ros_args={"bag": str(bag), "rate": 100.0, "start_delay_s": 0.0})
    assert player.proc.wait(timeout=60) == 0
    player.stop()
    assert "stopped at damage" in player.output and data_file.name in player.output


@pytest.mark.ros
@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_bag_record_writes_what_bag_play_publishes(tmp_path, ros_env, storage):
    imu, gnss = _imu(n=320, temp=False), _gnss(n=5)
    src = rec_io.write_bag(tmp_path / "src", imu, gnss)
    out = tmp_path / "recorded"
    recorder = NodeProcess("bag_record", env=ros_env,
                           ros_args={"output": str(out), "storage": storage, "discovery_period_s": 0.1})
    assert recorder.wait_for_line("ready", 20), recorder.output
    player = NodeProcess("bag_play", env=ros_env, ros_args={"bag": str(src), "rate": 1.0, "start_delay_s": 0.0,
                                                            "wait_for_subscribers": 1})
    assert player.proc.wait(timeout=60) == 0, player.output
    time.sleep(0.5)
    assert recorder.stop() == 0, recorder.output
    back, gback = rec_io.read_imu(out), rec_io.read_gnss(out)
    assert back.damage is None
    assert len(back) == len(imu), f"recorded {len(back)} of {len(imu)}"
    idx = np.searchsorted(np.round(imu.t, 6), np.round(back.t, 6))
    np.testing.assert_array_equal(back.gyro, imu.gyro[idx])
    assert len(gback) == 5


def test_bag_play_without_a_bag_stops_with_a_message(ros_env):
    player = NodeProcess("bag_play", env=ros_env, ros_args={"bag": "/nonexistent.mcap"})
    assert player.proc.wait(timeout=30) == 2
    player.stop()
    assert "parameter 'bag'" in player.output
