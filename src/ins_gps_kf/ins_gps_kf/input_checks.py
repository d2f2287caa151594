"""Plausibility of the filter's input: impossible IMU samples, bad fixes and stamps, GPS track jumps; the counts.

No ROS here. :class:`InputCounters` is what the filter exposes as ``InsGpsFilter.input_counters``
(a plain ``dict`` of ints, keys below, plus ``last_rejection``, a readable line): the node puts it
in ``/diagnostics``, the replay in its summary. Every rejected input is counted under one key:

* ``imu_nonfinite`` - an IMU sample with a NaN/Inf stamp, rate or specific force; dropped;
* ``imu_out_of_range`` - a |rate| or |specific force| component beyond ``imu_max_gyro_dps`` /
  ``imu_max_accel_mps2`` (the sensor cannot output it); dropped;
* ``imu_duplicate_stamps`` - a sample with the stamp of the one before; dropped;
* ``imu_out_of_order`` - a sample stamped before the one before by up to ``time_jump_s`` (rows swapped, a
  stamp jittered back); dropped, not a reset (the node's intake puts such a sample in its place, or drops it
  as late); a step back beyond ``time_jump_s`` is a restart, which resets the filter;
* ``fixes_invalid`` - NO_FIX status or a NaN/Inf stamp, latitude, longitude or height; dropped;
* ``fixes_out_of_range`` - latitude outside [-90, 90] deg or longitude outside [-180, 180] deg; dropped;
* ``fixes_std_unknown`` - a std <= 0 or not finite (a receiver or converter writing 0 for "unknown",
  NavSatFix COVARIANCE_TYPE_UNKNOWN): taken as unknown; the fix is used with the configured ``gps_std_m``,
  else with the std estimated from those fixes' innovations (:class:`UnknownFixStd`; 10 m until 10 have
  come); ``unknown_fix_std`` says the std in use (a text, like ``last_rejection``);
* ``fixes_duplicate`` - the same stamp and position as the fix before; dropped;
* ``fixes_conflicting`` - the same stamp as the fix before, another position: neither is used
  (the pending one is withdrawn when it was not fused yet);
* ``fixes_out_of_order`` - a stamp before the fix before (time going back), more than ``time_jump_s``
  before the IMU time, or more than ``max_bridged_gap_s + time_jump_s`` after it; dropped;
* ``gnss_clock_steps`` - the fix stamps' offset from the IMU clock changed: ``max_rejected_fixes``
  fixes in a row arrived more than ``time_jump_s`` behind the IMU time by the same amount (a GNSS
  clock stepped back; those fixes are dropped as out of order), so the later ones are re-stamped by
  it; or the stamps fit the IMU clock again and the offset goes back to zero;
* ``imu_clock_steps`` - the IMU clock stepped back by less than ``time_jump_s``: ``IMU_STEP_CONFIRM``
  samples in a row came stamped back from the latest at the IMU's rate (not a swapped pair, not a
  jitter), so the last of them and the later ones are re-stamped to go on from it (:class:`ImuClock`;
  the ones before are dropped as ``imu_out_of_order``); a step back beyond ``time_jump_s`` is a restart;
* ``gps_jumps`` - a fix whose track from the fix before needs a speed beyond ``max_speed_mps`` or an
  acceleration beyond ``max_accel_mps2`` (beyond the fixes' noise); the innovation gate decides
  whether it is used;
* ``gps_resets_refused`` - after ``max_rejected_fixes`` rejected fixes in a row, no reset to them
  because their track jumped away from the last accepted fix (a glitch: the INS is kept);
* ``alignment_not_gravity`` - a 1-s block fed to the stationary alignment whose mean |specific force| is
  outside [0.5 g, 2 g]: no IMU at rest reads that (an accelerometer in g reads 1.0), so it is not taken
  as rest and the alignment waits; ``last_rejection`` says what it read;
* ``state_resets`` - a non-finite navigation state or covariance, or an INS speed beyond twice
  ``max_speed_mps``: the filter resets and re-aligns (never publishes it);
* ``odometer_nonfinite``, ``odometer_duplicate``, ``odometer_out_of_order`` - a wheel speed (replay
  ``--odometry``) whose stamp or speed is NaN or infinite, repeats the previous stamp, or goes back: dropped;
* ``odometer_stuck`` - a wheel speed of exactly 0 while the INS says the vehicle moves faster than
  ``odometer_stuck_speed_mps``: a stuck wheel, not used.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

JUMP_CONFIRM_FACTOR = 4  # a track that jumped is taken (GPS reset) after this many times max_rejected_fixes fixes
NOISE_SIGMAS = 3.0  # speed/acceleration limits are exceeded only beyond this many sigmas of the fixes' noise


@dataclass
class InputCounters:
    """Counts of rejected or doubtful input (see the module doc for each key)."""

    imu_nonfinite: int = 0
    imu_out_of_range: int = 0
    imu_duplicate_stamps: int = 0
    imu_out_of_order: int = 0
    fixes_invalid: int = 0
    fixes_out_of_range: int = 0
    fixes_std_unknown: int = 0
    fixes_duplicate: int = 0
    fixes_conflicting: int = 0
    fixes_out_of_order: int = 0
    gnss_clock_steps: int = 0
    imu_clock_steps: int = 0
    gps_jumps: int = 0
    gps_resets_refused: int = 0
    state_resets: int = 0
    alignment_not_gravity: int = 0
    odometer_nonfinite: int = 0     # wheel speeds or stamps that are NaN or infinite
    odometer_duplicate: int = 0     # a wheel speed with the stamp of the previous one
    odometer_out_of_order: int = 0  # a wheel speed stamped before the previous one
    odometer_stuck: int = 0         # a wheel speed of 0 while the INS says the vehicle moves
    last_rejection: str = ""
    unknown_fix_std: str = ""

    def as_dict(self) -> dict:
        """Name -> count, and ``last_rejection``: what the node's diagnostics and the replay's JSON show."""
        return asdict(self)

    def counter(self, key: str):
        """A callable ``(text)`` that counts one event under ``key`` and makes ``text`` the ``last_rejection``."""
        def count(text: str) -> None:
            setattr(self, key, getattr(self, key) + 1)
            self.last_rejection = text
        return count

    def total(self) -> int:
        """Number of counted events (the int keys: not ``last_rejection`` nor ``unknown_fix_std``)."""
        return sum(v for v in asdict(self).values() if isinstance(v, int))


def screen_imu(t, gyro, accel, t_prev, max_gyro, max_accel, counters: InputCounters,
               time_jump: float = math.inf) -> np.ndarray | None:
    """Mask (n,) of the IMU samples to keep: finite, within the sensor range (rad/s, m/s^2), stamp after the
    latest kept one (a repeat, or a step back of up to ``time_jump`` s, is dropped; a longer step back is kept:
    a restart); None when all are kept (the common case, checked first in a few whole-array reductions).

    ``t_prev`` is the stamp of the last sample already processed (None at the start); counts go to
    ``counters`` and the last one is described in ``counters.last_rejection``.
    """
    with np.errstate(invalid="ignore"):  # NaN fails every comparison: it falls to the slow path
        if (len(t) and np.abs(gyro).max() <= max_gyro and np.abs(accel).max() <= max_accel
                and math.isfinite(t.sum()) and not (t_prev is not None and t[0] <= t_prev)
                and np.all(t[1:] > t[:-1])):
            return None
    finite = np.isfinite(t) & np.all(np.isfinite(gyro), axis=1) & np.all(np.isfinite(accel), axis=1)
    with np.errstate(invalid="ignore"):
        in_range = np.all(np.abs(gyro) <= max_gyro, axis=1) & np.all(np.abs(accel) <= max_accel, axis=1)
    keep = finite & in_range
    dup, back = _stamp_order(t, np.flatnonzero(keep), t_prev, time_jump)
    keep[dup] = False
    keep[back] = False
    n_bad, n_range = int(np.sum(~finite)), int(np.sum(finite & ~in_range))
    counters.imu_nonfinite += n_bad
    counters.imu_out_of_range += n_range
    counters.imu_duplicate_stamps += len(dup)
    counters.imu_out_of_order += len(back)
    if n_bad or n_range or len(dup) or len(back):
        k = int(np.flatnonzero(~keep)[-1])
        why = ("not finite" if not finite[k] else "beyond the sensor range" if not in_range[k]
               else "repeated stamp" if k in set(dup) else "stamped before the sample before")
        counters.last_rejection = f"IMU sample at t={t[k]:.3f} s dropped: {why}"
    return keep


def _stamp_order(t, idx, t_prev, time_jump):
    """Indices among ``idx`` whose stamp repeats the latest kept one, and those stamped back from it by up to
    ``time_jump`` s (a longer step back is a restart: kept, and the latest stamp starts again from it)."""
    stamps = t[idx]
    prev = np.concatenate(([np.nan if t_prev is None else t_prev], stamps[:-1]))
    if not np.any(stamps < prev):  # in order but for repeats: the vectorised common case
        return idx[stamps == prev], idx[:0]
    dup, back = [], []
    latest = -math.inf if t_prev is None else t_prev
    for i, ti in zip(idx, stamps):
        if ti == latest:
            dup.append(i)
        elif latest - time_jump <= ti < latest:
            back.append(i)
        else:
            latest = ti
    return np.array(dup, dtype=int), np.array(back, dtype=int)


def state_ok(nav, cov, velocity_n, t, max_speed, counters: InputCounters) -> bool:
    """Whether a state vector and covariance are finite and the velocity (m/s, ENU) no faster than ``max_speed``
    m/s horizontally; counted as ``state_resets`` if not (the filter then resets)."""
    speed = math.hypot(velocity_n[0], velocity_n[1])
    if math.isfinite(nav.sum() + cov.sum()) and speed <= max_speed:  # a sum is finite only if every term is
        return True
    counters.state_resets += 1
    counters.last_rejection = f"state at t={t:.3f} s not finite or too fast ({speed:.3g} m/s): reset"
    return False


def check_fix(t, lat_rad, lon_rad, h_m, status, last, t_imu, stale_s, future_s) -> str | None:
    """Why a fix (s, rad, rad, m, NavSatStatus) cannot be used, as an :class:`InputCounters` key; None if it can.

    ``last`` is the (t, lat, lon, h) of the previous usable fix or None; ``t_imu`` the IMU time (s) or
    None; a fix more than ``stale_s`` before it or ``future_s`` after it is out of order.
    """
    if status < 0 or not all(math.isfinite(float(v)) for v in (t, lat_rad, lon_rad, h_m)):
        return "fixes_invalid"
    if abs(lat_rad) > 0.5 * math.pi or abs(lon_rad) > math.pi:
        return "fixes_out_of_range"
    if last is not None and t == last[0]:
        return "fixes_duplicate" if (lat_rad, lon_rad, h_m) == tuple(last[1:]) else "fixes_conflicting"
    if (last is not None and t < last[0]) or (t_imu is not None and not -stale_s <= t - t_imu <= future_s):
        return "fixes_out_of_order"
    return None


def std_unknown(std_enu) -> bool:
    """Whether a fix's std (m, ENU) says nothing: a component <= 0 or not finite."""
    std = np.asarray(std_enu, dtype=float)
    return not (std.min() > 0.0 and std.max() < math.inf)  # NaN fails both


