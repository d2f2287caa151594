"""Stamp-ordered intake of the filter node: IMU samples and fixes in arrival order, the filter fed in stamp order.

No ROS here: the node hands over what its subscriptions took, this class decides the order,
what is too late, what is a restart, and what is counted. The rules (the offline replay's order):

* everything waits in a heap ordered by stamp (a fix before an IMU sample of equal stamp) until
  the newest IMU stamp is ``window_s`` past it. Only IMU stamps advance the release point: the
  denoised IMU comes later than the fixes, so a fix waits however far behind the IMU runs. Nothing
  is released by wall time, so a node that falls behind catches up with the same order;
* a fix goes where it arrived in the fix stream, by the rule the offline replay uses
  (:class:`ins_gps_kf.input_checks.FixArrivals`, fed in arrival order): at its stamp, except a stamp
  before the place of the fix before (time went back: ``fixes_stamped_back``), which goes one fix
  spacing after it; a fix found stamped ahead of the next one (``fixes_stamped_ahead``) stays where
  it is, and an outlier more than ``time_jump_s`` ahead does not hold up the ones after it. The
  filter gets the fix's own stamp there and judges it, as in the replay: a fix stamped back (by up to
  ``time_jump_s``) from the fix before comes after it, so the filter drops it (``fixes_out_of_order``)
  whenever it came; a GNSS clock that stepped back is found by the lag and its fixes re-stamped. No
  fix moves once placed, so the order never depends on what was processed when a fix came;
* a message whose place in the stamp order was already processed is dropped and counted
  (``late_imu``, ``late_fixes``) - the only drop there is;
* an IMU stamp more than ``time_jump_s`` before the last processed one is a restart (a bag
  looping): everything queued with the old stamps is run, then the filter is reset; what was
  queued for the new run (IMU samples older than the processed ones, fixes stamped nearer the new
  stamps than the old) is kept, the fixes placed anew as the new run's stream;
* an IMU clock stepping back by less than ``time_jump_s`` is re-stamped to go on
  (:class:`ins_gps_kf.input_checks.ImuClock`, as the offline replay does), not dropped as late for the rest of the run;
* a non-finite stamp is rejected and counted (it has no place in the order); what the samples
  carry is the filter's to judge;
* a wheel speed goes at its stamp, or after the latest wheel stamp before it when its stamp went back or is not
  finite (the offline replay's rule), so the filter judges it there (``odometer_out_of_order``,
  ``odometer_nonfinite``, and whenever it comes: a stamp not after the latest wheel stamp processed); at one
  stamp the fixes come first, then the wheel speeds, then the IMU sample; one with a newer stamp whose place was
  already processed is dropped as ``late_odometer``;
* consecutive IMU samples go to the filter as one chunk (the same numbers as one by one);
* after the input went stale (a link down: the node says when, :meth:`StampOrderIntake.hold_for_fixes`), if the
  fixes were keeping up with the IMU when it stopped, no IMU sample is released more than half a GNSS period past
  the fix stream's place until a deadline of the caller's steady clock: the IMU and fix backlogs of a cut come from
  two writers, repaired apart and in pieces, and a fix of the cut arriving after the IMU past it ran would be
  dropped as late. The hold moves with the fixes (no other wait), so the filter's numbers are the replay's whatever
  the order and the pieces the two backlogs come in, as long as the fixes' backlog comes before the deadline; a
  fix coming after it is dropped and counted (``late_fixes``: then, and only then, live differs from the replay).
  Only this deadline is wall time: a GNSS outage and a fix backlog still on its way look the same in stamps.
"""
from __future__ import annotations

import dataclasses
import heapq
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ins_gps_kf.input_checks import FixArrivals, ImuClock, InputCounters

