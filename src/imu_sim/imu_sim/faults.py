"""Sensor faults a scenario injects (``faults:`` in the scenario YAML), applied to the simulated IMU output.

Each entry names an effect of the health monitor's vocabulary (``sensor_health``), the channel and when it
starts, so the demo can show a fault being named live::

    faults:
      - {effect: vibration, channel: gy, start_s: 240, frequency_hz: 12.5, amplitude: 0.02}   # rad/s
      - {effect: white_noise_increase, channel: az, start_s: 400, factor: 3}
      - {effect: stuck_output, channel: gx, start_s: 500}
      - {effect: bias_shift, channel: gx, start_s: 300, step: 0.002}                          # rad/s
      - {effect: saturation, channel: gz, start_s: 100, level: 0.2}                           # rad/s
      - {effect: scale_factor_change, channel: gz, start_s: 300, change: 0.02}                # +2 %

Amplitudes, steps and levels in SI (rad/s for g*, m/s^2 for a*); ``start_s`` from the start of the scenario,
``end_s`` optional. Applied to the rates (increments / dt) after the sensor's own errors.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CHANNELS = ("gx", "gy", "gz", "ax", "ay", "az")
EFFECT_KEYS = {"vibration": ("frequency_hz", "amplitude"), "white_noise_increase": ("factor",),
               "stuck_output": (), "bias_shift": ("step",), "saturation": ("level",),
               "scale_factor_change": ("change",)}
"""Effects a scenario can inject and the parameters each needs (the monitor's names)."""


class FaultError(ValueError):
    """A ``faults:`` entry is invalid; the message names the file, the entry and the key."""


@dataclass(frozen=True)
class Fault:
    """One injected fault: effect, channel index, start and end (s), parameters (SI)."""

    effect: str
    channel: int
    start_s: float
    end_s: float
    params: dict


def parse(data, where: str) -> tuple:
    """Validate a ``faults:`` list (None: no faults)."""
    if data is None:
        return ()
    if not isinstance(data, list) or not all(isinstance(d, dict) for d in data):
        raise FaultError(f"{where}: faults: expected a list of mappings")
    return tuple(_one(d, f"{where}: faults[{i}]") for i, d in enumerate(data))


def _one(d: dict, where: str) -> Fault:
    effect = d.get("effect")
    if effect not in EFFECT_KEYS:
        raise FaultError(f"{where}: effect {effect!r}: expected one of {sorted(EFFECT_KEYS)}")
    known = {"effect", "channel", "start_s", "end_s", *EFFECT_KEYS[effect]}
    unknown = sorted(set(d) - known)
    if unknown:
        raise FaultError(f"{where}: unknown key(s) {unknown} for {effect}; known: {sorted(known)}")
    if d.get("channel") not in CHANNELS:
        raise FaultError(f"{where}: channel {d.get('channel')!r}: expected one of {list(CHANNELS)}")
    params = {}
    for key in ("start_s", "end_s", *EFFECT_KEYS[effect]):
        if key not in d:
            if key in ("start_s", "end_s"):
                continue
            raise FaultError(f"{where}: {effect} needs {key}")
        value = d[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise FaultError(f"{where}: {key}: expected a finite number, got {value!r}")
        params[key] = float(value)
    start, end = params.pop("start_s", 0.0), params.pop("end_s", np.inf)
    if end <= start:
        raise FaultError(f"{where}: end_s {end:g} must be after start_s {start:g}")
    return Fault(effect, CHANNELS.index(d["channel"]), start, end, params)


def apply(faults, t: np.ndarray, rates: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``rates`` (n, 6) rad/s and m/s^2 at times t (n,) s from the scenario start, with the faults applied."""
    out = np.array(rates, float)
    for f in faults:
        on = (t >= f.start_s) & (t < f.end_s)
        if not on.any():
            continue
        c, p = f.channel, f.params
        if f.effect == "vibration":
            out[on, c] += p["amplitude"] * np.sin(2 * np.pi * p["frequency_hz"] * t[on])
        elif f.effect == "white_noise_increase":
            sd = np.std(np.diff(out[:, c])) / np.sqrt(2)  # the channel's own per-sample noise
            out[on, c] += rng.normal(0.0, sd * np.sqrt(max(p["factor"] ** 2 - 1, 0.0)), on.sum())
        elif f.effect == "stuck_output":
            out[on, c] = out[np.argmax(on), c]
        elif f.effect == "bias_shift":
            out[on, c] += p["step"]
        elif f.effect == "saturation":
            out[on, c] = np.clip(out[on, c], -p["level"], p["level"])
        elif f.effect == "scale_factor_change":  # relative: the output is (1 + change) times what it was
            out[on, c] *= 1.0 + p["change"]
    return out