class UnknownFixStd:
    """The std (m, ENU) of fixes that carry none, estimated from their GPS innovations (covariance matching).

    An innovation ``nu = H x - z`` has the variance ``H P H' + R`` per axis. Over the last ``window``
    such fixes, ``R`` (horizontal: east and north pooled; vertical) is the value that makes the median
    of ``nu^2 / (H P H' + R)`` the median of a chi-square with one degree of freedom (0.4549): a median,
    so a glitch or a jump does not inflate it. Innovations whose predicted part ``H P H'`` exceeds the
    ``R`` in use say little about ``R`` (the filter's own uncertainty swamps it) and are left out. The
    std starts at ``start_m`` and falls by at most ``MAX_FALL`` per fix, so a filter not yet settled is
    not handed fixes it would then reject. ``counters.unknown_fix_std`` says which std is in use.
    """

    CHI2_1_MEDIAN = 0.4549364  # median of nu^2 / var for a Gaussian nu
    MAX_FALL = 0.7  # the std in use shrinks by at most this factor per fix

    def __init__(self, start_m: float, floor_m: float, counters: InputCounters, window: int = 60,
                 min_fixes: int = 10):
        self.start_m, self.floor_m, self.counters = float(start_m), max(float(floor_m), 1e-3), counters
        self.window, self.min_fixes = int(window), int(min_fixes)
        self.nu2 = np.empty((0, 3))  # squared innovations, m^2
        self.hph = np.empty((0, 3))  # the filter's predicted part of their variance, m^2
        self.std_enu = np.array([self.start_m] * 3)
        self.n_seen = 0

    def current(self) -> np.ndarray:
        """The std (3,) m, ENU, to give a fix without one now."""
        if not self.counters.unknown_fix_std:
            self.counters.unknown_fix_std = (f"{self.start_m:g} m (the default) until the innovations of "
                                             f"{self.min_fixes} fixes without a std give an estimate")
        return self.std_enu

    def observe(self, innovation, h, cov_prior) -> None:
        """One fix of unknown std went through the gate: its innovation (3,) m, Jacobian (3, n), prior P (n, n)."""
        nu = np.asarray(innovation, dtype=float)[:3]
        hph = np.einsum("ij,jk,ik->i", h[:3], cov_prior, h[:3])
        if not (np.all(np.isfinite(nu)) and np.all(np.isfinite(hph))):
            return
        self.n_seen += 1
        self.nu2 = np.vstack([self.nu2, nu**2])[-self.window:]
        self.hph = np.vstack([self.hph, hph])[-self.window:]
        std_h = self._matched(self.nu2[:, :2].ravel(), self.hph[:, :2].ravel(), self.std_enu[0])
        std_u = self._matched(self.nu2[:, 2], self.hph[:, 2], self.std_enu[2])
        if std_h is None and std_u is None:
            return
        self.std_enu = np.array([std_h or self.std_enu[0], std_h or self.std_enu[1], std_u or self.std_enu[2]])
        self.counters.unknown_fix_std = (f"{self.std_enu[0]:.3g} m horizontal, {self.std_enu[2]:.3g} m vertical, "
                                         f"estimated from the innovations of {self.n_seen} fixes without a std "
                                         "(set gps_std_m / gps_std_up_m if the receiver's is known)")

    def _matched(self, nu2, hph, std_now):
        """The std (m) whose variance matches the innovations' median (see the class doc); None if too few."""
        use = hph <= std_now**2
        if np.sum(use) < self.min_fixes:
            return None
        nu2, hph = nu2[use], hph[use]
        lo, hi = math.log(self.floor_m**2), math.log(max(4.0 * float(np.max(nu2)), self.floor_m**2))
        for _ in range(40):  # bisection on log R: the median ratio falls as R grows
            mid = 0.5 * (lo + hi)
            if np.median(nu2 / (hph + math.exp(mid))) > self.CHI2_1_MEDIAN:
                lo = mid
            else:
                hi = mid
        return max(math.exp(0.5 * hi), self.MAX_FALL * std_now)