GPS, ODOMETER, IMU = 0, 1, 2  # at one stamp: fixes, then wheel speeds, then the IMU sample (as in the replay)
RESUME_WAIT_S = 5.0
"""s of the steady clock after input comes back from a stale spell (a link down) during which no IMU sample is run
more than half a GNSS period past the fixes (:meth:`StampOrderIntake.hold_for_fixes`): the two
backlogs come from two writers repaired apart and in pieces, and a fix arriving after the IMU samples past its stamp
ran would be dropped as late (docs/two_hosts.md). Was a 1-s wait that ended as soon as one piece of the IMU backlog
left the fixes under 1.5 periods behind: on a busy CPU the README's two-host drive dropped 6 fixes of its cut that
came 0.2 s after the IMU's first piece (live - offline 5.6 m; 1.95 m once in three CI runs). Costs latency only when
the GNSS stopped during the cut (the IMU then waits this long for fixes that do not come)."""


@dataclass
class IntakeCounters:
    """What the intake saw and did (reported in the node's /diagnostics)."""

    imu_samples: int = 0       # IMU samples handed in
    fixes: int = 0             # fixes handed in
    late_imu: int = 0          # IMU samples older than the last processed message: dropped
    late_fixes: int = 0        # fixes older than the last processed message (or an IMU sample of their stamp)
    bad_stamps: int = 0        # non-finite stamps: rejected
    restarts: int = 0          # backward time jumps that reset the filter
    fixes_stamped_back: int = 0   # fixes stamped before the fix before: placed where they arrived
    fixes_stamped_ahead: int = 0  # fixes found stamped ahead of the fix after them (see FixArrivals)
    imu_missing: int = 0       # IMU samples missing in forward gaps of the released stream (estimate)
    wheel_speeds: int = 0      # wheel speeds handed in
    late_odometer: int = 0     # wheel speeds older than the last processed message: dropped
    last_restart: str = ""
    reasons: list = field(default_factory=list)

    @property
    def dropped(self) -> int:
        """Messages the intake dropped (late or unstamped)."""
        return self.late_imu + self.late_fixes + self.late_odometer + self.bad_stamps


