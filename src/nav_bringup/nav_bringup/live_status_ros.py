"""ROS glue of the demo and the graph tests: an rclpy probe on a running graph, and the live one-line status
(simulated clock, filter state, fixes, position error)."""
from __future__ import annotations

import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ins_gps_kf.status import FilterStatus
from nav_bringup.truth import TruthTrack


@contextmanager
def graph_probe(topics: dict):
    """rclpy up and a Probe on ``topics`` plus /diagnostics (newest status per node in ``probe.diags``).

    rclpy is shut down on exit; the launch_testing pattern of the graph tests and benchmarks.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray

    from nav_core.ros_node import Probe

    rclpy.init()
    probe = Probe(topics)
    probe.diags = {}
    probe.create_subscription(DiagnosticArray, "/diagnostics",
                              lambda m: probe.diags.update({s.name.split(":")[0]: s for s in m.status}), 100)
    try:
        yield probe
    finally:
        probe.destroy_node()
        rclpy.try_shutdown()


def diag_values(probe) -> dict:
    """Node name -> {key: value} of the newest diagnostics each node published."""
    return {name: {kv.key: kv.value for kv in st.values} for name, st in probe.diags.items()}


def watch(graph, player: str, sim_dir: Path | None, period_s: float = 5.0, on_clock=None, start=None) -> None:
    """Print a status line every ``period_s`` until the player node exits (or any node dies); ``on_clock(t, clock)``
    is called with the simulated time of each ``/clock`` received (s from the start of the drive, and as sent).
    ``start()`` starts the graph once the probe is up: the player plays about a second after the graph is ready,
    and a probe made after that (its truth track alone took 4 s at load 25) saw its first ``/clock`` tens of
    simulated seconds into the drive at 6-8x, past a link cut scheduled on it."""
    from nav_msgs.msg import Odometry
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock

    from nav_core.ros_node import stamp_to_s

    truth = TruthTrack.from_sim_dir(sim_dir) if sim_dir else None
    with graph_probe({"odometry/filtered": Odometry}) as probe:
        probe.clock = {}  # first and newest /clock (s): the simulated time runs from the start, navigating or not
        epoch = truth.epoch_s if truth else None
        probe.create_subscription(Clock, "/clock", lambda m: _on_clock(probe.clock, stamp_to_s(m.clock), epoch,
                                                                       on_clock),
                                  QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        if start is not None:
            start()
        _print_status(graph, player, probe, truth, period_s, stamp_to_s)


def _on_clock(clock: dict, t_s: float, epoch_s: float | None = None, on_clock=None) -> None:
    clock.setdefault("first", t_s)
    clock["now"] = t_s
    if on_clock is not None:
        on_clock(t_s - (clock["first"] if epoch_s is None else epoch_s), t_s)


def _print_status(graph, player, probe, truth, period_s, stamp_to_s) -> None:
    """The status loop of :func:`watch`."""
    print(f"{'wall':>6} {'sim t':>8} {'odom':>6} {'filter':<28} {'fixes':>6} {'rej':>4} {'pos err':>8}")
    print(f"{'s':>6} {'s':>8} {'msgs':>6} {'':<28} {'':>6} {'':>4} {'m':>8}")
    start = time.monotonic()
    while True:
        probe.spin_until(lambda p: False, period_s)
        dead = graph.dead()
        odom = probe.received["odometry/filtered"]
        kf = probe.diags.get("ins_gps_kf_node")
        kfv = FilterStatus.from_values(diag_values(probe)["ins_gps_kf_node"]) if kf else None
        err = ""
        if odom and truth is not None:
            msg = odom[-1][1]
            p = msg.pose.pose.position
            err = f"{truth.horizontal_error(stamp_to_s(msg.header.stamp), np.array([p.x, p.y, p.z])):8.2f}"
        clock = probe.clock
        sim_t = clock["now"] - (truth.epoch_s if truth else clock["first"]) if clock else 0.0
        print(f"{time.monotonic() - start:6.0f} {sim_t:8.1f} {len(odom):6d} "
              f"{(kf.message if kf else 'waiting')[:28]:<28} {kfv.fixes if kf else '-':>6} "
              f"{kfv.rejected_fixes if kf else '-':>4} {err:>8}", flush=True)
        if player in dead:
            time.sleep(2.0)  # let the filter finish the last samples
            return
        others = {k: v for k, v in dead.items() if k != player}
        if others:
            print(f"[demo] node(s) exited early: {others}")
            return
