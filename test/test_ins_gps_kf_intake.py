"""The filter node's stamp-ordered intake, without ROS: order, late drops, restarts, catching up."""
import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from ins_gps_kf import config as kfconfig
from ins_gps_kf import input_checks
from ins_gps_kf import synthetic as syn
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.intake import RESUME_WAIT_S, StampOrderIntake
from ins_gps_kf.status import INPUT_STALE_S
from ins_gps_kf.replay import run

RATE = 32.0


class Recorder:
    """Stands in for the filter: keeps the calls in the order they came."""

    def __init__(self):
        self.calls = []

    def process_imu(self, t, gyro, accel):
        self.calls += [("imu", float(s)) for s in t]
        return []

    def process_gps(self, t, *payload):
        self.calls.append(("gps", float(t)))

    def reset(self, reason):
        self.calls.append(("reset", reason))


def _intake(window_s=0.1, time_jump_s=1.0):
    rec = Recorder()
    return rec, StampOrderIntake(rec, window_s, time_jump_s, RATE)


def _imu(intake, t):
    intake.add_imu(t, np.zeros(3), np.zeros(3))


def _fix(intake, t):
    intake.add_fix(t, 0.1, 0.2, 3.0, np.ones(3), 0)


def test_out_of_order_messages_within_the_window_reach_the_filter_in_stamp_order():
    rec, intake = _intake()
    for t in (0.0, 2 / RATE, 1 / RATE, 3 / RATE):
        _imu(intake, t)
    _fix(intake, 1 / RATE)  # same stamp as an IMU sample: the fix goes first
    for k in range(4, 12):
        _imu(intake, k / RATE)
    intake.release()
    stamps = [t for _, t in rec.calls]
    assert stamps == sorted(stamps)
    assert rec.calls.index(("gps", 1 / RATE)) < rec.calls.index(("imu", 1 / RATE))
    assert intake.counters.dropped == 0


def test_a_fix_waits_for_the_imu_however_far_behind_it_runs():
    rec, intake = _intake()
    for k in range(10):
        _fix(intake, float(k))  # ten seconds of fixes first: the denoised IMU is late
    intake.release()
    assert rec.calls == []
    for k in range(int(12 * RATE)):
        _imu(intake, k / RATE)
    intake.release()
    assert [c for c in rec.calls if c[0] == "gps"] == [("gps", float(k)) for k in range(10)]
    assert intake.counters.late_fixes == 0


def test_messages_behind_what_was_processed_are_dropped_and_counted():
    rec, intake = _intake()
    for k in range(20):
        _imu(intake, k / RATE)
    intake.release()
    processed = len(rec.calls)
    _imu(intake, 1 / RATE)  # long gone
    _fix(intake, 2 / RATE)
    intake.release()
    assert len(rec.calls) == processed
    assert (intake.counters.late_imu, intake.counters.late_fixes, intake.counters.dropped) == (1, 1, 2)


def test_a_stamp_jumping_back_resets_the_filter_after_running_all_that_came_before():
    rec, intake = _intake()
    for k in range(64):
        _imu(intake, 10.0 + k / RATE)
        if k == 16:
            _fix(intake, 10.5)
    intake.release()
    _fix(intake, 3.5)  # the restarted bag's first fix comes before its (denoised, later) IMU: stamped back
    _fix(intake, 4.5)
    _imu(intake, 3.0)  # the bag restarts
    assert rec.calls[-1][0] == "reset"
    before = [t for kind, t in rec.calls[:-1] if kind == "imu"]
    assert before == [10.0 + k / RATE for k in range(64)]  # all of the old stamps, the window's worth too
    assert intake.counters.restarts == 1 and "jumped back" in intake.counters.last_restart
    for k in range(1, 20):
        _imu(intake, 3.0 + k / RATE)
    intake.flush()
    reset_at = [kind for kind, _ in rec.calls].index("reset")
    after = [t for kind, t in rec.calls[reset_at + 1:] if kind == "imu"]
    assert after == sorted(after) and after[0] == 3.0 and len(after) == 20
    assert [c for c in rec.calls[reset_at:] if c[0] == "gps"] == [("gps", 3.5), ("gps", 4.5)]  # kept for the new run
    new_run = [t for _, t in rec.calls[reset_at + 1:]]
    assert new_run == sorted(new_run)  # in their place among the new run's IMU samples
    assert intake.counters.late_imu == 0