def _h_std(fix) -> float:
    """Horizontal position std (m) of a fix: root of its east and north variances."""
    return math.sqrt(fix.cov[0, 0] + fix.cov[1, 1])


def jumps(track: list, max_speed: float, max_accel: float) -> bool:
    """Whether a fix sequence (``.t`` s, ``.enu`` m, ``.cov`` m^2) needs more than the physical limits.

    A chord faster than ``max_speed`` m/s, or two chords whose velocity change needs more than
    ``max_accel`` m/s^2, beyond ``NOISE_SIGMAS`` of the fixes' noise, is a jump. (Scalar arithmetic:
    it runs once per fix.)
    """
    chords = []  # (ve, vn, dt, std_a / dt, std_b / dt)
    for a, b in zip(track[:-1], track[1:]):
        dt = b.t - a.t
        if dt <= 0.0:
            return True
        de, dn = float(b.enu[0] - a.enu[0]), float(b.enu[1] - a.enu[1])
        sa, sb = _h_std(a), _h_std(b)
        if math.hypot(de, dn) > max_speed * dt + NOISE_SIGMAS * math.hypot(sa, sb):
            return True
        chords.append((de / dt, dn / dt, dt, sa / dt, sb / dt))
    for (e1, n1, dt1, s0, s1), (e2, n2, dt2, s1b, s2) in zip(chords[:-1], chords[1:]):
        noise = math.sqrt(s0**2 + (s1 + s1b) ** 2 + s2**2)
        if math.hypot(e2 - e1, n2 - n1) > max_accel * 0.5 * (dt1 + dt2) + NOISE_SIGMAS * noise:
            return True
    return False


