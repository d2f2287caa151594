"""``bp3010_emulator`` on a source a user brings damaged: one line naming the file, the sample, its time and the
channel, exit 2, before any port is opened (was: a FrameError traceback, exit 1, for a NaN sample, a gap of
seconds or a gyro in deg/s; exit 0 with 0 frames for an empty .bin; a probability of 2 accepted)."""
import numpy as np
import pytest

from imu_driver import bp3010_emulator
from nav_core import recording
from nav_core.recording import ImuRecording
from nav_core.units import DEG


def _csv(tmp_path, change=None):
    n = 640
    rng = np.random.default_rng(0)
    t, gyro, accel = np.arange(1, n + 1) / 64.0, rng.normal(0, 0.005, (n, 3)), rng.normal(0, 0.1, (n, 3)) + [0, 0, 9.8]
    gyro[300:340, 2] = 2.0  # a 115 deg/s turn: fits the frame in rad/s (5.2 rad/s), not in deg/s
    if change == "nan":
        accel[200, 1] = np.nan
    elif change == "gap":
        t[400:] += 3.0
    elif change == "deg":
        gyro = gyro / DEG
    return recording.write_imu_csv(tmp_path / "imu.csv", ImuRecording(t, gyro, accel))


@pytest.mark.parametrize("change, words", [
    ("nan", ["imu.csv", "sample 200", "t = 3.140625 s", "not finite"]),
    ("gap", ["imu.csv", "gaps longer than", "sample 400"]),
    ("deg", ["imu.csv", "gz", "in deg/s?", "t = 4.703125 s"]),
])
def test_a_recording_the_frames_cannot_carry_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch, change, words):
    def no_port(*args, **kwargs):
        raise AssertionError("a port was opened before the source was checked")
    monkeypatch.setattr(bp3010_emulator, "PtyPort", no_port)
    assert bp3010_emulator.main(["--source", str(_csv(tmp_path, change)), "--speed", "1000"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("bp3010_emulator: error:") and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


def test_a_clean_recording_plays_and_an_empty_bin_or_a_probability_of_2_is_refused(tmp_path, capsys):
    assert bp3010_emulator.main(["--source", str(_csv(tmp_path)), "--speed", "1000", "--max-frames", "64"]) == 0
    assert "frames_sent=64" in capsys.readouterr().out
    (tmp_path / "empty.bin").write_bytes(b"")
    assert bp3010_emulator.main(["--source", str(tmp_path / "empty.bin")]) == 2
    assert "empty.bin: no BP3010 frame" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        bp3010_emulator.main(["--flip-probability", "2"])
    assert exit_.value.code == 2 and "--flip-probability" in capsys.readouterr().err


def test_bag_play_refuses_a_topic_the_bag_does_not_have_naming_the_closest(tmp_path, rclpy_context):
    from rclpy.parameter import Parameter

    from imu_driver.bag_play_node import BagPlayer
    from nav_core.params import ConfigError

    n = 64
    bag = recording.write_bag(tmp_path / "bag", ImuRecording(1.7e9 + np.arange(n) / 64, np.zeros((n, 3)),
                                                             np.tile([0, 0, 9.8], (n, 1))),
                              recording.GnssRecording(1.7e9 + np.arange(2.0), np.full(2, 0.8), np.full(2, 0.1),
                                                      np.zeros(2), np.ones((2, 3))), storage="mcap")
    with pytest.raises(ConfigError, match=r"'topics': \['gps/fx'\] not in bag .*did you mean 'gps/fix'"):
        BagPlayer(parameter_overrides=[Parameter("bag", value=str(bag)),  # was: played imu/data_raw alone, silently
                                       Parameter("topics", value=["imu/data_raw", "gps/fx"])])


@pytest.mark.parametrize("entries, match", [
    (["imu/data_raw"], r"'imu/data_raw' is not 'topic=node"),
    (["imu/data_raw= , "], r"is not 'topic=node"),
    (["gps/fx=ins_gps_kf_node"],
     r"'gps/fx' is not played \(did you mean 'gps/fix'\?\); playing \['gps/fix', 'imu/data_raw'\]"),
])
def test_bag_play_refuses_a_reader_entry_it_cannot_wait_for_naming_it(entries, match):
    from imu_driver.bag_play_node import parse_readers
    from nav_core.params import ConfigError

    with pytest.raises(ConfigError, match=match):
        parse_readers(entries, {"imu/data_raw": None, "gps/fix": None})


def test_bag_play_reads_readers_per_topic_merging_entries():
    from imu_driver.bag_play_node import parse_readers

    got = parse_readers(["/imu/data_raw=wmra_node, bag_record", "", "imu/data_raw=sensor_health_node"],
                        {"imu/data_raw": None, "gps/fix": None})
    assert got == {"imu/data_raw": {"wmra_node", "bag_record", "sensor_health_node"}}


def test_bag_play_of_a_cut_bag_still_brings_the_clock_to_its_last_message(tmp_path, rclpy_context, monkeypatch):
    from rclpy.parameter import Parameter

    from imu_driver.bag_play_node import BagPlayer

    n = 6400  # two MCAP chunks; cut in the second
    t = 1.7e9 + np.arange(n) / 64
    bag = recording.write_bag(tmp_path / "bag", ImuRecording(t, np.zeros((n, 3)), np.tile([0, 0, 9.8], (n, 1))),
                              storage="mcap")
    data = next(bag.glob("*.mcap"))
    data.write_bytes(data.read_bytes()[:data.stat().st_size * 3 // 4])
    clock = []
    monkeypatch.setattr(BagPlayer, "_publish_clock", lambda self, ns: clock.append(ns))
    player = BagPlayer(parameter_overrides=[Parameter("bag", value=str(bag)), Parameter("rate", value=1000.0),
                                            Parameter("start_delay_s", value=0.0)])
    try:
        assert player.done.wait(30.0)
    finally:
        player.close()
        player.destroy_node()
    assert player.error and "cut short" in player.error
    last = recording.read_imu(bag).t[-1]
    assert clock and abs(clock[-1] * 1e-9 - last) < 1e-6  # was: up to one clock step short (10 s here)