def test_a_fix_stamped_a_little_back_when_the_bag_restarts_stays_with_the_old_run():
    rec, intake = _intake()
    for k in range(int(12 * RATE)):
        _imu(intake, k / RATE)
        if k % int(RATE) == 0:
            _fix(intake, k / RATE)
    intake.release()
    _fix(intake, 10.6)  # received at 12 s, stamped 0.4 s before the fix before: queued where it arrived
    _fix(intake, 2.5)  # the restarted bag's first fix
    _imu(intake, 2.0)  # the bag restarts
    reset_at = [kind for kind, _ in rec.calls].index("reset")
    assert ("gps", 10.6) in rec.calls[:reset_at]  # run before the reset (the filter drops it as out of order)
    for k in range(1, 40):
        _imu(intake, 2.0 + k / RATE)
    intake.flush()
    assert [c for c in rec.calls[reset_at:] if c[0] == "gps"] == [("gps", 2.5)]  # the new run's, in its place
    new_run = [t for _, t in rec.calls[reset_at + 1:]]
    assert new_run == sorted(new_run)
    assert intake.counters.dropped == 0 and intake.counters.fixes_stamped_back == 2


def test_a_non_finite_stamp_is_rejected_and_counted():
    rec, intake = _intake()
    _imu(intake, math.nan)
    intake.add_fix(math.inf, 0.1, 0.2, 3.0, np.ones(3), 0)
    for k in range(10):
        _imu(intake, k / RATE)
    intake.flush()
    assert [kind for kind, _ in rec.calls] == ["imu"] * 10
    assert intake.counters.bad_stamps == 2


def test_missing_imu_samples_are_counted_from_the_stamp_gaps():
    rec, intake = _intake()
    for k in [*range(10), *range(15, 20)]:
        _imu(intake, k / RATE)
    intake.flush()
    assert intake.counters.imu_missing == 5  # stamps 10..14


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["imu", "gps"]), st.integers(0, 400)), min_size=1, max_size=120),
       st.integers(0, 1000))
def test_whatever_the_arrival_order_the_filter_sees_nondecreasing_stamps(messages, seed):
    rec, intake = _intake(window_s=0.25)
    rng = np.random.default_rng(seed)
    for kind, k in messages:
        t = k / RATE
        _imu(intake, t) if kind == "imu" else _fix(intake, t)
        if rng.random() < 0.3:
            intake.release()
    intake.flush()
    runs, stamps = [[]], []
    for kind, t in rec.calls:
        if kind == "reset":
            runs.append([])
        else:
            runs[-1].append((kind, t))
            stamps.append(t)
    # between restarts (stamp jumps back > 1 s) the IMU stamps never go back, and a fix comes between the
    # IMU samples of its stamp unless the intake counted it as stamped back or ahead (it goes where it arrived)
    out_of_place = 0
    for run in runs:
        imu = [t for kind, t in run if kind == "imu"]
        assert imu == sorted(imu)
        for k, (kind, t) in enumerate(run):
            before = [s for knd, s in run[:k] if knd == "imu"][-1:] or [-math.inf]
            after = [s for knd, s in run[k + 1:] if knd == "imu"][:1] or [math.inf]
            out_of_place += kind == "gps" and not before[0] <= t <= after[0]
    c = intake.counters
    assert out_of_place <= c.fixes_stamped_back + c.fixes_stamped_ahead
    assert len(runs) - 1 == c.restarts
    # every message handed in was either processed or counted as dropped: nothing vanishes silently
    assert len(stamps) + c.dropped == len(messages)