def reset_allowed(last_accepted, streak: list, max_speed, max_accel, min_fixes: int) -> bool:
    """Whether the rejected ``streak`` of fixes may replace the INS solution (a GPS reset).

    Yes when the fixes, from the last accepted one on, form a physically possible track (the INS
    drifted away from a continuous GPS track); after a jump only when the track since the jump
    has lasted ``JUMP_CONFIRM_FACTOR * min_fixes`` fixes (a glitch that persists is the new truth).
    """
    if len(streak) < min_fixes:
        return False
    head = [last_accepted] if last_accepted is not None else []
    if not jumps(head + streak, max_speed, max_accel):
        return True
    tail = next(k for k in range(len(streak)) if not jumps(streak[k:], max_speed, max_accel))
    return len(streak) - tail >= JUMP_CONFIRM_FACTOR * min_fixes


class FixHistory:
    """The fixes behind the GPS-reset decision: the last accepted one, the rejected ones since (bounded), the
    last three consumed (for the jump count). Limits in m/s and m/s^2; counts go to ``counters``."""

    def __init__(self, max_rejected: int, max_speed: float, max_accel: float, counters: InputCounters):
        self.max_rejected, self.max_speed, self.max_accel = max_rejected, max_speed, max_accel
        self.counters = counters
        self.last_accepted = None
        self.streak: list = []
        self.recent: list = []

    def consumed(self, fix) -> None:
        """A fix reached an epoch: count it if its track from the two before is physically impossible."""
        self.recent = (self.recent + [fix])[-3:]
        if jumps(self.recent, self.max_speed, self.max_accel):
            self.counters.gps_jumps += 1

    def judged(self, fix, accepted: bool) -> None:
        """The gate's verdict on ``fix``: an accepted fix ends the rejected streak."""
        if accepted:
            self.last_accepted, self.streak = fix, []
        else:
            self.streak = (self.streak + [fix])[-(JUMP_CONFIRM_FACTOR * self.max_rejected + 1):]

    def reset_allowed(self, fix) -> bool:
        """Whether the streak and ``fix`` may replace the INS solution (see :func:`reset_allowed`); counted if not."""
        if reset_allowed(self.last_accepted, self.streak + [fix], self.max_speed, self.max_accel, self.max_rejected):
            return True
        self.counters.gps_resets_refused += 1  # the rejected fixes jumped away: a glitch, keep the INS
        self.counters.last_rejection = f"fix at t={fix.t:.3f} s: no GPS reset, the rejected fixes jumped"
        return False


