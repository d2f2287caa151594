"""Live one-line status of a running graph: simulated time, filter state, fixes, position error (rclpy)."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from nav_bringup.truth import TruthTrack


def watch(graph, player: str, sim_dir: Path | None, period_s: float = 5.0) -> None:
    """Print a status line every ``period_s`` until the player node exits (or any node dies)."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from nav_msgs.msg import Odometry

    from nav_core.ros_node import Probe, stamp_to_s

    truth = TruthTrack.from_sim_dir(sim_dir) if sim_dir else None
    rclpy.init()
    probe = Probe({"odometry/filtered": Odometry})
    diags = {}
    probe.create_subscription(DiagnosticArray, "/diagnostics",
                              lambda m: diags.update({s.name: s for s in m.status}), 50)
    print(f"{'wall':>6} {'sim t':>8} {'odom':>6} {'filter':<28} {'fixes':>6} {'rej':>4} {'pos err':>8}")
    print(f"{'s':>6} {'s':>8} {'msgs':>6} {'':<28} {'':>6} {'':>4} {'m':>8}")
    start = time.monotonic()
    try:
        while True:
            probe.spin_until(lambda p: False, period_s)
            dead = graph.dead()
            odom = probe.received["odometry/filtered"]
            kf = next((s for n, s in diags.items() if "ins_gps_kf" in n), None)
            kfv = {kv.key: kv.value for kv in kf.values} if kf else {}
            err = ""
            if odom and truth is not None:
                msg = odom[-1][1]
                p = msg.pose.pose.position
                err = f"{truth.horizontal_error(stamp_to_s(msg.header.stamp), np.array([p.x, p.y, p.z])):8.2f}"
            first = stamp_to_s(odom[0][1].header.stamp) if odom else 0.0
            sim_t = stamp_to_s(odom[-1][1].header.stamp) - (truth.epoch_s if truth else first) if odom else 0.0
            print(f"{time.monotonic() - start:6.0f} {sim_t:8.1f} {len(odom):6d} "
                  f"{(kf.message if kf else 'waiting')[:28]:<28} {kfv.get('fixes', '-'):>6} "
                  f"{kfv.get('rejected_fixes', '-'):>4} {err:>8}", flush=True)
            if player in dead:
                time.sleep(2.0)  # let the filter finish the last samples
                return
            others = {k: v for k, v in dead.items() if k != player}
            if others:
                print(f"[demo] node(s) exited early: {others}")
                return
    finally:
        probe.destroy_node()
        rclpy.try_shutdown()
