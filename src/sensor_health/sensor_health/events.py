"""The effect vocabulary of the health monitor and its event record (what health.json and the node publish)."""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

from nav_core.noise_stats import Z95

CHANNELS = ("gx", "gy", "gz", "ax", "ay", "az")
"""Sensor channels: gyro x y z (rad/s), accelerometer x y z (m/s^2)."""

EFFECTS = {
    "white_noise_increase": "the white-noise level of a channel rose above the model's (estimate: sd factor)",
    "vibration": "a new spectral line (estimate: frequency Hz and amplitude per channel, SI)",
    "stuck_output": "a channel repeats one value exactly (frozen), longer than the model's noise allows",
    "saturation": "a channel sits at its range or clips (flat tops at one value; estimate: the clip value)",
    "non_finite": "NaN or infinite samples (estimate: how many)",
    "bias_shift": "the channel's mean stepped (estimate: the step, SI), where the motion keeps it observable",
    "scale_factor_change": "the channel's scale factor changed, where the motion makes it observable (gz: yaw "
                           "against the GNSS course in turns; estimate: relative change, 0.02 = +2 %)",
    "turn_on_bias": "at an unaccelerated start, a channel's bias lies outside the model's stated turn-on bounds "
                    "(estimate: the bias less the model's, SI; accelerometer: along gravity)",
    "dropout": "samples missing: a stamp gap above gap_factor sample intervals (estimate: gap s)",
    "sample_rate_change": "the sample interval changed for good (estimate: the new rate, Hz)",
}
"""Effect name -> what it means. The README documents each with how it is detected and estimated."""

LEVELS = ("OK", "WARN", "ERROR")


def _finite(x):
    """JSON has no NaN: non-finite floats become None (nested lists and dicts too)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


@dataclass
class Event:
    """One named fault: detected at ``t_s``, began at ``onset_s`` (recording time, s); or, with level ``OK`` and
    ``statistic["cleared"]``, a named fault seen gone at ``t_s`` (:func:`cleared_event`)."""

    t_s: float
    onset_s: float
    effect: str
    channels: list
    level: str
    estimate: object
    interval_95: object
    message: str
    statistic: dict = field(default_factory=dict)
    """The detector's statistic and threshold at detection (for the reader who wants to judge the margin)."""

    def __post_init__(self):
        if self.effect not in EFFECTS:
            raise ValueError(f"unknown effect {self.effect!r}; the vocabulary is {sorted(EFFECTS)}")
        if self.level not in ("WARN", "ERROR") and not (self.level == "OK" and self.statistic.get("cleared")):
            raise ValueError(f"event level must be WARN or ERROR (OK only for a cleared fault), not {self.level!r}")

    @property
    def cleared(self) -> bool:
        """A fault that went away, not a new one."""
        return self.level == "OK"

    def to_dict(self) -> dict:
        """The health.json form (plain types, NaN as null)."""
        return _finite(asdict(self))

    @classmethod
    def from_dict(cls, data: dict) -> Event:
        """Inverse of :meth:`to_dict` (the report and the tests read events back through it)."""
        return cls(**{k: data[k] for k in ("t_s", "onset_s", "effect", "channels", "level", "estimate",
                                          "interval_95", "message")}, statistic=data.get("statistic", {}))

    def to_json(self) -> str:
        """One line of JSON (the event topic carries it)."""
        return json.dumps(self.to_dict(), sort_keys=True)


def bias_shift_event(t_s: float, onset_s: float, channel: str, step: float, sd: float, message: str,
                     statistic: dict) -> Event:
    """A ``bias_shift`` WARN on one channel: the step (the channel's SI unit) and its 95 % interval from its sd."""
    return Event(t_s, onset_s, "bias_shift", [channel], "WARN", step, [step - Z95 * sd, step + Z95 * sd], message,
                 statistic)


def cleared_event(note: dict) -> Event:
    """A fault that went away (the monitor's ``cleared`` notes: effect, channels, t_s seen gone, since_s named) as an
    ``OK`` event for the event topic."""
    chans = ", ".join(note["channels"])
    return Event(note["t_s"], note["t_s"], note["effect"], list(note["channels"]), "OK", None, None,
                 f"{note['effect']} on {chans} cleared (named at {note['since_s']:.3f} s)",
                 {"cleared": True, "named_s": note["since_s"]})
