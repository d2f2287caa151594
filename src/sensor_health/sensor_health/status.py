"""The node's status as a typed record (:class:`nav_core.status.NodeStatus`): what it writes to /diagnostics per
channel and for the summary, and what readers (the demo report, the tests) parse back through the same type.
No ROS."""
from __future__ import annotations

import json
from dataclasses import dataclass

from nav_core.status import NodeStatus
from sensor_health.events import CHANNELS, Event

SUMMARY = "summary"


@dataclass
class ChannelStatus(NodeStatus):
    """One channel (or the summary): OK/WARN/ERROR, a message and the latest event's key-values."""

    level: str = "OK"
    message: str = ""
    effect: str = ""
    onset_s: float = float("nan")
    t_s: float = float("nan")
    estimate: str = ""
    interval_95: str = ""
    events: int = 0

    PRECISE = ("onset_s", "t_s")
    SUMMARY = ("events",)


def statuses(monitor, now_s: float, counts: dict) -> dict:
    """Name (a channel or ``summary``) -> :class:`ChannelStatus`; the summary has the worst level."""
    out = {}
    for ch, (level, e) in monitor.channel_status(now_s).items():
        out[ch] = _from_event(level, e, counts.get(ch, 0))
    worst = max((s.level for s in out.values()), key=("OK", "WARN", "ERROR").index)
    named = [f"{ch}: {s.effect}" for ch, s in out.items() if s.level != "OK"]
    total = counts.get(SUMMARY, 0)
    out[SUMMARY] = ChannelStatus(worst, "; ".join(named) if named else f"healthy ({total} events so far)",
                                 events=total)
    return out


def _from_event(level: str, e: Event | None, n: int) -> ChannelStatus:
    if e is None:
        return ChannelStatus("OK", "healthy", events=n)
    d = e.to_dict()
    return ChannelStatus(level, e.message if level != "OK" else f"healthy (last: {e.effect})", e.effect,
                         e.onset_s, e.t_s, json.dumps(d["estimate"]), json.dumps(d["interval_95"]), n)


def count_events(counts: dict, events) -> dict:
    """Add events to per-channel and summary counts."""
    for e in events:
        counts[SUMMARY] = counts.get(SUMMARY, 0) + 1
        for ch in e.channels:
            if ch in CHANNELS:
                counts[ch] = counts.get(ch, 0) + 1
    return counts
