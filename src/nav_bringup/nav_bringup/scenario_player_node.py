"""``scenario_player``: play a simulated run live — BP3010 frames into a pty, GPS fixes, and ``/clock``.

One time base drives all three, so the graph can run faster than real time:
simulated time ``t`` is ``(wall - start) x rate``; ``/clock`` carries
``epoch_s + t``; frame k is written at ``t = (k + 1) / 64`` (through the
driver's emulator, so it is the same byte stream a real port would carry);
fix k of ``gnss.csv`` is published at its own ``t`` with stamp ``epoch_s + t``.
Nodes run with ``use_sim_time``. GPS faults (outage, a fix far off, a NaN fix)
can be injected for the fault tests. The simulation's truth goes out on ``truth/odometry``
(``truth_rate_hz``; pose in ``map`` = ENU at the scenario's datum, which is the filter's datum
in nav-demo), so a bag of the run holds the reference its errors are measured against.
"""
from __future__ import annotations

import contextlib
import math
import threading
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import NavSatFix, NavSatStatus

from imu_driver.emulator import Emulator, FaultPlan, PtyPort, counts_from_source
from nav_bringup.status import ScenarioStatus
from nav_bringup.truth import TruthTrack
from nav_core import frames, recording
from nav_core.params import ConfigError, Param
from nav_core.ros_node import Diagnostics, declare_parameters, link_publisher, run_node, stamp_from_s

PARAMS = (
    Param("sim_dir", "", "output folder of `imu-sim simulate` (bp3010.bin, gnss.csv)"),
    Param("link", "/tmp/bp3010", "symlink to create for the emulator's pty (the driver's port)"),
    Param("rate", 1.0, "speed: simulated seconds per wall second", 0.05, 100.0),
    Param("epoch_s", 1_700_000_000.0, "/clock and stamps at simulated t = 0, s", 0.0, 4e9),
    Param("clock_rate_hz", 200.0, "/clock messages per wall second", 1.0, 5000.0),
    Param("duration_s", 0.0, "stop after this much simulated time, s; 0 = the whole run", 0.0, 1e7),
    Param("wait_for_topics", ["imu/data_raw"], "topics that must have a publisher before playing"),
    Param("wait_for_subscribers", ["gps/fix"], "topics that must have a subscriber before playing"),
    Param("wait_timeout_s", 60.0, "give up waiting for the graph after this long, s", 0.0, 3600.0),
    Param("gps_outage_start_s", -1.0, "start of a GPS outage (no fixes), simulated s; < 0 = none", -1.0, 1e7),
    Param("gps_outage_duration_s", 0.0, "length of the GPS outage, s", 0.0, 1e7),
    Param("gps_offset_at_s", -1.0, "publish one fix displaced north at this simulated s; < 0 = none", -1.0, 1e7),
    Param("gps_offset_m", 500.0, "displacement of that fix, m", 0.0, 1e6),
    Param("gps_nan_at_s", -1.0, "publish one NaN fix at this simulated s; < 0 = none", -1.0, 1e7),
    Param("disconnect_at_s", [-1.0], "unplug the serial port at these simulated s (< 0 = none)"),
    Param("disconnect_for_s", 5.0, "how long each unplug lasts, simulated s", 0.0, 3600.0),
    Param("garbage_every_s", 0.0, "insert a burst of garbage bytes every this many simulated s; 0 = none",
          0.0, 1e6),
    Param("exit_when_done", True, "shut down when the run is over"),
    Param("truth_rate_hz", 10.0, "publish the simulation's truth (sim_dir/truth.csv) on truth/odometry at this "
          "rate, Hz; 0 = none", 0.0, 1000.0),
)


