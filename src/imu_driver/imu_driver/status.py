"""The BP3010 driver's status, typed (:class:`nav_core.status.NodeStatus`): frames, errors, stamping, port state.

The driver node writes it to ``/diagnostics``; the report and the tests read it back through this type.
"""
from __future__ import annotations

from dataclasses import dataclass

from nav_core.status import NodeStatus


@dataclass
class DriverStatus(NodeStatus):
    """Counts since start, the rate over the last second (Hz) and the stamping's state (s, ppm)."""

    SUMMARY = ("frames_received", "checksum_errors", "lost_frames")

    level: str = "STALE"
    message: str = ""
    frames_received: int = 0
    checksum_errors: int = 0
    resyncs: int = 0
    lost_frames: int = 0
    bytes_discarded: int = 0
    actual_rate_hz: float = 0.0
    nominal_rate_hz: int = 0
    port: str = ""
    port_state: str = ""
    counter_jumps: int = 0
    duplicates: int = 0
    reconnects: int = 0
    clock_reanchors: int = 0
    clock_gaps_bridged: int = 0
    stamp_read_delay_s: float = 0.0
    stamp_ahead_s: float = 0.0
    stamp_slewed_frames: int = 0
    stamp_drift_ppm: float = 0.0
    sim_clock_rate: float = 0.0
    frames_before_clock: int = 0
    last_error: str = ""


def driver_status(stats, clock, rate_hz: float, nominal_rate_hz: int, port: str, port_state: str, reconnects: int,
                  sim_clock_rate: float, frames_before_clock: int, last_error: str) -> DriverStatus:
    """The status from the decoder's ``stats`` and the stamping ``clock`` (:mod:`imu_driver.driver_core`); ERROR
    while the port is not connected, WARN below half the nominal rate."""
    if port_state != "connected":
        level, message = "ERROR", f"port {port_state}"
    elif rate_hz < 0.5 * nominal_rate_hz:
        level, message = "WARN", f"receiving {rate_hz:.1f} Hz of {nominal_rate_hz} Hz"
    else:
        level, message = "OK", "receiving"
    return DriverStatus(level, message, stats.frames, stats.checksum_errors, stats.resyncs, stats.lost_frames,
                        stats.bytes_discarded, rate_hz, nominal_rate_hz, port, port_state, stats.counter_jumps,
                        stats.duplicates, reconnects, clock.reanchors, clock.gaps_bridged, clock.delay_s,
                        clock.ahead_s, clock.slewed_frames, clock.drift * 1e6, sim_clock_rate, frames_before_clock,
                        last_error)