class GnssClock:
    """The offset (s) of the fix stamps from the IMU clock, zero until a GNSS clock step is confirmed.

    A fix arriving (at IMU time ``t_imu``) more than ``stale_s`` after its stamp is stale; when
    ``n_confirm`` stale fixes in a row lag by the same amount (within ``stale_s``), the GNSS clock
    stepped back by that much and later fixes are re-stamped onto the IMU clock. A fix whose own
    stamp fits the IMU time again ends the offset. Both are counted as ``gnss_clock_steps``.
    """

    def __init__(self, n_confirm: int, stale_s: float, counters: InputCounters):
        self.n_confirm, self.stale_s, self.counters = n_confirm, stale_s, counters
        self.offset = 0.0
        self.lags: list[float] = []

    def restamp(self, t: float, t_imu: float | None) -> float:
        """The stamp ``t`` (s, finite) on the IMU clock; a stale result is the caller's to drop."""
        if t_imu is None:
            return t + self.offset
        if self.offset and abs(t - t_imu) <= self.stale_s:
            self._set(0.0, t)  # the GNSS clock is back on the IMU clock
        if t_imu - (t + self.offset) <= self.stale_s:
            self.lags = []
            return t + self.offset
        self.lags = (self.lags + [t_imu - t])[-self.n_confirm:]
        if len(self.lags) == self.n_confirm and max(self.lags) - min(self.lags) <= self.stale_s:
            self._set(float(np.median(self.lags)), t)
            self.lags = []
        return t + self.offset

    def _set(self, offset: float, t: float) -> None:
        self.counters.gnss_clock_steps += 1
        self.counters.last_rejection = (f"fix stamps from t={t:.3f} s moved by {offset - self.offset:+.3f} s "
                                        f"onto the IMU clock (GNSS clock step)")
        self.offset = offset