class ScenarioPlayer(Node):
    """Emulator thread + GPS + clock, all on simulated time."""

    def __init__(self, **kwargs):
        super().__init__("scenario_player", **kwargs)
        self.p = declare_parameters(self, PARAMS)
        sim_dir = Path(self.p["sim_dir"])
        if not (sim_dir / "bp3010.bin").exists() or not (sim_dir / "gnss.csv").exists():
            raise ConfigError(f"parameter 'sim_dir': {sim_dir} has no bp3010.bin and gnss.csv "
                              f"(run `imu-sim simulate --out {sim_dir}` first)")
        try:  # a damaged simulation folder is the parameter's fault: one line, exit 2
            counts = counts_from_source(str(sim_dir / "bp3010.bin"), 0.0, 0)
            self.gnss = recording.read_gnss(sim_dir / "gnss.csv")
        except ValueError as err:
            raise ConfigError(f"parameter 'sim_dir': {err}") from None
        if self.gnss.damage:  # read past it: say what was lost
            self.get_logger().warning(self.gnss.damage)
        if len(self.gnss) == 0:
            self.get_logger().warning(f"{sim_dir / 'gnss.csv'}: no fixes: GPS silent for the whole run")
        if self.p["duration_s"] > 0:
            counts = counts[:int(self.p["duration_s"] * 64)]
        self.duration_s = len(counts) / 64.0
        self.clock_pub = self.create_publisher(Clock, "/clock", QoSProfile(depth=10))
        self.gps_pub = link_publisher(self, NavSatFix, "gps/fix")
        self.truth = self._load_truth(sim_dir, self.p["truth_rate_hz"])
        self.truth_pub = self.create_publisher(Odometry, "truth/odometry", 10) if self.truth else None
        self.next_truth = 0
        self.diag = Diagnostics(self, "scenario")
        rate = self.p["rate"]
        disconnects = tuple(t for t in self.p["disconnect_at_s"] if t >= 0)
        faults = FaultPlan(garbage_every_s=self.p["garbage_every_s"], disconnect_at_s=disconnects,
                           disconnect_for_s=self.p["disconnect_for_s"])
        self.port = PtyPort(Path(self.p["link"]))
        self.emulator = Emulator(self.port, counts, faults=faults, speed=rate,
                                 log=lambda s: self.get_logger().info(f"emulator: {s}"))
        self.start_wall = None
        self._ticker = None
        self.next_fix = 0
        self.fixes_sent = 0
        self.done = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="scenario")
        self._thread.start()
        self.create_timer(1.0, self._publish_diagnostics)
        self.get_logger().info(f"ready: {sim_dir} ({self.duration_s:.0f} s simulated) at {rate}x on {self.port.link}")

    def sim_time(self) -> float:
        """Simulated seconds since the start of the run (0 before it starts)."""
        if self.start_wall is None:
            return 0.0
        return (time.monotonic() - self.start_wall) * self.p["rate"]

    def _graph_ready(self) -> bool:
        pubs = all(self.count_publishers(t) > 0 for t in self.p["wait_for_topics"] if t)
        subs = all(self.count_subscribers(t) > 0 for t in self.p["wait_for_subscribers"] if t)
        return pubs and subs

    def _run(self) -> None:
        deadline = time.monotonic() + self.p["wait_timeout_s"]
        with self._until_shutdown():
            while not self._graph_ready() and time.monotonic() < deadline and not self._stop.is_set():
                self._publish_clock(0.0)
                time.sleep(0.05)
            if self._stop.wait(1.0):  # let the subscribers' side of discovery finish
                return
            self.get_logger().info("playing")
            self.start_wall = time.monotonic()
            self._ticker = threading.Thread(target=self._tick, daemon=True, name="clock_gps")
            self._ticker.start()
            # the frames' schedule and /clock share one zero: the emulator's own start, taken after the
            # ticker thread started, was 3-5 ms of wall time later (27-42 ms of simulated time at 8x), and
            # every frame, hence every driver stamp, was that much later than the /clock around it
            self.emulator.run(start=self.start_wall)
            self.done = True
            if not self._stop.is_set():
                self.get_logger().info(f"done: {self.emulator.stats.frames_sent} frames, {self.fixes_sent} fixes")

    def _tick(self) -> None:
        period = 1.0 / self.p["clock_rate_hz"]
        with self._until_shutdown():
            while not self._stop.is_set() and not self.done:
                t = self.sim_time()
                self._publish_clock(t)
                while self.next_fix < len(self.gnss) and self.gnss.t[self.next_fix] <= t:
                    self._publish_fix(self.next_fix)
                    self.next_fix += 1
                while self.truth and self.next_truth < len(self.truth[0]) and self.truth[0][self.next_truth] <= t:
                    self._publish_truth(self.next_truth)
                    self.next_truth += 1
                self._stop.wait(period)

    @contextlib.contextmanager
    def _until_shutdown(self):
        """A thread's body: an error raised because the node is shutting down (Ctrl-C) ends it quietly."""
        try:
            yield
        except Exception:  # noqa: BLE001 - publishing on a context that Ctrl-C just shut down
            if not (self._stop.is_set() or not self.context.ok()):
                raise

    def _publish_clock(self, t: float) -> None:
        msg = Clock()
        msg.clock = stamp_from_s(self.p["epoch_s"] + t)
        self.clock_pub.publish(msg)

    def _publish_fix(self, i: int) -> None:
        t = float(self.gnss.t[i])
        start, length = self.p["gps_outage_start_s"], self.p["gps_outage_duration_s"]
        if 0 <= start <= t < start + length:
            return
        msg = NavSatFix()
        msg.header.stamp = stamp_from_s(self.p["epoch_s"] + t)
        msg.header.frame_id = "gps_link"
        msg.status.status = int(self.gnss.status[i])
        msg.status.service = NavSatStatus.SERVICE_GPS
        lat, lon = math.degrees(self.gnss.lat[i]), math.degrees(self.gnss.lon[i])
        if abs(t - self.p["gps_offset_at_s"]) < 0.5:
            lat += math.degrees(self.p["gps_offset_m"] / 6.371e6)
        if abs(t - self.p["gps_nan_at_s"]) < 0.5:
            lat = lon = float("nan")
        msg.latitude, msg.longitude, msg.altitude = lat, lon, float(self.gnss.h[i])
        msg.position_covariance = np.diag(self.gnss.std_enu[i] ** 2).ravel()
        msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        self.gps_pub.publish(msg)
        self.fixes_sent += 1

    @staticmethod
    def _load_truth(sim_dir: Path, rate_hz: float):
        """(t s from the run's start, ENU (n, 3) m, quaternion xyzw (n, 4)) at ``rate_hz``; None without truth."""
        if rate_hz <= 0 or not (sim_dir / "truth.csv").exists() or not (sim_dir / "sim_info.yaml").exists():
            return None
        track = TruthTrack.from_sim_dir(sim_dir)
        t = track.t - track.epoch_s
        keep = np.flatnonzero(np.diff(np.floor(t * rate_hz), prepend=-1.0) > 0)  # first sample of each period
        quat = frames.quat_xyzw_from_euler(track.rpy[keep, 0], track.rpy[keep, 1], track.rpy[keep, 2])
        return t[keep], track.enu[keep], np.atleast_2d(quat)

    def _publish_truth(self, i: int) -> None:
        t, enu, quat = (a[i] for a in self.truth)
        msg = Odometry()
        msg.header.stamp = stamp_from_s(self.p["epoch_s"] + float(t))
        msg.header.frame_id, msg.child_frame_id = "map", "truth"
        pose = msg.pose.pose
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in enu)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in quat)
        self.truth_pub.publish(msg)

    def _publish_diagnostics(self) -> None:
        stats = self.emulator.stats
        st = ScenarioStatus("OK", "done" if self.done else ("playing" if self.start_wall else "waiting for graph"),
                            float(self.sim_time()), float(self.duration_s), stats.frames_sent, self.fixes_sent,
                            stats.disconnects, stats.garbage_bursts)
        self.diag.publish(st.level, st.message, st.to_values())
        if self.done and self.p["exit_when_done"]:
            rclpy.try_shutdown()

    def close(self) -> None:
        """Stop the threads, then remove the port (Ctrl-C ends the run without a traceback)."""
        self._stop.set()
        self.emulator.stop()
        for thread in (self._thread, self._ticker):
            if thread is not None:
                thread.join(timeout=5.0)
        self.port.unplug()


def main(args=None) -> int:
    """Entry point of ``scenario_player``."""
    return run_node(ScenarioPlayer, args, usage=(
        "scenario_player",
        "Play a simulated run live: BP3010 frames into a pty, GPS fixes and /clock.",
        PARAMS,
        "scenario_player --ros-args -p sim_dir:=out/demo/sim_seed1 -p link:=/tmp/bp3010"))


if __name__ == "__main__":
    raise SystemExit(main())
