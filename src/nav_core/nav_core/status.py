"""Typed node status: a node's ``/diagnostics`` values as a dataclass that the node writes and the report reads.

A node's core defines ``@dataclass class XStatus(NodeStatus)`` (``level`` and ``message`` first, then
typed fields with defaults); the node publishes ``level``, ``message`` and :meth:`NodeStatus.to_values`,
and a reader parses them back with :meth:`NodeStatus.from_values` through the same type, so no key is
spelled in two places. A missing or unreadable value takes the field's default (a status from an older
node still parses). A field holding a dataclass is written flat, its fields among the others.
"""
from __future__ import annotations

import dataclasses

_DEFAULT = object()


class NodeStatus:
    """Base of the status dataclasses; subclasses are ``@dataclass`` with ``level`` and ``message`` first."""

    PRECISE: tuple = ()
    """Float fields written to 1 us (stamps in s) instead of 6 significant digits."""
    SUMMARY: tuple = ()
    """Fields the report's one-line summary of the node shows."""

    def to_values(self) -> dict:
        """``/diagnostics`` key -> string; ``level`` and ``message`` are the status's own fields."""
        out = {}
        for f in dataclasses.fields(self):
            if f.name in ("level", "message"):
                continue
            value = getattr(self, f.name)
            if dataclasses.is_dataclass(value):
                out.update({k: str(v) for k, v in dataclasses.asdict(value).items()})
            elif value is None:
                out[f.name] = ""
            elif isinstance(value, float):
                out[f.name] = f"{value:.6f}" if f.name in self.PRECISE else f"{value:.6g}"
            else:
                out[f.name] = str(value)
        return out

    @classmethod
    def from_values(cls, values: dict, level: str = "STALE", message: str = ""):
        """The status from ``/diagnostics`` values (strings), with its level name and message."""
        return _parse_fields(cls, values, {"level": level, "message": message})

    def summary(self) -> str:
        """``key value, ...`` of the :attr:`SUMMARY` fields."""
        values = self.to_values()
        return ", ".join(f"{k} {values[k]}" for k in self.SUMMARY)


def level_name(level: int) -> str:
    """``DiagnosticStatus.level`` (0..3) as the name the statuses carry."""
    return ("OK", "WARN", "ERROR", "STALE")[min(int(level), 3)]


def _parse_fields(cls, values: dict, given: dict | None = None):
    """A dataclass ``cls`` from the string ``values`` of its fields (nested dataclass fields read flat)."""
    kwargs = dict(given or {})
    for f in dataclasses.fields(cls):
        if f.name in kwargs:
            continue
        if f.default_factory is not dataclasses.MISSING and dataclasses.is_dataclass(f.default_factory):
            kwargs[f.name] = _parse_fields(f.default_factory, values)
        elif f.name in values:
            value = _parse(f, values[f.name])
            if value is not _DEFAULT:
                kwargs[f.name] = value
    return cls(**kwargs)


def _parse(f: dataclasses.Field, text):
    """The value of field ``f`` from its string (the type from the field's default), or _DEFAULT."""
    default = f.default if f.default is not dataclasses.MISSING else None
    text = str(text)
    try:
        if isinstance(default, bool):
            return text == "True"
        if isinstance(default, int):
            return int(float(text))
        if isinstance(default, float):
            return float(text)
        if default is None:  # optional numbers: "" is None
            return None if text == "" else float(text)
    except ValueError:
        return _DEFAULT
    return text