def _places(stamps, stale_s=1.0):
    """The one arrival rule over a fix stream: (places s, whether each fix found the one before stamped ahead)."""
    arrivals = input_checks.FixArrivals(stale_s)
    out = [arrivals.place_of(float(t)) for t in stamps]
    return np.array([p for p, _ in out], dtype=float), np.array([a for _, a in out], dtype=bool)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([-2.5, -7.0, -100.0]), st.integers(1, 12)), max_size=6),
       st.integers(2, 12), st.sampled_from([0.2, 1.0, 5.0]))
def test_a_receiver_whose_clock_steps_back_has_each_fix_placed_where_it_arrived(steps, n0, period_s):
    # a receiver keeping its rate (period_s, known after two fixes), received at 100 s + k periods; its clock steps
    # back now and then
    offsets = [0.0] * n0
    for step, n in steps:
        offsets += [offsets[-1] + step * period_s] * n
    received = 100.0 + period_s * np.arange(len(offsets))
    places, ahead = _places(received + np.array(offsets))
    np.testing.assert_allclose(places, received, rtol=0, atol=1e-9)
    assert not ahead.any()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.integers(-3, 3).map(lambda k: k * 0.25), st.sampled_from([-100.0, 30.0, np.nan])),
                max_size=40))
def test_a_fix_stamped_a_little_back_reaches_the_filter_after_a_fix_stamped_later(moves):
    # a 1-Hz stream, each fix moved by some quarter seconds, some far ahead or behind, some unstamped
    stamps = np.arange(len(moves), dtype=float) + np.array(moves, dtype=float)
    places, _ = _places(stamps)
    order = sorted(range(len(stamps)), key=lambda k: (places[k], k))  # the intake's heap (and the replay's) order
    rank = {k: r for r, k in enumerate(order)}
    finite = np.isfinite(stamps)
    assert np.all(places[finite] >= stamps[finite])  # never handed over before its stamp
    last = None  # the last stamped fix received before this one
    for k in np.flatnonzero(finite):
        if last is not None and stamps[last] - 1.0 <= stamps[k] < stamps[last]:  # back, by up to stale_s
            # the filter gets a fix stamped later first, so it drops this one (fixes_out_of_order), whenever it came
            assert any(stamps[j] > stamps[k] and rank[j] < rank[k] for j in range(k)), (k, stamps, places)
        last = k
    if np.all(np.diff(stamps[finite]) >= 0):
        assert np.array_equal(places[finite], stamps[finite])  # fixes in time order go at their stamps


def test_an_outlier_stamped_far_ahead_stays_at_its_stamp_and_holds_up_no_other_fix():
    stamps = np.arange(10.0)
    stamps[4] += 30.0
    places, ahead = _places(stamps)
    np.testing.assert_array_equal(places, stamps)  # the filter judges the outlier when its stamp comes
    assert ahead.tolist() == [k == 5 for k in range(10)]


def test_a_fix_stamped_a_little_ahead_delays_no_fix_after_it():
    stamps = np.arange(10.0)
    stamps[4] += 1.5  # 0.5 s after the next fix: that one is placed after it (the filter drops it), the rest in line
    places, ahead = _places(stamps)
    assert places[5] > places[4] and ahead[5]
    np.testing.assert_array_equal(np.delete(places, 5), np.delete(stamps, 5))