IMU_STEP_CONFIRM = 3  # samples in a row, stamped back at the IMU's rate, that show the IMU clock stepped back


class ImuClock:
    """The offset (s) put on the IMU stamps after the IMU clock stepped back by less than ``time_jump`` s.

    Fed the stamps in the order they come (one or many at a time: the same result), it returns
    them re-stamped. ``IMU_STEP_CONFIRM`` samples in a row stamped before the latest, each one
    period (the last forward step, within a factor of 1.5) after the one before, are a clock step:
    the offset moves so that the first of them would have come one period after the latest, and
    the last of them and every later stamp get it (the ones before are returned as they came: the filter
    drops them as out of order). A stamp back by more than ``time_jump`` is a restart: the offset goes to zero.
    A swapped pair, a reversed block or a jittered stamp never makes such a run.
    """

    def __init__(self, time_jump: float, counters: InputCounters):
        self.time_jump, self.counters = float(time_jump), counters
        self.offset = 0.0
        self.latest = -math.inf  # latest stamp returned in order, s (re-stamped)
        self.period = math.nan  # last forward step of the stamps, s
        self.pending: list[float] = []  # raw stamps of the samples stamped back in a row

    def restamp(self, t) -> np.ndarray:
        """The stamps (n,) s re-stamped (non-finite ones pass as they are, for the filter to drop)."""
        t = np.asarray(t, dtype=float)
        out = t + self.offset
        if not self.pending and len(t) and out[0] > self.latest and np.all(np.diff(out) > 0):  # the common case
            if len(t) > 1:
                self.period = float(out[-1] - out[-2])
            elif math.isfinite(self.latest):
                self.period = float(out[0] - self.latest)
            self.latest = float(out[-1])
            return out
        return np.array([self.one(float(ti)) for ti in t])

    def one(self, t: float) -> float:
        """One stamp (s) re-stamped."""
        if not math.isfinite(t):
            return t
        out = t + self.offset
        if out > self.latest:
            self.period = out - self.latest if math.isfinite(self.latest) else self.period
            self.latest, self.pending = out, []
            return out
        if self.latest - out > self.time_jump:  # a restart: the stamps start again from here
            self.offset, self.latest, self.pending = 0.0, t, []
            return t
        if out == self.latest:  # a repeated stamp: the filter drops it
            return out
        regular = bool(self.pending) and self.period / 1.5 <= t - self.pending[-1] <= 1.5 * self.period
        self.pending = self.pending + [t] if regular else [t]
        if len(self.pending) < IMU_STEP_CONFIRM:
            return out
        moved = self.latest + self.period - (self.pending[0] + self.offset)
        self.offset += moved
        self.counters.imu_clock_steps += 1
        self.counters.last_rejection = (f"IMU stamps from t={self.pending[0]:.3f} s moved by {moved:+.3f} s: the "
                                        "IMU clock stepped back")
        self.latest, self.pending = t + self.offset, []
        return self.latest


