"""The INS/GPS filter: alignment, strapdown between filter epochs, covariance propagation and updates at epochs.

One object used identically by the node (one message at a time) and the offline
replay (large chunks): feed IMU samples and GPS fixes in stamp order (a fix
before an IMU sample with the same stamp); every filter epoch (multiples of
``1 / filter_rate_hz`` s) yields an :class:`Estimate`. Chunking does not change
the numbers: the kernel runs the same per-sample arithmetic either way.

This module holds the life cycle and the epoch; each policy lives apart: the start
(:mod:`starts`), the update models (:mod:`updates`: GNSS position, zero velocity), which fix
an epoch uses and when a GPS reset is due (:mod:`gnss_policy`), heading from the course and
the reset itself (:mod:`heading`), and crossing IMU gaps (:mod:`bridging`).
Bad input never raises nor reaches the state (:mod:`ins_gps_kf.input_checks`, counted in
``input_counters``, a dict for diagnostics); a non-finite or over-speed state resets instead.
"""
from __future__ import annotations

import math

import numpy as np

from nav_core import earth
from nav_core import sensor_model as sm
from nav_core.earth import LocalFrame
from nav_core.units import DEG
from ins_gps_kf import error_model as em
from ins_gps_kf import heading, input_checks, kalman, measurements, starts, strapdown
from ins_gps_kf.alignment import InMotionAligner
from ins_gps_kf.bridging import GapBridge, time_breaks
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.gnss_policy import GnssPolicy
from ins_gps_kf.odometry import Odometry, epoch_span, odometry
from ins_gps_kf.records import (ALIGNING, HEADING_PENDING, NAVIGATING, STATUS_CODES, WAITING,  # noqa: F401
                                Counters, Estimate, Fix)
from ins_gps_kf.updates import Epoch, GnssPosition, Mounting, NonHolonomic, WheelOdometer, ZeroVelocity

ODOMETER_SCALE_DRIVE = 1e-5  # 1/sqrt(s): the odometer scale drifts slowly (tyre pressure, load, temperature)
MOUNTING_DRIVE = 1e-5  # rad/sqrt(s): the mounting is fixed; a little drive keeps the estimate from freezing

EPOCH_TOL_S = 1e-6  # stamps within this of an epoch belong to it (ns stamp rounding)