def test_a_fix_stamped_back_goes_where_it_arrived_and_the_filter_gets_its_stamp():
    rec, intake = _intake()
    for k in range(3):
        _fix(intake, 10.0 + k)
    _fix(intake, 13.0 - 100.0)  # the GNSS clock steps back 100 s: received at 13 s
    _fix(intake, 14.0 - 100.0)
    for k in range(int(16 * RATE)):
        _imu(intake, k / RATE)
    intake.flush()
    gps = [(k, t) for k, (kind, t) in enumerate(rec.calls) if kind == "gps"]
    assert [t for _, t in gps] == [10.0, 11.0, 12.0, -87.0, -86.0]  # the filter judges the stamps
    assert [rec.calls[k - 1][1] for k, _ in gps] == [10 - 1 / RATE, 11 - 1 / RATE, 12 - 1 / RATE,
                                                     13 - 1 / RATE, 14 - 1 / RATE]  # each where it arrived
    assert intake.counters.fixes_stamped_back == 2 and intake.counters.dropped == 0


def _drive():
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=20.0)
    rng = np.random.default_rng(3)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.01, 1e-3, 1e-3)
    return imu, syn.gnss(motion, RATE, 1.0, rng)


def _filter():
    p = kfconfig.defaults()
    p.update(alignment_time_s=15.0, imu_rate_hz=RATE)
    return InsGpsFilter(kfconfig.from_params(p))


def _stamped(gnss, case):
    """The fixes of ``_drive`` as a receiver with trouble stamps them: (stamps s, when they arrive s) per fix."""
    received, stamps = gnss.t.copy(), gnss.t.copy()
    if case == "gnss_clock_stepping_back_100s":  # the receiver keeps its rate, its clock steps: they arrive as before
        stamps[received >= 35.0] -= 100.0
    elif case == "fixes_out_of_order":
        k = int(np.searchsorted(received, 40.0))
        stamps[k] = stamps[k - 1] - 0.6  # stamped 0.6 s (< time_jump_s) before the fix that came before it
        stamps[k - 20] += 10.5  # and one outlier stamped 10.5 s ahead, 20 fixes before
    return stamps, received


@pytest.mark.parametrize("case", ["clean", "gnss_clock_stepping_back_100s", "fixes_out_of_order"])
@pytest.mark.parametrize("batch_s, imu_lag_s", [(0.01, 0.0), (0.5, 1.5), (12.0, 0.8)],
                         ids=["every_sample", "imu_behind_the_fixes", "catching_up_after_a_12s_stall"])
def test_the_intake_gives_the_offline_replay_numbers_however_the_input_is_batched(batch_s, imu_lag_s, case):
    imu, gnss = _drive()
    gnss.t, received = _stamped(gnss, case)  # the recording keeps the fixes in the order they came
    offline_filter = _filter()
    offline = run(offline_filter, imu, gnss)
    live = []
    intake = StampOrderIntake(_filter(), 0.1, 1.0, RATE, on_run=lambda est, *_: live.extend(est))
    # arrival order: fixes when received, the IMU imu_lag_s after its stamp; taken every batch_s
    arrivals = sorted([(t, 0, i) for i, t in enumerate(received)] + [(t + imu_lag_s, 1, i) for i, t in enumerate(imu.t)])
    edge = batch_s
    for when, kind, i in arrivals:
        if when > edge:
            intake.release()
            edge = (when // batch_s + 1) * batch_s
        if kind:
            intake.add_imu(imu.t[i], imu.gyro[i], imu.accel[i])
        else:
            intake.add_fix(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i], gnss.status[i])
    intake.flush()
    assert len(live) == len(offline) > 40
    for a, b in zip(live, offline):
        assert a.t == b.t
        np.testing.assert_array_equal(a.position_n, b.position_n)
    assert intake.counters.dropped == 0 and intake.counters.imu_missing == 0
    assert intake.filter.input_counters == offline_filter.input_counters
    counts, c = intake.filter.input_counters, intake.counters
    if case == "gnss_clock_stepping_back_100s":  # the step is found, and the fixes after it re-stamped and used
        assert c.fixes_stamped_back == np.sum(gnss.t < received) and counts["gnss_clock_steps"] == 1
        assert intake.filter.last_fix_t > received[-1] - 1.0
    elif case == "fixes_out_of_order":  # the one stamped back comes after the one before: the filter drops it
        assert (c.fixes_stamped_back, c.fixes_stamped_ahead, counts["fixes_out_of_order"]) == (1, 1, 1)
    else:
        assert (c.fixes_stamped_back, c.fixes_stamped_ahead, counts["fixes_out_of_order"]) == (0, 0, 0)