class FixArrivals:
    """Where each fix of a stream goes among the IMU samples (s), decided fix by fix in the order the fixes come.

    The one arrival rule of the node's intake and the offline replay: it looks at no later fix and
    never moves a fix it placed, so the node hands the filter the replay's order whatever its
    batching. A fix goes at its stamp, unless the stamp is before the stream's place (time went
    back): then one fix spacing (the last forward step of the stamps) after it, where a receiver
    keeping its rate sent it. The filter gets the fix's own stamp there and judges it: a fix stamped
    before one it took already is dropped (out of order), a GNSS clock that stepped back shows as a
    steady lag (:class:`GnssClock`).

    When the stamp went back to between the two fixes before, and the fix before was stamped past
    its slot (one spacing after the fix before it), that one was stamped ahead (the flag returned).
    If by more than ``stale_s`` s past this stamp, it is an outlier: it waits at its stamp for the
    filter to judge and holds up no other fix, the stream goes on from its slot. Otherwise this fix
    still goes one spacing after it (the filter drops it), and the stream goes on as if both had
    come in their slots, so a fix stamped a little ahead delays none of the later ones.
    """

    def __init__(self, stale_s: float):
        self.stale_s = float(stale_s)
        self.restart()

    def restart(self) -> None:
        """Forget the stream (a restarted recording)."""
        self.place, self.prev_t, self.spacing = -math.inf, math.nan, 0.0  # the stream: last place, stamp, step
        self._before = None  # the stream before the last fix (place, stamp, step): its slot

    def place_of(self, t: float) -> tuple[float, bool]:
        """(place in s of the fix stamped ``t`` s, whether the fix before was found stamped ahead)."""
        if not math.isfinite(t):  # the filter drops it; it goes with the fix before, the stream keeps going
            self._before = None
            return self.place, False
        before, ahead, at = (self.place, self.prev_t, self.spacing), False, None
        if t < self.place and t < self.prev_t and self._before is not None:
            place0, t0, step0 = self._before
            slot = (place0 + step0, t0 + step0, step0)  # where the fix before belonged in line
            if not self.prev_t <= slot[1] and not t < t0:  # (NaN: no fix before it, nothing to be before)
                if self.prev_t - t > self.stale_s:  # an outlier: this fix goes on from its slot
                    ahead, before = True, slot
                elif step0 > 0.0:  # this fix is the one out of order: after the fix before; the stream in line
                    ahead, before, at = True, slot, self.place + self.spacing
        self._before = before
        if at is not None:  # the stream goes on in line, as if this fix had come in its slot
            place, prev_t, spacing = before[0] + before[2], before[1] + before[2], before[2]
        else:
            place, prev_t, spacing = before
            if t > prev_t:
                spacing = t - prev_t  # the receiver's rate: the last forward step
            at = place = t if t >= place else place + spacing
            prev_t = t
        self.place, self.prev_t, self.spacing = place, prev_t, spacing
        return at, ahead

