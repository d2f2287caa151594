"""The filter node's status, typed: built from the core, serialised to ``/diagnostics`` key-value strings by the
node and parsed back by the report through the same type, so no key is spelled in two places.

:meth:`FilterStatus.to_values` gives the ``DiagnosticStatus`` values (strings); :meth:`FilterStatus.from_values`
reads them back (a missing or unreadable value takes the field's default: a status from an older node
still parses). The rejected-input counts are :class:`ins_gps_kf.input_checks.InputCounters`' own fields.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from nav_core.status import NodeStatus
from nav_core.units import DEG
from ins_gps_kf.input_checks import InputCounters
from ins_gps_kf.records import ALIGNING, NAVIGATING

INPUT_STALE_S = 1.0
"""s of the node's steady clock with no IMU or GPS message after which its status says the input is stale (a link
down between the sensor and the compute host; the simulated /clock may be stopped with it)."""


@dataclass
class FilterStatus(NodeStatus):
    """What the filter node reports each second: state, GNSS use, the intake's drops, rejected input (SI, s)."""

    PRECISE = ("first_imu_stamp_s", "first_fix_stamp_s")  # the report matches bag stamps by them
    SUMMARY = ("state", "fixes", "rejected_fixes")

    level: str = "STALE"  # OK | WARN | ERROR
    message: str = ""
    state: str = ""
    last_nis: float = math.nan
    fixes: int = 0
    rejected_fixes: int = 0
    invalid_fixes: int = 0
    reused_fixes: int = 0
    gps_resets: int = 0
    gps_age_s: float = math.inf
    zupts: int = 0
    nhc_updates: int = 0
    nhc_rejected: int = 0
    nhc_mounting_pitch_deg: float | None = None  # the IMU's mounting estimated from the drive (None: not yet)
    nhc_mounting_yaw_deg: float | None = None
    epochs: int = 0
    alignment: str = ""
    filter_resets: int = 0
    imu_gaps_bridged: int = 0
    last_reset: str = ""
    # the node's intake: everything it dropped, and why; samples missing in the stamps it released
    late_dropped: int = 0
    late_imu: int = 0
    late_fixes: int = 0
    bad_stamps: int = 0
    imu_missing: int = 0
    node_resets: int = 0
    fixes_stamped_back: int = 0
    fixes_stamped_ahead: int = 0
    imu_received: int = 0
    fixes_received: int = 0
    queued: int = 0
    # the first stamps received: the report replays the run's bag from them, s (None until one comes)
    first_imu_stamp_s: float | None = None
    first_fix_stamp_s: float | None = None
    bad_imu_messages: int = 0
    nonfinite_estimates: int = 0
    processing_errors: int = 0
    last_processing_error: str = ""
    input: InputCounters = field(default_factory=InputCounters)  # the core's rejected and doubtful input
    align_roll_deg: float | None = None
    align_pitch_deg: float | None = None
    input_stale_s: float = 0.0  # the node's steady-clock time since its last IMU or GPS message (0 before any)
    # the wheel odometer (odometer_enabled): speeds received, used and gated out at epochs, dropped by the intake
    # as late, messages that did not decode; its estimated scale-factor error, % (None: odometer off)
    wheel_speeds_received: int = 0
    odometer_updates: int = 0
    odometer_rejected: int = 0
    odometer_gaps: int = 0  # runs of epochs without a wheel speed within odometer_max_age_s (NHC alone)
    late_odometer: int = 0
    bad_odometer_messages: int = 0
    odometer_scale_pct: float | None = None