def test_an_imu_clock_stepping_back_less_than_time_jump_is_restamped_in_the_intake_as_in_the_replay():
    imu, gnss = _drive()
    stepped = imu.t.copy()
    stepped[imu.t >= 35.0] -= 0.98  # the IMU clock steps back 0.98 s (time_jump_s 1 s): no restart
    results = []
    for t in (imu.t, stepped):
        live = []
        intake = StampOrderIntake(_filter(), 0.1, 1.0, RATE, on_run=lambda est, *_: live.extend(est))
        for k in np.argsort(np.concatenate([gnss.t, imu.t]), kind="stable"):  # arrival order: as recorded
            if k < len(gnss):
                intake.add_fix(gnss.t[k], gnss.lat[k], gnss.lon[k], gnss.h[k], gnss.std_enu[k], gnss.status[k])
            else:
                intake.add_imu(t[k - len(gnss)], imu.gyro[k - len(gnss)], imu.accel[k - len(gnss)])
            intake.release()
        intake.flush()
        results.append((intake, {e.t: e.position_n for e in live}))
    (_, clean), (intake, live) = results
    assert intake.filter.input_counters["imu_clock_steps"] == 1 and intake.counters.restarts == 0
    assert intake.counters.late_imu <= 2  # the samples that showed the step; was: 0.98 s of samples, then late stamps
    err = [np.linalg.norm(live[t] - clean[t]) for t in clean if t in live and t > 36.0]
    assert len(err) > 0.9 * sum(t > 36.0 for t in clean) and max(err) < 1.0


def test_warm_up_runs_the_filter_through_alignment_heading_and_gps_updates():
    from ins_gps_kf.filter import NAVIGATING
    from ins_gps_kf.intake import warm_up

    p = kfconfig.defaults()
    p["estimate_scale_factors"] = True  # the 21-state kernels too
    filt = warm_up(kfconfig.from_params(p))
    assert filt.status == NAVIGATING
    assert filt.counters.epochs > 10 and filt.counters.fixes > 10 and filt.last_fix_t > 15.0


CUT = (38.0, 46.0)  # s: the link down (wall = stamps at 1x), in the drive's turn


