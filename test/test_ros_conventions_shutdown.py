"""Ctrl-C ends a node cleanly: exit status 0 and no thread traceback (scenario_player's threads write a pty)."""
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest


@pytest.mark.ros
def test_scenario_player_stops_on_ctrl_c_while_playing_without_a_traceback(tmp_path, ros_env):
    from imu_driver.bp3010_codec import encode_stream
    from nav_core.recording import GnssRecording, write_gnss_csv

    sim, n = tmp_path / "sim", 64 * 30
    sim.mkdir()
    (sim / "bp3010.bin").write_bytes(encode_stream(np.zeros((n, 3)), np.tile([0, 0, 9.8 / 64], (n, 1))))
    write_gnss_csv(sim / "gnss.csv", GnssRecording(np.arange(30.0), np.full(30, 0.9), np.full(30, 0.1),
                                                   np.zeros(30), np.ones((30, 3))))
    exe = Path(sys.executable).parent / "scenario_player"
    proc = subprocess.Popen([str(exe), "--ros-args", "-p", f"sim_dir:={sim}", "-p", f"link:={tmp_path / 'port'}",
                             "-p", "wait_timeout_s:=0.0"], env=ros_env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    out = ""
    deadline = time.monotonic() + 30.0
    while "playing" not in out and time.monotonic() < deadline and proc.poll() is None:
        out += proc.stdout.readline()
    time.sleep(1.0)  # frames and fixes are flowing
    proc.send_signal(signal.SIGINT)
    rest, _ = proc.communicate(timeout=20)
    out += rest
    assert "playing" in out and proc.returncode == 0, out
    assert "Traceback" not in out and "Exception in thread" not in out, out
    assert not (tmp_path / "port").exists()  # the port link is removed on the way out