class StampOrderIntake:
    """Reorder heap in front of an :class:`~ins_gps_kf.filter.InsGpsFilter` (or anything with its three calls).

    ``on_run(estimates, t_s, gyro, accel)`` is called after every chunk of IMU samples ran
    through the filter, with the epoch estimates it produced and the chunk's newest sample.
    """

    def __init__(self, filt, window_s: float, time_jump_s: float, imu_rate_hz: float, on_run=None,
                 gps_rate_hz: float = 1.0):
        self.filter = filt
        self.gnss_period_s = 1.0 / float(gps_rate_hz)
        self.hold_until: float | None = None  # caller's steady s: the IMU waits for the fixes until then (a cut)
        self.window_s = float(window_s)
        self.time_jump_s = float(time_jump_s)
        self.imu_period_s = 1.0 / float(imu_rate_hz)
        self.on_run = on_run or (lambda *args: None)
        self.counters = IntakeCounters()
        self._heap: list = []
        self._seq = itertools.count()
        self.newest_t = -math.inf   # newest IMU stamp handed in since the last restart, s
        self.last_t: float | None = None  # newest IMU stamp released to the filter, s
        self._done = (-math.inf, GPS)  # (stamp, kind) of the last message released: the order's front
        self.fix_places = FixArrivals(time_jump_s)
        self.wheel_place = -math.inf  # the latest finite wheel-speed stamp handed in since the last restart, s
        self.wheel_done = -math.inf   # the latest finite wheel-speed stamp released to the filter, s
        # an IMU clock stepping back by less than time_jump_s is re-stamped here, before the stamp order
        self.imu_clock = ImuClock(time_jump_s, getattr(filt, "input", None) or InputCounters())

    @property
    def pending(self) -> int:
        """Messages waiting in the heap."""
        return len(self._heap)

    def add_imu(self, t_s: float, gyro, accel) -> None:
        """Queue one IMU sample: stamp s, rate (3,) rad/s, specific force (3,) m/s^2."""
        self.counters.imu_samples += 1
        if not math.isfinite(t_s):
            self.counters.bad_stamps += 1
            return
        t_s = self.imu_clock.one(t_s)
        if self.last_t is not None and t_s < self.last_t - self.time_jump_s:
            self._restart(f"stamp jumped back {self.last_t - t_s:.3f} s (bag restart?)", t_s)
        heapq.heappush(self._heap, (t_s, IMU, next(self._seq), (gyro, accel)))
        self.newest_t = max(self.newest_t, t_s)

    def add_fix(self, t_s: float, lat_rad: float, lon_rad: float, h_m: float, std_enu, status: int = 0) -> None:
        """Queue one fix (s, rad, rad, m, std ENU (3,) m, NavSatStatus); its contents are the filter's to judge."""
        self.counters.fixes += 1
        place, ahead = self.fix_places.place_of(t_s)  # the replay gives the filter the same order
        if not math.isfinite(t_s):
            self.counters.bad_stamps += 1
            return
        self.counters.fixes_stamped_ahead += ahead
        self.counters.fixes_stamped_back += place != t_s
        heapq.heappush(self._heap, (place, GPS, next(self._seq), (t_s, lat_rad, lon_rad, h_m, std_enu, status)))

    def add_odometry(self, t_s: float, speed_mps: float) -> None:
        """Queue one wheel speed (stamp s, forward m/s) at its place (see the module doc); the filter judges it."""
        self.counters.wheel_speeds += 1
        if math.isfinite(t_s):
            self.wheel_place = max(self.wheel_place, t_s)
        heapq.heappush(self._heap, (self.wheel_place, ODOMETER, next(self._seq), (t_s, speed_mps)))

    @property
    def fixes_current(self) -> bool:
        """Whether the fix stream keeps up with the IMU handed in (its place within 1.5 GNSS periods of the newest
        IMU stamp, or ahead); False before any fix."""
        return self.fix_places.place >= self.newest_t - 1.5 * self.gnss_period_s

    def hold_for_fixes(self, until_s: float) -> bool:
        """The input came back after a stale spell: if the fixes were keeping up when it stopped, release no IMU
        sample more than half a GNSS period past the fix stream's place until ``until_s`` (the caller's steady
        clock, s; see the module doc). Call before handing in what came back; returns whether it holds."""
        self.hold_until = until_s if self.fixes_current else None
        return self.hold_until is not None

    def release(self, now_s: float = -math.inf) -> None:
        """Run everything ``window_s`` older than the newest IMU stamp through the filter, in stamp order; while a
        hold is on (before its deadline, ``now_s`` on the caller's steady clock), nothing more than half a GNSS
        period past the fix stream's place."""
        until = self.newest_t - self.window_s
        if self.hold_until is not None and now_s >= self.hold_until:
            self.hold_until = None
        if self.hold_until is not None:
            until = min(until, self.fix_places.place + 0.5 * self.gnss_period_s)
        self._drain(until)

    def flush(self) -> None:
        """Run everything still queued (shutdown)."""
        self._drain(math.inf)

    def _restart(self, reason: str, t_new: float) -> None:
        """Run the old stamps' tail, reset the filter, keep what belongs to the new stamps (from ``t_new`` s)."""
        new_run = [item for item in self._heap if self._new_run(item, t_new)]
        self._heap = [item for item in self._heap if not self._new_run(item, t_new)]
        heapq.heapify(self._heap)
        self.flush()
        self.filter.reset(reason)
        self.hold_until = None  # the old run's fixes are not coming
        self._heap = [item for item in new_run if item[1] == IMU]
        self.newest_t = max((item[0] for item in self._heap), default=-math.inf)
        self.last_t, self._done = None, (-math.inf, GPS)
        self.fix_places.restart()
        self.wheel_place = self.wheel_done = -math.inf
        for _, kind, seq, payload in sorted((item for item in new_run if item[1] != IMU), key=lambda item: item[2]):
            if kind == GPS:  # the new run's stream
                self._heap.append((self.fix_places.place_of(payload[0])[0], GPS, seq, payload))
            else:
                self.wheel_place = max(self.wheel_place, payload[0]) if math.isfinite(payload[0]) else self.wheel_place
                self._heap.append((self.wheel_place, ODOMETER, seq, payload))
        heapq.heapify(self._heap)
        self.counters.restarts += 1
        self.counters.last_restart = reason
        self.counters.reasons.append(reason)

    def _new_run(self, item, t_new: float) -> bool:
        """Whether a queued message belongs to the run restarting at ``t_new`` s: an IMU sample older than what was
        processed (it would be late), a fix or wheel speed whose stamp is nearer ``t_new`` than the processed stamps."""
        if item[1] == IMU:
            return item[:2] < self._done
        return abs(item[3][0] - t_new) < abs(item[3][0] - self._done[0])

    def _drain(self, until_t: float) -> None:
        run = []
        while self._heap and self._heap[0][0] <= until_t:
            t, kind, _, payload = heapq.heappop(self._heap)
            if (t, kind) < self._done:  # its place in the stamp order was processed already
                if kind == GPS:
                    self.counters.late_fixes += 1
                elif kind == ODOMETER and not self._judged_anyway(payload[0]):
                    self.counters.late_odometer += 1
                elif kind == ODOMETER:  # dropped by the filter wherever it goes: counted under its own name
                    self.filter.process_odometry(*payload)
                else:
                    self.counters.late_imu += 1
                continue
            self._done = (t, kind)
            if kind == GPS:
                self._run_imu(run)
                run = []
                self.filter.process_gps(*payload)  # its own stamp: the filter judges a stamp out of place
                continue
            if kind == ODOMETER:
                self._run_imu(run)
                run = []
                self.filter.process_odometry(*payload)
                self.wheel_done = max(self.wheel_done, payload[0]) if math.isfinite(payload[0]) else self.wheel_done
                continue
            if self.last_t is not None and t - self.last_t > 1.5 * self.imu_period_s:
                self.counters.imu_missing += int(round((t - self.last_t) / self.imu_period_s)) - 1
            self.last_t = t
            run.append((t, payload))
        self._run_imu(run)

    def _judged_anyway(self, t_s: float) -> bool:
        """Whether a wheel speed stamped ``t_s`` s is one the filter drops wherever it goes (a stamp not finite, or
        not after the latest wheel stamp released): it is handed over however late, so it is counted as the
        replay counts it."""
        return not math.isfinite(t_s) or t_s <= self.wheel_done

    def _run_imu(self, run) -> None:
        if not run:
            return
        t = np.fromiter((s for s, _ in run), float, len(run))
        gyro = np.array([p[0] for _, p in run], dtype=float)
        accel = np.array([p[1] for _, p in run], dtype=float)
        estimates = self.filter.process_imu(t, gyro, accel)
        self.on_run(estimates, float(t[-1]), gyro[-1], accel[-1])