class InsGpsFilter:
    """Loosely coupled INS/GPS error-state Kalman filter (15 states, 21 with scale factors, n - 1 more per flicker
    bias axis with n Gauss-Markov states per axis, then the odometer scale and the mounting) with alignment."""

    def __init__(self, cfg: FilterConfig, model: sm.SensorModel | None = None):
        self.cfg = cfg
        self.model = model if model is not None else em.default_mems_model()
        self.noise = em.noise_from_sensor_model(self.model, cfg.flicker_correlation_time, cfg.bias_gm_per_axis,
                                                cfg.bias_gm_band_max)
        self.lever_arm_b = np.asarray(cfg.lever_arm_b, dtype=float)
        self.n_core = em.N_STATES_SF if cfg.estimate_scale_factors else em.N_STATES
        self.n_ins = self.n_core + self.noise.n_extra  # the flicker's further Gauss-Markov components follow
        self.n_states = self.n_ins + (1 if cfg.odometer_enabled else 0)
        mount_index = None
        if cfg.nhc_enabled and cfg.nhc_mounting == "estimate":
            mount_index = slice(self.n_states, self.n_states + 2)
            self.n_states += 2
        self.mounting = Mounting(cfg, mount_index)
        self.frame = LocalFrame(*cfg.datum) if cfg.datum is not None else None
        self.counters = Counters()
        self.input = input_checks.InputCounters()
        self.gnss_clock = input_checks.GnssClock(cfg.max_rejected_fixes, cfg.time_jump, self.input)
        self.unknown_fix_std = input_checks.UnknownFixStd(measurements.UNKNOWN_FIX_STD_M, cfg.min_gps_std, self.input)
        self.gnss_model = GnssPosition(self.lever_arm_b)
        self.zupt = ZeroVelocity(cfg)
        self.nhc = NonHolonomic(cfg, self.mounting)
        self.odometer = WheelOdometer(cfg, self.n_ins, self.input.counter("odometer_stuck"), self.mounting,
                                      self._count_odometer_gap)
        self.bridge = GapBridge(cfg)
        self.last_fix_t = -math.inf
        self.last_nis = math.nan
        self.recorder = None  # a smoother.ForwardStore when a smoothing pass follows (replay --smooth)
        self._start_over()

    # ------------------------------------------------------------------ life cycle

    def _start_over(self):
        self.status = WAITING if self.frame is None else ALIGNING
        self._cut_chain()
        self._last_fix_in = None  # (t, lat, lon, h) of the last fix let in, for duplicate and order checks
        self.aligner = starts.make_aligner(self.cfg, self.input)
        self.alignment = None
        self.nav = None
        self.mem = None
        self.cov = None
        self.t_last = None
        self.bridge.clear()
        self.gnss = GnssPolicy(self.cfg, self.counters, self.input)
        self.course = heading.HeadingFromCourse(self.cfg)
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.gyro_scale = np.zeros(3)  # estimated scale-factor errors (unitless), with estimate_scale_factors
        self.odometer.scale = 0.0
        self.odometer.pending, self.odometer.last_t = None, -math.inf  # a restarted clock: wheel stamps start anew
        self.odometer.in_gap = False
        self.accel_scale = np.zeros(3)

    def _count_odometer_gap(self):
        """One more odometer gap (an epoch without a recent wheel speed after one with it)."""
        self.counters.odometer_gaps += 1

    def _cut_chain(self):
        """Tell the recorder the state was set anew (not by a linear update): no smoothing across this epoch."""
        if getattr(self, "recorder", None) is not None:
            self.recorder.cut()

    def reset(self, reason: str):
        """Forget the navigation solution and re-align (keeps the datum); counted and remembered."""
        self.counters.resets += 1
        self.counters.reset_reasons.append(reason)
        self._start_over()

    @property
    def input_counters(self) -> dict:
        """Rejected or doubtful input by kind (ints) and ``last_rejection`` (str); see :mod:`input_checks`."""
        return self.input.as_dict()

    @property
    def navigating(self) -> bool:
        """Whether a navigation solution exists (aligned)."""
        return self.nav is not None

    # ------------------------------------------------------------------ outputs (what the node publishes)

    def odometry(self, est: Estimate, prev_t: float) -> Odometry:
        """The odometry of ``est`` (:func:`ins_gps_kf.odometry.odometry`); ``prev_t`` the previous epoch, s."""
        return odometry(est, self.noise, epoch_span(est.t, prev_t, self.cfg.filter_rate_hz, self.cfg.imu_rate_hz))

    def oriented_imu(self, gyro, accel) -> tuple:
        """(quaternion xyzw, attitude covariance (3, 3) rad^2, gyro rad/s, accel m/s^2): a sample ``gyro``,
        ``accel`` with the current biases removed and the current attitude; only while navigating."""
        return (self.nav[strapdown.Q].copy(), self.cov[em.PHI, em.PHI].copy(), gyro - self.gyro_bias,
                accel - self.accel_bias)

    def imu_variances(self) -> tuple:
        """Per-sample white-noise variances (3,) of the gyro (rad^2/s^2) and accel (m^2/s^4) at the IMU rate."""
        return self.noise.gyro_white ** 2 * self.cfg.imu_rate_hz, self.noise.accel_white ** 2 * self.cfg.imu_rate_hz

    # ------------------------------------------------------------------ GPS input

    def process_gps(self, t, lat_rad, lon_rad, h_m, std_enu, status=0) -> bool:
        """Queue one fix (s, rad, rad, m, std ENU m, NavSatStatus); False if it is dropped (counted)."""
        cfg = self.cfg
        t = self.gnss_clock.restamp(float(t), self.t_last) if math.isfinite(float(t)) else t
        why = input_checks.check_fix(t, lat_rad, lon_rad, h_m, status, self._last_fix_in, self.t_last,
                                     cfg.time_jump, cfg.max_bridged_gap + cfg.time_jump)
        if why is not None:
            setattr(self.input, why, getattr(self.input, why) + 1)
            self.counters.fixes_invalid += why == "fixes_invalid"
            self.input.last_rejection = f"fix at t={float(t):.3f} s dropped: {why}"
            if why == "fixes_conflicting" and self.gnss.pending_fix is not None and self.gnss.pending_fix.t == t:
                self.gnss.pending_fix = None  # two positions for one instant: trust neither
            return False
        self._last_fix_in = (t, lat_rad, lon_rad, h_m)
        self.counters.fixes += 1
        if self.frame is None:
            self.frame = LocalFrame(lat_rad / DEG, lon_rad / DEG, float(h_m))
            self.status = ALIGNING
        known = not input_checks.std_unknown(std_enu)
        if not known and not (cfg.gps_std > 0 and cfg.gps_std_up > 0):
            self.input.fixes_std_unknown += 1
            std_enu = self.unknown_fix_std.current()  # from the innovations of such fixes (10 m at first)
        cov = measurements.fix_covariance(std_enu, cfg.gps_std, cfg.gps_std_up, cfg.min_gps_std)
        self.gnss.pending_fix = Fix(float(t), self.frame.to_enu(lat_rad / DEG, lon_rad / DEG, h_m), cov,
                                    known or cfg.gps_std > 0)
        if self.nav is None and isinstance(self.aligner, InMotionAligner):
            self.aligner.add_fix(t, self.gnss.pending_fix.enu)
        return True

    # ------------------------------------------------------------------ IMU input

    def process_imu(self, t, gyro, accel) -> list[Estimate]:
        """Feed IMU samples: ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2; returns epoch estimates."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        gyro = np.atleast_2d(np.asarray(gyro, dtype=float))
        accel = np.atleast_2d(np.asarray(accel, dtype=float))
        keep = input_checks.screen_imu(t, gyro, accel, self.t_last, self.cfg.imu_max_gyro, self.cfg.imu_max_accel,
                                       self.input, self.cfg.time_jump)
        if keep is not None:
            t, gyro, accel = t[keep], gyro[keep], accel[keep]
        if self.cfg.apply_calibration:
            gyro, accel = self.model.gyro.correct(gyro), self.model.accel.correct(accel)
        out = []
        if len(t) == 0:
            return out
        start = 0
        for bad in time_breaks(t, self.t_last, self.cfg.time_jump):
            out += self._process_span(t[start:bad], gyro[start:bad], accel[start:bad])
            if bad > start:
                self.bridge.remember(gyro[start:bad], accel[start:bad])
            prev_t = t[bad - 1] if bad > 0 else self.t_last
            gap = t[bad] - prev_t
            if self.bridge.can_bridge(gap, self.nav is not None):
                out += self._bridge(prev_t, float(t[bad]))
            else:
                self.reset(f"time jump of {gap:+.3f} s at t={t[bad]:.3f} s")
            start = bad
        out += self._process_span(t[start:], gyro[start:], accel[start:])
        self.bridge.remember(gyro, accel)
        return out

    def _bridge(self, t_from: float, t_to: float) -> list[Estimate]:
        """Cross a forward IMU gap (:mod:`ins_gps_kf.bridging`): counted, covariance grown, held samples run."""
        self.counters.gaps_bridged += 1
        self.counters.reset_reasons.append(f"IMU gap of {t_to - t_from:.3f} s at t={t_from:.3f} s bridged")
        self.bridge.grow(self.cov, t_to - t_from)
        held = self.bridge.held(t_from, t_to)
        return [] if held is None else self._process_span(*held)

    def _process_span(self, t, gyro, accel) -> list[Estimate]:
        out = []
        i, n = 0, len(t)
        while i < n:
            if self.nav is None:
                i = self._align(t, gyro, accel, i)
                continue
            j = i + int(np.searchsorted(t[i:], self.next_epoch - EPOCH_TOL_S))
            if j >= n:
                self._integrate(t[i:], gyro[i:], accel[i:])
                break
            self._integrate(t[i:j + 1], gyro[i:j + 1], accel[i:j + 1])
            est = self._epoch()
            if self._state_ok(est):
                out.append(est)
                if self.recorder is not None:
                    self.recorder.epoch(est)
            i = j + 1
        return out

    def _state_ok(self, est: Estimate) -> bool:
        """False (and reset, counted) if the state is not finite or faster than twice the speed limit."""
        if input_checks.state_ok(self.nav, self.cov, est.velocity_n, est.t, 2.0 * self.cfg.max_speed, self.input):
            return True
        self.reset(f"diverged state at t={est.t:.3f} s")
        return False

    def process_odometry(self, t, speed_mps) -> bool:
        """Queue one wheel speed (s, m/s, forward); False if it is dropped (NaN, duplicate or earlier stamp: counted)."""
        t, speed = float(t), float(speed_mps)
        odo = self.odometer
        why = ("odometer_nonfinite" if not (math.isfinite(t) and math.isfinite(speed)) else
               "odometer_duplicate" if t == odo.last_t else "odometer_out_of_order" if t < odo.last_t else None)
        if why is not None:
            self.input.counter(why)(f"wheel speed at t={t:.3f} s dropped: {why}")
            return False
        odo.last_t, odo.pending = t, (t, speed)
        return True

    def _integrate(self, t, gyro, accel):
        if self.cfg.estimate_scale_factors:
            gyro, accel = gyro * (1.0 - self.gyro_scale), accel * (1.0 - self.accel_scale)
        strapdown.integrate(self.nav, self.mem, t, gyro, accel, self.gyro_bias, self.accel_bias,
                            self.w_ie_n, self.w_en_n, self.g_n)
        self.t_last = float(t[-1])

    # ------------------------------------------------------------------ alignment and start

    def _align(self, t, gyro, accel, i) -> int:
        """Feed samples from ``i`` to the aligner until it finishes; returns the next index."""
        for k in range(i, len(t)):
            self.t_last = float(t[k])
            if self.frame is None:
                continue
            if self.aligner.add(t[k], gyro[k], accel[k]):
                self._start_navigation(float(t[k]))
                return k + 1
        return len(t)

    def _start_navigation(self, t0):
        """Navigation from the finished alignment (:mod:`ins_gps_kf.starts`)."""
        cfg = self.cfg
        known_yaw = not math.isnan(cfg.initial_yaw)
        self.alignment = self.aligner.finish(self.frame.lat0_deg * DEG, cfg.initial_yaw if known_yaw else None)
        new = starts.start(cfg, self.alignment, t0, self.gnss.pending_fix, self.lever_arm_b, self.model,
                           self.n_core)
        self.nav, self.mem, self.cov, self.status = new.nav, new.mem, new.cov, new.status
        if self.n_states > self.n_core:
            cov = np.zeros((self.n_states, self.n_states))
            cov[:self.n_core, :self.n_core] = self.cov
            if self.noise.n_extra:
                idx = np.r_[em.index(em.BG, em.BA), self.n_core:self.n_ins]
                total_var = np.diag(self.cov)[em.index(em.BG, em.BA)]
                cov[np.ix_(idx, idx)] = em.bias_component_covariance(self.noise, total_var)
            extra = np.arange(self.n_ins, self.n_states)
            cov[extra, extra] = [v**2 for v, _ in self._extra_states()]
            self.cov = cov
        self.gyro_bias, self.accel_bias = new.gyro_bias, new.accel_bias
        self.epoch_index = math.floor(t0 * cfg.filter_rate_hz + EPOCH_TOL_S) + 1
        self._earth_at = (math.inf, math.inf)
        self._radii = earth.radii(self.frame.lat0_deg * DEG)
        self._update_earth()

    def _extra_states(self) -> list:
        """(initial std, driving density) of each state after the INS ones: the odometer scale (unitless), then
        the mounting's pitch and yaw errors (rad)."""
        cfg = self.cfg
        out = [(cfg.odometer_scale_std, ODOMETER_SCALE_DRIVE)] if cfg.odometer_enabled else []
        if self.mounting.index is not None:
            out += [(cfg.mounting_std, MOUNTING_DRIVE)] * 2
        return out

    @property
    def next_epoch(self) -> float:
        """Stamp of the next filter epoch, s."""
        return self.epoch_index / self.cfg.filter_rate_hz

    # ------------------------------------------------------------------ epoch

    def mat_nb(self):
        """Current body-to-ENU rotation matrix."""
        return strapdown.mat_nb(self.nav)

    def _update_earth(self):
        """Earth rate, transport rate and gravity (ENU) at the current position, held until the next epoch.

        Gravity and Earth rate are recomputed only after a move of ~1 m in latitude or height
        (they change by parts per billion per metre); the transport rate follows the velocity.
        """
        h = self.frame.h0_m + self.nav[strapdown.P][2]
        rm, rn = self._radii
        lat = self.frame.lat0_deg * DEG + self.nav[strapdown.P][1] / (rm + h)
        if abs(lat - self._earth_at[0]) > 1.5e-7 or abs(h - self._earth_at[1]) > 1.0:
            self._earth_at = (lat, h)
            self._radii = earth.radii(lat)
            self.w_ie_n = earth.earth_rate_n(lat)
            self.g_n = earth.gravity_n(lat, h)
            self.gravity = -self.g_n[2]
        self.w_en_n = earth.transport_rate_n(lat, h, self.nav[strapdown.V])

    def _epoch(self) -> Estimate:
        t_e = self.t_last
        motion = strapdown.epoch_motion(self.mem)
        f_n = motion[0]
        dt = self.mem[strapdown.M_DT]
        mat_nb = self.mat_nb()
        f_cont, g_cont = em.dynamics(mat_nb, f_n, self.w_ie_n, self.w_en_n, self.noise)
        if self.cfg.estimate_scale_factors:
            w_b = self.mem[strapdown.M_WSUM] / max(self.mem[strapdown.M_N], 1.0)
            f_cont, g_cont = em.with_scale_factors(f_cont, g_cont, mat_nb, w_b, mat_nb.T @ f_n)
        f_cont, g_cont = em.with_bias_components(f_cont, g_cont, self.noise, self.n_core)
        if self.n_states > self.n_ins:
            f_cont, g_cont = em.with_random_walks(f_cont, g_cont, [d for _, d in self._extra_states()])
        order = 10 if self.noise.n_extra else 8  # fast bias components (kalman.propagate_series)
        if self.recorder is None:
            self.cov = kalman.propagate_series(self.cov, f_cont, g_cont, dt, order)
        else:
            phi, self.cov = kalman.propagate_series_phi(self.cov, f_cont, g_cont, dt, order)
            self.recorder.predicted(phi, self.cov)
        predicted = self.nav[strapdown.P].copy(), self.nav[strapdown.Q].copy()  # the continuous INS chain
        w_mean_b = self.mem[strapdown.M_WSUM] / max(self.mem[strapdown.M_N], 1.0)
        epoch = Epoch(t_e, self.nav, self.n_states, motion, self.gravity)
        gps_used, nis = self._gps_update(epoch)
        # after the GNSS update: a heading from the course moves the state and so the gravity used next
        epoch.gps_speed, epoch.gravity = self.gnss.gps_speed, self.gravity
        epoch.gnss_fresh = t_e - self.last_fix_t <= 1.5 / self.cfg.gps_rate_hz
        epoch.vel_std_h = float(np.sqrt(np.trace(self.cov[em.DV, em.DV][:2, :2])))
        stationary = self.zupt.stationary(epoch)
        zupt_used = self._update(self.zupt, epoch)
        self.counters.zupts += zupt_used
        epoch.stationary, epoch.rate_b, epoch.heading_known = stationary, w_mean_b, self.status == NAVIGATING
        epoch.yaw_std = float(np.sqrt(self.cov[em.YAW, em.YAW][0, 0]))
        self._update(self.nhc, epoch, self.counters, "nhc_updates", "nhc_rejected")
        self._update(self.odometer, epoch, self.counters, "odometer_updates", "odometer_rejected")
        strapdown.reset_accumulators(self.mem)
        self._update_earth()
        self.counters.epochs += 1
        while self.next_epoch <= t_e + EPOCH_TOL_S:
            self.epoch_index += 1
        return Estimate(t_e, self.nav[strapdown.P].copy(), self.nav[strapdown.V].copy(),
                        self.nav[strapdown.Q].copy(), self.cov.copy(), self.gyro_bias.copy(),
                        self.accel_bias.copy(), self.status, gps_used, zupt_used, nis, stationary,
                        np.concatenate([self.gyro_scale, self.accel_scale])
                        if self.cfg.estimate_scale_factors else None, w_mean_b, *predicted)

    def _update(self, model, epoch: Epoch, counters=None, used: str = "", rejected: str = "") -> bool:
        """Apply ``model``'s measurement at ``epoch`` if it has one (gated at the model's probability, else the
        filter's); whether it passed the gate. With ``counters``, the ``used`` or ``rejected`` count goes up."""
        measurement = model.measurement(epoch)
        if measurement is None:
            return False
        accepted = self._apply(measurement, model.gate_probability).accepted
        if counters is not None:
            key = used if accepted else rejected
            setattr(counters, key, getattr(counters, key) + 1)
        return accepted

    def _gps_update(self, epoch: Epoch):
        """Use the fix :class:`GnssPolicy` gives this epoch: heading from the course while it is pending, a GPS
        reset when one is due, else the position update; returns (used, NIS)."""
        t_e = epoch.t
        taken = self.gnss.take(t_e)
        if taken is None:
            return False, math.nan
        fix, reused = taken
        if self.status == HEADING_PENDING and not reused and self._try_heading(fix, t_e):
            self.gnss.taken_whole(fix)
            self.last_fix_t = fix.t
            return True, math.nan
        if not reused and self.gnss.reset_due(fix):
            self._reset_to_fix(fix)
            return True, math.nan
        self.gnss_model.fix = fix
        z = self.gnss_model.measurement(epoch)
        cov_prior = self.cov
        corr = self._apply(z)
        if not (reused or fix.std_known) and self.status == NAVIGATING:  # a pending heading swamps the noise
            self.unknown_fix_std.observe(corr.innovation, z[1], cov_prior)
        self.gnss.judged(fix, corr.accepted, reused)
        self.last_nis = corr.nis
        if corr.accepted:
            self.last_fix_t = max(self.last_fix_t, fix.t)
            return True, corr.nis
        return False, self.last_nis

    def _apply(self, measurement, gate_probability: float | None = None):
        """Gate, update and feed back one ``(z, H, R)``; returns the Correction (its dx is None if rejected)."""
        z, h, r = measurement
        probability = self.cfg.gate_probability if gate_probability is None else gate_probability
        self.cov, corr = kalman.correct(self.cov, z, h, r, probability)
        if corr.accepted:
            dx = corr.dx.copy()
            if self.status == HEADING_PENDING:
                dx[em.YAW] = 0.0  # yaw is unknown yet: do not let a linear update steer it
            self._feed_back(dx)
        return corr

    def _feed_back(self, dx):
        """Subtract the estimated errors from the nav state and biases (error state returns to zero)."""
        if self.recorder is not None:
            self.recorder.corrected(dx)
        self.nav[strapdown.P] -= dx[em.DP]
        self.nav[strapdown.V] -= dx[em.DV]
        strapdown.rotate_attitude(self.nav, dx[em.PHI])
        self.gyro_bias = self.gyro_bias - dx[em.BG]
        self.accel_bias = self.accel_bias - dx[em.BA]
        if self.cfg.odometer_enabled:
            self.odometer.scale -= float(dx[self.n_ins])
        if self.mounting.index is not None:
            self.mounting.feed_back(dx[self.mounting.index])
        if self.cfg.estimate_scale_factors:
            self.gyro_scale = self.gyro_scale - dx[em.SG]
            self.accel_scale = self.accel_scale - dx[em.SA]

    # ------------------------------------------------------------------ heading from course, GPS reset

    def _reset_to_fix(self, fix: Fix):
        """After too many rejected fixes in a row the INS has diverged: restart at the fix, heading pending."""
        self.counters.gps_resets += 1
        self._cut_chain()
        self.gnss.rejected_in_row = 0
        self.gnss.taken_whole(fix)
        self.last_fix_t = fix.t
        heading.reset_to_fix(self.nav, self.cov, fix, self.lever_arm_b, self.cfg.heading_std)
        self.status = HEADING_PENDING
        self.course.history = [(fix, heading.ins_yaw(self.nav))]

    def _try_heading(self, fix: Fix, t_e) -> bool:
        """Set yaw, velocity and position from the GPS course when the ground speed allows; True if done."""
        course = self.course.course(fix, heading.ins_yaw(self.nav))
        if course is None:
            return False
        heading.set_heading(self.nav, self.cov, fix, t_e, course, self.lever_arm_b, self.cfg.heading_std)
        self._cut_chain()
        self.course.history = []
        self.status = NAVIGATING
        self._update_earth()
        return True
