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
    cleared_s: float = float("nan")
    """When the latest event's fault went away (a held vibration line); NaN while it lasts or when not followed."""

    PRECISE = ("onset_s", "t_s", "cleared_s")
    SUMMARY = ("events",)


def statuses(monitor, now_s: float, counts: dict) -> dict:
    """Name (a channel or ``summary``) -> :class:`ChannelStatus`; the summary has the worst level."""
    out = {}
    for ch, (level, e) in monitor.channel_status(now_s).items():
        out[ch] = _from_event(level, e, counts.get(ch, 0), _cleared(monitor, ch, e))
    worst = max((s.level for s in out.values()), key=("OK", "WARN", "ERROR").index)
    named = [f"{ch}: {s.effect}" for ch, s in out.items() if s.level != "OK"]
    total = counts.get(SUMMARY, 0)
    out[SUMMARY] = ChannelStatus(worst, "; ".join(named) if named else f"healthy ({total} events so far)",
                                 events=total)
    return out


def _cleared(monitor, ch: str, e: Event | None) -> float:
    """When the fault of event ``e`` on ``ch`` was cleared (NaN: not cleared, or not a followed fault)."""
    times = [c["t_s"] for c in monitor.cleared if e is not None and c["effect"] == e.effect and ch in c["channels"]
             and c["t_s"] >= e.t_s]
    return max(times) if times else float("nan")


def _from_event(level: str, e: Event | None, n: int, cleared_s: float = float("nan")) -> ChannelStatus:
    if e is None:
        return ChannelStatus("OK", "healthy", events=n)
    d = e.to_dict()
    if level != "OK":
        message = e.message
    elif cleared_s == cleared_s:
        message = f"healthy: {e.effect} cleared at t {cleared_s:.3f} s"
    else:
        message = f"healthy (last: {e.effect})"
    return ChannelStatus(level, message, e.effect, e.onset_s, e.t_s, json.dumps(d["estimate"]),
                         json.dumps(d["interval_95"]), n, cleared_s)


def count_events(counts: dict, events) -> dict:
    """Add events to per-channel and summary counts."""
    for e in events:
        counts[SUMMARY] = counts.get(SUMMARY, 0) + 1
        for ch in e.channels:
            if ch in CHANNELS:
                counts[ch] = counts.get(ch, 0) + 1
    return counts
