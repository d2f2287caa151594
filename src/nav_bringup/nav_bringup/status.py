"""The scenario player's status, typed (:class:`nav_core.status.NodeStatus`), ROS-free: the node writes it to
``/diagnostics``, nav-demo's report reads it back through this type."""
from __future__ import annotations

from dataclasses import dataclass

from nav_core.status import NodeStatus


@dataclass
class ScenarioStatus(NodeStatus):
    """The player's status: simulated time played and planned (s), frames and fixes sent, pty faults."""

    SUMMARY = ("sim_time_s", "frames_sent", "fixes_sent")

    level: str = "STALE"
    message: str = ""
    sim_time_s: float = 0.0
    duration_s: float = 0.0
    frames_sent: int = 0
    fixes_sent: int = 0
    disconnects: int = 0
    garbage_bursts: int = 0
