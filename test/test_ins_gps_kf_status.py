"""The filter node's typed status: built from the core, written as /diagnostics strings, read back by the report
through the same type (ins_gps_kf.status.FilterStatus), so a key cannot be spelled two ways."""
import dataclasses
import functools
import math

import numpy as np

from ins_gps_kf import config
from ins_gps_kf.filter import NAVIGATING, InsGpsFilter
from ins_gps_kf.intake import StampOrderIntake
from ins_gps_kf.status import FilterStatus, StatusOnResume, filter_status, mark_stale
from ins_gps_kf import synthetic
from nav_bringup import report


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


T0 = 1.7e9  # bag-like stamps: the first ones must come back to 1 us


@functools.lru_cache
def _status(seconds=30.0, **params):
    cfg = config.from_params({"alignment_time_s": 10.0, **params})
    filt = InsGpsFilter(cfg)
    intake = StampOrderIntake(filt, 0.1, 1.0, cfg.imu_rate_hz)
    motion = synthetic.straight(still_s=15.0, accel_s=5.0, cruise_s=seconds - 20.0)
    imu = synthetic.add_imu_errors(synthetic.ideal_imu(motion, cfg.imu_rate_hz), np.random.default_rng(1),
                                   gyro_white=1e-4, accel_white=1e-3)
    gnss = synthetic.gnss(motion, cfg.imu_rate_hz, 1.0, np.random.default_rng(2))
    t = imu.t + T0
    k_fix = 0
    for k in range(len(t)):
        while k_fix < len(gnss) and gnss.t[k_fix] <= imu.t[k]:
            intake.add_fix(gnss.t[k_fix] + T0, gnss.lat[k_fix], gnss.lon[k_fix], gnss.h[k_fix], gnss.std_enu[k_fix], 0)
            k_fix += 1
        intake.add_imu(t[k], imu.gyro[k], imu.accel[k])
        if k % 32 == 0:
            intake.release()
    intake.flush()
    return filter_status(filt, intake, first_imu_t=float(t[0]), first_fix_t=float(t[0]), bad_imu_messages=2), filt


def test_the_status_round_trips_through_diagnostics_strings():
    _, _, filt, intake = _resumed_run(say_status=False)
    st = filter_status(filt, intake, first_imu_t=T0 + 0.1, first_fix_t=T0, bad_imu_messages=2)
    assert st.state == NAVIGATING and st.fixes > 30 and st.zupts > 0 and st.imu_received > 2000
    values = st.to_values()
    assert all(isinstance(v, str) for v in values.values())
    back = FilterStatus.from_values(values, st.level, st.message)
    for f in dataclasses.fields(FilterStatus):
        if f.name in ("last_nis", "gps_age_s", "align_roll_deg", "align_pitch_deg"):  # printed to 6 digits
            a, b = getattr(st, f.name), getattr(back, f.name)
            assert a is None and b is None or math.isclose(a, b, rel_tol=1e-5) or math.isnan(a) and math.isnan(b)
        else:
            assert _same(getattr(back, f.name), getattr(st, f.name)), f.name
    assert abs(back.first_imu_stamp_s - st.first_imu_stamp_s) < 1e-6  # 1.7e9 s to the microsecond
    assert back.input == filt.input  # every rejected-input counter, by the core's own field names


def test_the_report_reads_the_filter_node_s_status_through_the_type():
    st, _ = _status(30.0)
    diags = {"ins_gps_kf_node: ins_gps_kf": (1, st.message, st.to_values()), "wmra_node: wmra": (0, "ok", {})}
    parsed = report.filter_status(diags)
    assert parsed.imu_received == st.imu_received and parsed.late_dropped == st.late_dropped
    assert parsed.level == "WARN" and parsed.bad_imu_messages == 2
    assert report.filter_status({"wmra_node: wmra": (0, "ok", {})}) is None


def test_an_older_or_partial_status_still_parses_with_defaults():
    back = FilterStatus.from_values({"fixes": "7", "first_imu_stamp_s": "", "last_nis": "nan", "gps_age_s": "x"})
    assert back.fixes == 7 and back.first_imu_stamp_s is None and math.isnan(back.last_nis)
    assert back.gps_age_s == math.inf and back.input.gps_jumps == 0


def test_an_odometer_that_sends_nothing_is_said_and_its_counts_are_in_the_status():
    st, _ = _status(30.0, odometer_enabled=True)
    assert st.level == "WARN" and "odometer on but no wheel speed received" in st.message
    assert (st.wheel_speeds_received, st.odometer_updates, st.odometer_scale_pct) == (0, 0, 0.0)
    assert _status(30.0)[0].odometer_scale_pct is None  # off: no scale to report


@functools.lru_cache
def _resumed_run(say_status: bool):
    """A 36-s drive whose input stops at 30 s (a link cut) and comes back sample by sample with a fix at 31 s, as
    the node takes it (stamps from T0, s): (the IMU stamp and status of each status said at once, odometry epochs
    (t, position), the filter, its intake)."""
    cfg = config.from_params({"alignment_time_s": 10.0})
    filt = InsGpsFilter(cfg)
    said, epochs, newest = [], [], [0.0]
    watch = StatusOnResume()

    def on_run(estimates, t, gyro, accel):  # the node's _on_run, with its status on resume
        epochs.extend((e.t, e.position_n.copy()) for e in estimates)
        newest[0] = t
        if say_status and watch.due(filt.counters.fixes):
            said.append((t, mark_stale(filter_status(filt, intake), 0.0)))

    intake = StampOrderIntake(filt, 0.0, 1.0, cfg.imu_rate_hz, on_run=on_run)
    motion = synthetic.straight(still_s=15.0, accel_s=5.0, cruise_s=16.0)
    imu = synthetic.add_imu_errors(synthetic.ideal_imu(motion, cfg.imu_rate_hz), np.random.default_rng(1),
                                   gyro_white=1e-4, accel_white=1e-3)
    gnss = synthetic.gnss(motion, cfg.imu_rate_hz, 1.0, np.random.default_rng(2))
    k_fix = 0
    for k in range(len(imu.t)):
        if imu.t[k] > 30.0 and watch.fixes_before is None and not said:  # the input back after a stale spell
            assert filt.status == NAVIGATING
            watch.input_resumed(filt.counters.fixes)
        while k_fix < len(gnss) and gnss.t[k_fix] <= imu.t[k]:
            intake.add_fix(gnss.t[k_fix] + T0, gnss.lat[k_fix], gnss.lon[k_fix], gnss.h[k_fix], gnss.std_enu[k_fix], 0)
            k_fix += 1
        intake.add_imu(imu.t[k] + T0, imu.gyro[k], imu.accel[k])
        intake.release()
    return said, epochs, filt, intake


def test_the_first_fix_after_a_stale_spell_has_its_status_said_at_once_and_changes_no_estimate():
    said, epochs, filt, _ = _resumed_run(say_status=True)
    assert len(said) == 1  # once per spell: the periodic status keeps its rate otherwise
    t, st = said[0]
    assert T0 + 31.0 <= t <= T0 + 31.0 + 1.0 / filt.cfg.imu_rate_hz  # the IMU run after the fix at 31 s, not 1 s on
    assert (st.level, st.message, st.input_stale_s) == ("OK", "navigating", 0.0)
    assert st.fixes == 32  # the fixes at 0..30 s before it, and it
    _, quiet_epochs, _, _ = _resumed_run(say_status=False)
    assert len(epochs) == len(quiet_epochs) > 0
    assert all(a[0] == b[0] and np.array_equal(a[1], b[1]) for a, b in zip(epochs, quiet_epochs))