def filter_status(filt, intake, first_imu_t=None, first_fix_t=None, bad_imu_messages=0, nonfinite_estimates=0,
                  processing_errors=0, last_processing_error="", bad_odometer_messages=0) -> FilterStatus:
    """The status of ``filt`` (:class:`ins_gps_kf.filter.InsGpsFilter`) behind ``intake``
    (:class:`ins_gps_kf.intake.StampOrderIntake`), with the node's own counts; level and message included."""
    c, ic, cfg = filt.counters, intake.counters, filt.cfg
    age = (intake.last_t - filt.last_fix_t) if intake.last_t is not None else math.inf
    level, message = _level(filt, age, ic.dropped, nonfinite_estimates, processing_errors)
    st = FilterStatus(
        level, message, filt.status, filt.last_nis, c.fixes, c.fixes_rejected, c.fixes_invalid, c.fixes_reused,
        c.gps_resets, age, c.zupts, c.nhc_updates, c.nhc_rejected, *filt.nhc.mounting_deg(), c.epochs,
        ("aligned" if filt.alignment is not None else
         f"{filt.aligner.elapsed_s:.1f}/{cfg.alignment_time_s:.0f} s stationary" if filt.status == ALIGNING
         else "waiting for a GPS fix (datum)"),
        c.resets, c.gaps_bridged, c.reset_reasons[-1] if c.reset_reasons else "",
        ic.dropped, ic.late_imu, ic.late_fixes, ic.bad_stamps, ic.imu_missing, ic.restarts, ic.fixes_stamped_back,
        ic.fixes_stamped_ahead, ic.imu_samples, ic.fixes, intake.pending, first_imu_t, first_fix_t,
        bad_imu_messages, nonfinite_estimates, processing_errors, last_processing_error,
        dataclasses.replace(filt.input),
        filt.alignment.roll / DEG if filt.alignment is not None else None,
        filt.alignment.pitch / DEG if filt.alignment is not None else None)
    st.wheel_speeds_received, st.late_odometer, st.bad_odometer_messages = (ic.wheel_speeds, ic.late_odometer,
                                                                            bad_odometer_messages)
    st.odometer_updates, st.odometer_rejected = c.odometer_updates, c.odometer_rejected
    st.odometer_gaps = c.odometer_gaps
    st.odometer_scale_pct = 100.0 * filt.odometer.scale if cfg.odometer_enabled else None
    if cfg.odometer_enabled and not ic.wheel_speeds and filt.status == NAVIGATING:  # a topic or type mistaken
        st.level = "WARN"
        st.message += "; odometer on but no wheel speed received (odometer_topic, odometer_msg_type?)"
    return st


def _level(filt, age, dropped, nonfinite, errors) -> tuple[str, str]:
    """(level, message): OK while navigating on fresh GNSS, WARN on INS only, while aligning or after drops."""
    stale_gps = age > 3.0 / filt.cfg.gps_rate_hz
    if filt.status == NAVIGATING and not stale_gps:
        level, message = "OK", "navigating"
    elif filt.status == NAVIGATING:
        level, message = "WARN", f"navigating on INS only (GPS age {age:.1f} s)"
    else:
        level, message = "WARN", filt.status
    if dropped or nonfinite or errors:
        message += f"; input dropped {dropped}, non-finite estimates {nonfinite}, errors {errors}"
        level = "WARN"
    if filt.input.gnss_clock_steps:  # fixes re-stamped onto the IMU clock: worth a look at the receiver
        message += f"; GNSS clock steps {filt.input.gnss_clock_steps}"
        level = "WARN"
    return level, message


def mark_stale(st: FilterStatus, stale_s: float) -> FilterStatus:
    """``st`` with its input's staleness ``stale_s`` (s, steady clock); past :data:`INPUT_STALE_S` it warns that
    the filter holds its last estimate until input comes back (then it bridges the gap: ``max_bridged_gap_s``)."""
    st.input_stale_s = float(stale_s)
    if stale_s > INPUT_STALE_S:
        st.level = "WARN" if st.level == "OK" else st.level
        st.message = f"input stale for {stale_s:.1f} s (no IMU or GPS message): holding the last estimate; {st.message}"
    return st


class StatusOnResume:
    """Says when the filter node's status is due out of its period: at the first fix taken after a stale spell of
    its input (a link back), so 'input stale' turns to 'navigating' at once, not up to a status period (one
    simulated second) later. It only reads the filter's fix count: the filter's output is the same either way."""

    def __init__(self):
        self.fixes_before: int | None = None  # the filter's fix count when the input came back (None: not armed)

    def input_resumed(self, fixes: int) -> None:
        """The input came back after a stale spell, the filter having taken ``fixes`` fixes so far."""
        self.fixes_before = int(fixes)

    def due(self, fixes: int) -> bool:
        """Whether a status is due now, the filter having taken ``fixes`` fixes: once, at the first fix since
        :meth:`input_resumed`."""
        if self.fixes_before is None or fixes <= self.fixes_before:
            return False
        self.fixes_before = None
        return True