def warm_up(cfg, model=None):
    """Run a throwaway filter (``cfg``, ``model``) through alignment, heading and GPS updates on 20 s of a
    synthetic drive, so every numba kernel is compiled (or loaded from its cache) before real input comes.

    A fresh install compiles the covariance kernels at the first epoch after alignment: tens of
    seconds on a busy 2-core machine, during which a node would take no input. Returns the filter.
    """
    from ins_gps_kf import synthetic
    from ins_gps_kf.filter import InsGpsFilter

    rate = cfg.imu_rate_hz
    cfg = dataclasses.replace(cfg, alignment_time_s=3.0, min_alignment_time_s=1.0, datum=None,
                              alignment_mode="stationary")
    motion = synthetic.straight(still_s=4.0, accel_s=6.0, cruise_s=10.0, accel=1.0)
    imu = synthetic.ideal_imu(motion, rate, oversample=2)
    gnss = synthetic.gnss(motion, rate, 0.5, np.random.default_rng(0))
    filt = InsGpsFilter(cfg, model)
    intake = StampOrderIntake(filt, 0.0, cfg.time_jump, rate)
    for k in np.argsort(np.concatenate([gnss.t, imu.t]), kind="stable"):
        if k < len(gnss):
            intake.add_fix(gnss.t[k], gnss.lat[k], gnss.lon[k], gnss.h[k], gnss.std_enu[k], 0)
        else:
            i = k - len(gnss)
            intake.add_imu(imu.t[i], imu.gyro[i], imu.accel[i])
    intake.flush()
    return filt
