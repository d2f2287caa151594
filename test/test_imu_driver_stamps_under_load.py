"""bp3010_driver stamps with the CPU busy: emulator -> pty -> driver, two nice-10 busy loops; no stamp goes back.

At 64 Hz on the wall clock, and at 1,000 frames per wall second as the graph runs it (scenario_player at
15.6x with /clock, the driver on simulated time). Each frame carries its index in dθx, so every received
message is compared with the time the frame was made.
"""
import subprocess
import sys
from contextlib import contextmanager

import numpy as np
import pytest
from sensor_msgs.msg import Imu

from imu_driver.bp3010_codec import DEFAULT_FORMAT, encode_counts
from nav_core.processes import NodeProcess
from nav_core.ros_node import Probe

pytestmark = [pytest.mark.ros, pytest.mark.slow]
EPOCH_S = 1_700_000_000.0
STREAM_WALL_S = 8.0
"""Wall seconds of stream each test takes: 6 after the 2-s settle (was 12: the same checks, 4 s more each)."""


@contextmanager
def busy_cpu(n=2):
    """``n`` busy-loop processes at nice 10 for the duration (killed by their own pids)."""
    procs = [subprocess.Popen(["nice", "-n", "10", sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def _indexed_stream(path, n):
    """A BP3010 stream whose frame k has dθx = k counts (so a message names its frame)."""
    counts = np.zeros((n, 6), dtype=np.int64)
    counts[:, 0] = np.arange(n)
    counts[:, 5] = 2000
    path.write_bytes(encode_counts(np.arange(n), counts))
    return path


def _stamps_and_index(probe):
    msgs = [m for _, m in probe.received["imu/data_raw"]]
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs], dtype=np.int64)
    index = np.array([int(round(m.angular_velocity.x / 64 / DEFAULT_FORMAT.dtheta_lsb_rad)) for m in msgs])
    return stamps, index


def _check(stamps_ns, index, made_s, settle_s, spread_s):
    """No stamp goes back; after ``settle_s`` the stamp minus the frame's making time varies by < ``spread_s``."""
    assert len(stamps_ns) > 100
    assert np.all(np.diff(stamps_ns) > 0), f"stamps went back: {np.diff(stamps_ns).min() * 1e-9:.6f} s"
    assert np.all(np.diff(index) > 0)
    residual = (stamps_ns - stamps_ns[0]) * 1e-9 - (made_s[index] - made_s[index[0]])
    settled = residual[made_s[index] - made_s[index[0]] > settle_s]
    assert np.ptp(settled) < spread_s, f"stamp - frame time spans {np.ptp(settled):.4f} s"
    return residual


def test_wall_clock_stamps_at_64_hz_never_go_back_with_the_cpu_busy(tmp_path, rclpy_context):
    env = rclpy_context
    stream = _indexed_stream(tmp_path / "idx.bin", 64 * 60)
    link = tmp_path / "port"
    with busy_cpu():
        emu = NodeProcess("bp3010_emulator", ["--source", stream, "--link", link], env=env)
        drv = NodeProcess("bp3010_driver", env=env, ros_args={"port": str(link)})
        probe = Probe({"imu/data_raw": Imu})
        try:
            assert emu.wait_for_line("PORT", 10) and drv.wait_for_line("ready", 20), drv.output
            assert probe.spin_until(lambda p: len(p.received["imu/data_raw"]) >= 64 * STREAM_WALL_S, 40), drv.output
        finally:
            probe.destroy_node()
            assert drv.stop() == 0, drv.output
            emu.stop()
    stamps, index = _stamps_and_index(probe)
    # frame k leaves the emulator at (k + 1) / 64 s after its start; the stamps follow that, not the reads
    _check(stamps, index, np.arange(64 * 60) / 64.0, settle_s=2.0, spread_s=0.004)


@pytest.mark.parametrize("rate", [3.0, 1000.0 / 64.0])
def test_simulated_time_stamps_never_go_back_with_the_cpu_busy(tmp_path, rclpy_context, rate):
    # 15.6x: 1,000 frames per wall second, the graph's 1 kHz load; 3x: the demo's RATE=3.
    env = rclpy_context
    seconds = STREAM_WALL_S * rate  # simulated
    sim_dir = tmp_path / "sim"
    sim_dir.mkdir()
    _indexed_stream(sim_dir / "bp3010.bin", int(seconds * 64))
    (sim_dir / "gnss.csv").write_text("t,lat_deg,lon_deg,h_m,std_e,std_n,std_u\n0,45,7,100,1,1,2\n"
                                      f"{seconds:.1f},45,7,100,1,1,2\n")
    link = tmp_path / "port"
    with busy_cpu():
        drv = NodeProcess("bp3010_driver", env=env, ros_args={"port": str(link), "use_sim_time": True,
                                                              "reconnect_period_s": 0.1})
        player = NodeProcess("scenario_player", env=env, ros_args={
            "sim_dir": str(sim_dir), "link": str(link), "rate": rate, "epoch_s": EPOCH_S,
            "wait_for_subscribers": ["imu/data_raw"], "exit_when_done": False})
        probe = Probe({"imu/data_raw": Imu})
        try:
            assert player.wait_for_line("playing", 60), player.output
            assert probe.spin_until(lambda p: player.wait_for_line("done:", 0), seconds / rate + 30), player.output
            probe.spin_until(lambda p: False, 1.0)
        finally:
            probe.destroy_node()
            assert drv.stop() == 0, drv.output
            player.stop()
    stamps, index = _stamps_and_index(probe)
    made = (np.arange(int(seconds * 64)) + 1) / 64.0  # scenario_player writes frame k at simulated (k + 1) / 64
    residual = _check(stamps, index, made, settle_s=2.0 * rate, spread_s=0.004 * rate)
    # and against the simulated clock itself: the player's frames and /clock share one zero, so the stamps
    # sit on the frames' simulated times to within the most prompt /clock delivery and read (0.1 ms of wall
    # time at 3x and 15.6x); before they shared it, the emulator's later start put them late (8.5 ms at 3x)
    error = stamps * 1e-9 - (EPOCH_S + made[index])
    settled = error[made[index] - made[index[0]] > 2.0 * rate]
    assert abs(np.median(settled)) < 0.001 * rate, f"stamps {np.median(settled):+.4f} s off the frames' times"
    assert np.ptp(residual) < 0.6 * rate
