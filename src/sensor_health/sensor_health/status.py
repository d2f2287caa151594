"""The node's status as a typed record: what it writes to /diagnostics and what readers (the demo report, the
tests) parse back through the same keys. No ROS."""
from __future__ import annotations

import json
from dataclasses import dataclass

from sensor_health.events import CHANNELS, Event

SUMMARY = "summary"
KEYS = ("effect", "onset_s", "t_s", "estimate", "interval_95", "events")


@dataclass
class ChannelStatus:
    """One channel (or the summary): OK/WARN/ERROR, a message and the latest event's key-values."""

    name: str
    level: str
    message: str
    effect: str = ""
    onset_s: float = float("nan")
    t_s: float = float("nan")
    estimate: str = ""
    interval_95: str = ""
    events: int = 0

    def values(self) -> dict:
        """Key -> text for DiagnosticStatus.values."""
        return {k: _text(getattr(self, k)) for k in KEYS}

    @classmethod
    def from_values(cls, name: str, level: str, message: str, values: dict) -> ChannelStatus:
        """Inverse of :meth:`values` (missing keys keep their defaults)."""
        kw = {}
        for k in KEYS:
            if k in values:
                kw[k] = float(values[k]) if k in ("onset_s", "t_s") else int(values[k]) if k == "events" \
                    else values[k]
        return cls(name, level, message, **kw)


def _text(v) -> str:
    return f"{v:.6f}" if isinstance(v, float) else str(v)


def statuses(monitor, now_s: float, counts: dict) -> list:
    """One :class:`ChannelStatus` per channel and the summary (worst level, number of events)."""
    out = []
    for ch, (level, e) in monitor.channel_status(now_s).items():
        out.append(_from_event(ch, level, e, counts.get(ch, 0)))
    worst = max((s.level for s in out), key=("OK", "WARN", "ERROR").index)
    named = [f"{s.name}: {s.effect}" for s in out if s.level != "OK"]
    total = counts.get(SUMMARY, 0)
    msg = "; ".join(named) if named else f"healthy ({total} events so far)"
    out.append(ChannelStatus(SUMMARY, worst, msg, events=total))
    return out


def _from_event(ch: str, level: str, e: Event | None, n: int) -> ChannelStatus:
    if e is None:
        return ChannelStatus(ch, "OK", "healthy", events=n)
    return ChannelStatus(ch, level, e.message if level != "OK" else f"healthy (last: {e.effect})", e.effect,
                         e.onset_s, e.t_s, json.dumps(e.to_dict()["estimate"]),
                         json.dumps(e.to_dict()["interval_95"]), n)


def count_events(counts: dict, events) -> dict:
    """Add events to per-channel and summary counts."""
    for e in events:
        counts[SUMMARY] = counts.get(SUMMARY, 0) + 1
        for ch in e.channels:
            if ch in CHANNELS:
                counts[ch] = counts.get(ch, 0) + 1
    return counts