def _after_a_cut(imu, gnss, fixes_after_s, imu_first_piece_s=0.5, imu_piece_every_s=0.1, fix_lag_s=0.02,
                 imu_lag_s=0.3):
    """When each message reaches the filter node (s of its steady clock) across a link cut (``CUT``): fixes
    ``fix_lag_s`` after their stamp, the denoised IMU ``imu_lag_s`` after; what would have come in the cut comes
    after it: the IMU backlog in pieces (the first ``imu_first_piece_s`` of stamps at once, then a second of stamps
    every ``imu_piece_every_s``), the fixes' ``fixes_after_s`` after the link's return (None: the GNSS stopped in
    the cut, its fixes never come); each stream in order (reliable). Returns sorted (arrival s, kind 0 fix / 1 IMU,
    index)."""
    down, up = CUT
    out, last = [], -math.inf
    for i, t in enumerate(gnss.t):
        when = t + fix_lag_s
        if down <= when < up and fixes_after_s is None:
            continue
        last = max(last, up + fixes_after_s if down <= when < up else when)
        out.append((last, 0, i))
    first, last = None, -math.inf
    for i, t in enumerate(imu.t):
        when = t + imu_lag_s
        if down <= when < up:
            first = t if first is None else first
            piece = 0 if t < first + imu_first_piece_s else 1 + int((t - first - imu_first_piece_s) // 1.0)
            when = up + 0.05 + piece * imu_piece_every_s
        last = max(last, when)
        out.append((last, 1, i))
    return sorted(out)


def _node_loop(imu, gnss, arrivals, period_s=0.01):
    """The filter node's intake loop (:meth:`InsGpsKfNode.take_input`) on a simulated steady clock: every
    ``period_s`` what arrived is handed in (after a stale spell the intake is told to hold for the fixes), then
    released. Returns the epoch estimates published and the intake."""
    live = []
    intake = StampOrderIntake(_filter(), 0.1, 1.0, RATE, on_run=lambda est, *_: live.extend(est), gps_rate_hz=1.0)
    last, k = None, 0
    for now in np.arange(0.0, arrivals[-1][0] + RESUME_WAIT_S + 1.0, period_s):
        taken = []
        while k < len(arrivals) and arrivals[k][0] <= now:
            taken.append(arrivals[k])
            k += 1
        if taken:
            if last is not None and now - last > INPUT_STALE_S:
                intake.hold_for_fixes(now + RESUME_WAIT_S)
            last = now
        for _, kind, i in taken:
            if kind:
                intake.add_imu(imu.t[i], imu.gyro[i], imu.accel[i])
            else:
                intake.add_fix(gnss.t[i], gnss.lat[i], gnss.lon[i], gnss.h[i], gnss.std_enu[i], gnss.status[i])
        intake.release(now)
    intake.flush()
    return live, intake


@functools.lru_cache(maxsize=2)
def _cut_drive(gnss_stops: bool):
    """``_drive``'s IMU and fixes (none from the cut to 52 s when the GNSS stops in it) and their offline replay."""
    imu, gnss = _drive()
    if gnss_stops:  # the receiver lost the sky in the cut: the recording has no fix there either
        gnss = gnss.select((gnss.t < CUT[0] - 0.02) | (gnss.t >= 52.0))
    return imu, gnss, run(_filter(), imu, gnss)


@pytest.mark.parametrize("fixes_after_s, first_piece_s", [(0.0, 8.0), (0.2, 0.5), (1.8, 0.5), (None, 0.5)],
                         ids=["fixes_first", "fixes_after_a_first_imu_piece", "fixes_1_8s_after_the_imu_in_pieces",
                              "gnss_stopped_in_the_cut"])
def test_after_a_link_cut_the_filter_gives_the_replay_numbers_whichever_backlog_comes_first(fixes_after_s,
                                                                                          first_piece_s):
    # the README's two-host drive failed once in three CI runs, live - offline 1.95 m: fixes of the cut dropped as
    # late, the IMU backlog run past them. The node's 1-s wait, ended by the first IMU piece that left the fixes
    # under 1.5 periods behind or by the clock, dropped 2 fixes in the second case and 10 in the third
    imu, gnss, offline = _cut_drive(fixes_after_s is None)
    live, intake = _node_loop(imu, gnss, _after_a_cut(imu, gnss, fixes_after_s, first_piece_s))
    assert intake.counters.dropped == 0 and intake.counters.imu_missing == 0
    assert len(live) == len(offline) > 40
    for a, b in zip(live, offline):
        assert a.t == b.t
        np.testing.assert_array_equal(a.position_n, b.position_n)


def test_a_fix_backlog_later_than_the_resume_wait_is_dropped_and_counted():
    # the one case live differs from the replay: a GNSS outage and fixes still on their way look the same in
    # stamps, so the IMU waits RESUME_WAIT_S of the steady clock, no longer
    imu, gnss, _ = _cut_drive(False)
    live, intake = _node_loop(imu, gnss, _after_a_cut(imu, gnss, RESUME_WAIT_S + 0.5))
    cut_fixes = int(np.sum((gnss.t + 0.02 >= CUT[0]) & (gnss.t + 0.02 < CUT[1])))
    late = intake.counters.late_fixes  # the cut's and the ones queued behind them (in order) that came too late
    assert cut_fixes == 8 and late >= cut_fixes and intake.counters.late_imu == 0
    assert intake.filter.counters.fixes == len(gnss) - late
