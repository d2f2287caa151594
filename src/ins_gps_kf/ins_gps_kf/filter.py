"""The INS/GPS filter: alignment, strapdown between filter epochs, covariance propagation and updates at epochs.

One object used identically by the node (one message at a time) and the offline
replay (large chunks): feed IMU samples and GPS fixes in stamp order (a fix
before an IMU sample with the same stamp); every filter epoch (multiples of
``1 / filter_rate_hz`` s) yields an :class:`Estimate`. Chunking does not change
the numbers: the kernel runs the same per-sample arithmetic either way.

Bad input never raises nor reaches the state (:mod:`ins_gps_kf.input_checks`, counted in
``input_counters``, a dict for diagnostics); a non-finite or over-speed state resets instead.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import earth, frames
from nav_core import sensor_model as sm
from nav_core.earth import LocalFrame
from nav_core.units import DEG
from ins_gps_kf import error_model as em
from ins_gps_kf.error_model import DP, DV, PHI
from ins_gps_kf import input_checks, kalman, measurements, strapdown
from ins_gps_kf.alignment import InMotionAligner, MotionAlignment, StationaryAligner, yaw_from_displacement
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import Counters, Estimate, Fix

WAITING, ALIGNING, HEADING_PENDING, NAVIGATING = "waiting_for_fix", "aligning", "heading_pending", "navigating"
STATUS_CODES = {WAITING: 0, ALIGNING: 1, HEADING_PENDING: 2, NAVIGATING: 3}
EPOCH_TOL_S = 1e-6  # stamps within this of an epoch belong to it (ns stamp rounding)
HEADING_BASELINE_SIGMAS = 10.0  # course baseline at least this many GPS sigmas: heading error ~ 1/10 rad worst
HEADING_HISTORY_S = 10.0  # longest course baseline, s
UNKNOWN_STD_HEADING_HISTORY_S = 30.0  # with fixes of unknown std (10 m assumed) a longer baseline is needed


class InsGpsFilter:
    """Loosely coupled INS/GPS error-state Kalman filter (15 states, 21 with scale factors) with alignment."""

    def __init__(self, cfg: FilterConfig, model: sm.SensorModel | None = None):
        self.cfg = cfg
        self.model = model if model is not None else em.default_mems_model()
        self.noise = em.noise_from_sensor_model(self.model, cfg.flicker_correlation_time)
        self.lever_arm_b = np.asarray(cfg.lever_arm_b, dtype=float)
        self.n_states = em.N_STATES_SF if cfg.estimate_scale_factors else em.N_STATES
        self.frame = LocalFrame(*cfg.datum) if cfg.datum is not None else None
        self.counters = Counters()
        self.input = input_checks.InputCounters()
        self.gnss_clock = input_checks.GnssClock(cfg.max_rejected_fixes, cfg.time_jump, self.input)
        self.unknown_fix_std = input_checks.UnknownFixStd(measurements.UNKNOWN_FIX_STD_M, cfg.min_gps_std, self.input)
        self.last_fix_t = -math.inf
        self.last_nis = math.nan
        self._start_over()

    # ------------------------------------------------------------------ life cycle

    def _start_over(self):
        cfg = self.cfg
        self.status = WAITING if self.frame is None else ALIGNING
        self._last_fix_in = None  # (t, lat, lon, h) of the last fix let in, for duplicate and order checks
        if cfg.alignment_mode == "in_motion":
            self.aligner = InMotionAligner(cfg.motion_window_s, cfg.motion_max_accel, cfg.heading_min_speed,
                                           cfg.motion_gyro_bias)
        else:
            # block means: the per-block noise is far below the per-sample thresholds, hence a quarter
            self.aligner = StationaryAligner(cfg.alignment_time_s, cfg.min_alignment_time_s,
                                             0.25 * cfg.stationary_gyro, cfg.stationary_accel,
                                             max_rate=cfg.stationary_gyro,
                                             on_refused=self.input.counter("alignment_not_gravity"))
        self.alignment = None
        self.nav = None
        self.mem = None
        self.cov = None
        self.t_last = None
        self._recent = None
        self.pending_fix: Fix | None = None
        self.prev_fix: Fix | None = None
        self.heading_history = []  # (fix, INS yaw at its epoch) while the heading is pending
        self.rejected_in_row = 0
        self.fix_history = input_checks.FixHistory(cfg.max_rejected_fixes, cfg.max_speed, cfg.max_accel, self.input)
        self.gps_speed = 0.0  # horizontal speed between the last two fixes, m/s, less 3 sigma of its noise
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.gyro_scale = np.zeros(3)  # estimated scale-factor errors (unitless), with estimate_scale_factors
        self.accel_scale = np.zeros(3)

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
            if why == "fixes_conflicting" and self.pending_fix is not None and self.pending_fix.t == t:
                self.pending_fix = None  # two positions for one instant: trust neither
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
        self.pending_fix = Fix(float(t), self.frame.to_enu(lat_rad / DEG, lon_rad / DEG, h_m), cov,
                               known or cfg.gps_std > 0)
        if self.nav is None and isinstance(self.aligner, InMotionAligner):
            self.aligner.add_fix(t, self.pending_fix.enu)
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
        for bad in self._time_breaks(t):
            out += self._process_span(t[start:bad], gyro[start:bad], accel[start:bad])
            if bad > start:
                self._remember(gyro[start:bad], accel[start:bad])
            prev_t = t[bad - 1] if bad > 0 else self.t_last
            gap = t[bad] - prev_t
            if 0.0 < gap <= self.cfg.max_bridged_gap and self.nav is not None and self._recent is not None:
                out += self._bridge(prev_t, float(t[bad]))
            else:
                self.reset(f"time jump of {gap:+.3f} s at t={t[bad]:.3f} s")
            start = bad
        out += self._process_span(t[start:], gyro[start:], accel[start:])
        self._remember(gyro, accel)
        return out

    def _remember(self, gyro, accel) -> None:
        """Keep the last second of samples (n, 6): a bridged gap holds their mean, not one noisy sample."""
        n = max(int(self.cfg.imu_rate_hz), 1)
        rows = np.hstack([gyro[-n:], accel[-n:]])
        if len(rows) < n and self._recent is not None:
            rows = np.vstack([self._recent, rows])[-n:]
        self._recent = rows

    def _bridge(self, t_from: float, t_to: float) -> list[Estimate]:
        """Cross a forward IMU gap: hold the last second's mean sample; grow the covariance by what
        the vehicle may have done meanwhile (``bridge_*_std``), so the next fixes pull the solution back."""
        n = int(np.floor((t_to - t_from) * self.cfg.imu_rate_hz)) - 1
        self.counters.gaps_bridged += 1
        self.counters.reset_reasons.append(f"IMU gap of {t_to - t_from:.3f} s at t={t_from:.3f} s bridged")
        gap = t_to - t_from
        self.cov[DV, DV] += np.eye(3) * (self.cfg.bridge_accel_std * gap) ** 2
        self.cov[DP, DP] += np.eye(3) * (0.5 * self.cfg.bridge_accel_std * gap**2) ** 2
        # A road vehicle turns about the vertical; its roll and pitch stay within a few degrees, so only the
        # heading uncertainty grows with the turn rate (tilt growth would let GPS updates bend the tilt).
        self.cov[em.YAW, em.YAW] += (self.cfg.bridge_rate_std * gap) ** 2
        if n < 1:
            return []
        ts = t_from + np.arange(1, n + 1) / self.cfg.imu_rate_hz
        held = np.tile(self._recent.mean(axis=0), (n, 1))
        return self._process_span(ts, held[:, :3], held[:, 3:])

    def _time_breaks(self, t):
        """Indices where the stamp goes backwards or jumps forward by more than ``time_jump`` s."""
        prev = np.concatenate(([t[0] if self.t_last is None else self.t_last], t[:-1]))
        dt = t - prev
        return np.flatnonzero((dt < 0.0) | (dt > self.cfg.time_jump))

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
            i = j + 1
        return out

    def _state_ok(self, est: Estimate) -> bool:
        """False (and reset, counted) if the state is not finite or faster than twice the speed limit."""
        if input_checks.state_ok(self.nav, self.cov, est.velocity_n, est.t, 2.0 * self.cfg.max_speed, self.input):
            return True
        self.reset(f"diverged state at t={est.t:.3f} s")
        return False

    def _integrate(self, t, gyro, accel):
        if self.n_states == em.N_STATES_SF:
            gyro, accel = gyro * (1.0 - self.gyro_scale), accel * (1.0 - self.accel_scale)
        strapdown.integrate(self.nav, self.mem, t, gyro, accel, self.gyro_bias, self.accel_bias,
                            self.w_ie_n, self.w_en_n, self.g_n)
        self.t_last = float(t[-1])

    # ------------------------------------------------------------------ alignment

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
        cfg = self.cfg
        lat0 = self.frame.lat0_deg * DEG
        known_yaw = not math.isnan(cfg.initial_yaw)
        self.alignment = self.aligner.finish(lat0, cfg.initial_yaw if known_yaw else None)
        if isinstance(self.alignment, MotionAlignment):
            self._start_navigation_in_motion(t0)
            return
        yaw = cfg.initial_yaw if known_yaw else 0.0
        quat = frames.quat_xyzw_from_euler(self.alignment.roll, self.alignment.pitch, yaw)
        pos, pos_std = np.zeros(3), 10.0
        if self.pending_fix is not None:
            mat_nb = Rotation.from_quat(quat).as_matrix()
            pos = self.pending_fix.enu - mat_nb @ self.lever_arm_b
            pos_std = np.sqrt(np.diag(self.pending_fix.cov))
        self.nav = strapdown.new_state(quat, np.zeros(3), pos)
        self.mem = strapdown.new_memory(t0)
        self.gyro_bias = self.alignment.gyro_bias.copy()
        self.accel_bias = np.zeros(3)
        att_std = np.array([cfg.init_attitude_std, cfg.init_attitude_std, cfg.heading_std])
        self.cov = em.initial_covariance(pos_std, cfg.zupt_std, att_std, cfg.init_gyro_bias_std,
                                         cfg.init_accel_bias_std, *self._scale_stds())
        self.status = NAVIGATING if known_yaw else HEADING_PENDING
        self._start_epochs(t0)

    def _scale_stds(self) -> tuple:
        """Initial scale-factor stds (gyro, accel) when they are states, else nothing."""
        std = self.cfg.init_scale_factor_std
        return (std, std) if self.n_states == em.N_STATES_SF else ()

    def _start_epochs(self, t0):
        self.epoch_index = math.floor(t0 * self.cfg.filter_rate_hz + EPOCH_TOL_S) + 1
        self._earth_at = (math.inf, math.inf)
        self._radii = earth.radii(self.frame.lat0_deg * DEG)
        self._update_earth()

    def _start_navigation_in_motion(self, t0):
        """Navigation from an in-motion alignment: level (or the roll/pitch parameters), course, fitted velocity
        and position; gyro bias from the window, or zero (the model's when its calibration is not applied)."""
        cfg, al = self.cfg, self.alignment
        tilt_std = al.tilt_std
        if not math.isnan(cfg.initial_roll):
            al.roll = cfg.initial_roll
        if not math.isnan(cfg.initial_pitch):
            al.pitch = cfg.initial_pitch
        if not (math.isnan(cfg.initial_roll) or math.isnan(cfg.initial_pitch)):
            tilt_std = cfg.init_attitude_std  # both given: as good as the parameters claim
        quat = frames.quat_xyzw_from_euler(al.roll, al.pitch, al.yaw)
        mat_nb = Rotation.from_quat(quat).as_matrix()
        pos = al.position_n - mat_nb @ self.lever_arm_b
        pos_std = (np.sqrt(np.diag(self.pending_fix.cov)) if self.pending_fix is not None
                   else np.maximum(al.position_std, 1.0))
        self.nav = strapdown.new_state(quat, al.velocity_n, pos)
        self.mem = strapdown.new_memory(t0)
        from_model = not (cfg.motion_gyro_bias or cfg.apply_calibration)
        self.gyro_bias = self.model.gyro.bias.copy() if from_model else al.gyro_bias.copy()
        self.accel_bias = np.zeros(3)
        speed = float(np.hypot(al.velocity_n[0], al.velocity_n[1]))
        vel_std = np.sqrt(al.velocity_std**2 + (0.05 * speed) ** 2 + 0.1**2)
        att_std = np.array([max(tilt_std, cfg.init_attitude_std)] * 2 + [math.hypot(cfg.heading_std, al.yaw_std)])
        self.cov = em.initial_covariance(pos_std, vel_std, att_std, cfg.init_gyro_bias_std, cfg.init_accel_bias_std,
                                         *self._scale_stds())
        self.status = NAVIGATING
        self._start_epochs(t0)

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
        f_n, w_rms, w_mean, f_mean, f_std = strapdown.epoch_motion(self.mem)
        dt = self.mem[strapdown.M_DT]
        mat_nb = self.mat_nb()
        f_cont, g_cont = em.dynamics(mat_nb, f_n, self.w_ie_n, self.w_en_n, self.noise)
        if self.n_states == em.N_STATES_SF:
            w_b = self.mem[strapdown.M_WSUM] / max(self.mem[strapdown.M_N], 1.0)
            f_cont, g_cont = em.with_scale_factors(f_cont, g_cont, mat_nb, w_b, mat_nb.T @ f_n)
        self.cov = kalman.propagate_series(self.cov, f_cont, g_cont, dt)
        predicted = self.nav[strapdown.P].copy(), self.nav[strapdown.Q].copy()  # the continuous INS chain
        w_mean_b = self.mem[strapdown.M_WSUM] / max(self.mem[strapdown.M_N], 1.0)
        gps_used, nis = self._gps_update(t_e)
        # rms catches vibration, the mean catches a steady turn; GPS and INS speed veto smooth cruising and
        # braking, which a MEMS IMU cannot tell from rest
        stationary = bool(w_rms < self.cfg.stationary_gyro and w_mean < 0.25 * self.cfg.stationary_gyro
                          and f_std < self.cfg.stationary_accel
                          and abs(f_mean - self.gravity) < 3 * self.cfg.stationary_accel
                          and self.gps_speed < self.cfg.zupt_max_gps_speed
                          and float(np.linalg.norm(self.nav[strapdown.V])) < self.cfg.zupt_max_ins_speed)
        zupt_used = False
        if self.cfg.zupt_enabled and stationary:
            zupt_used = self._apply(measurements.zero_velocity(self.nav[strapdown.V], self.cfg.zupt_std,
                                                               self.n_states)).accepted
            self.counters.zupts += zupt_used
        strapdown.reset_accumulators(self.mem)
        self._update_earth()
        self.counters.epochs += 1
        while self.next_epoch <= t_e + EPOCH_TOL_S:
            self.epoch_index += 1
        return Estimate(t_e, self.nav[strapdown.P].copy(), self.nav[strapdown.V].copy(),
                        self.nav[strapdown.Q].copy(), self.cov.copy(), self.gyro_bias.copy(),
                        self.accel_bias.copy(), self.status, gps_used, zupt_used, nis, stationary,
                        np.concatenate([self.gyro_scale, self.accel_scale])
                        if self.n_states == em.N_STATES_SF else None, w_mean_b, *predicted)

    def _gps_update(self, t_e):
        """Use the newest pending fix (or, optionally, re-use the last one); returns (used, NIS)."""
        fix, reused = self.pending_fix, False
        self.pending_fix = None
        if fix is not None and self.prev_fix is not None and fix.t > self.prev_fix.t:
            dt = fix.t - self.prev_fix.t
            noise = 3.0 * np.sqrt(fix.cov[0, 0] + self.prev_fix.cov[0, 0]) / dt
            self.gps_speed = max(float(np.hypot(*(fix.enu - self.prev_fix.enu)[:2])) / dt - noise, 0.0)
        if fix is None:
            max_age = 1.5 / self.cfg.gps_rate_hz
            if not (self.cfg.reuse_last_fix and self.prev_fix is not None and t_e - self.prev_fix.t <= max_age):
                return False, math.nan
            fix, reused = self.prev_fix, True
        if not reused:
            self.fix_history.consumed(fix)
        if self.status == HEADING_PENDING and not reused and self._try_heading(fix, t_e):
            self.prev_fix = fix
            self.fix_history.judged(fix, True)
            self.last_fix_t = fix.t
            return True, math.nan
        if (not reused and self.rejected_in_row >= self.cfg.max_rejected_fixes
                and self.fix_history.reset_allowed(fix)):
            self._reset_to_fix(fix, t_e)
            return True, math.nan
        z = measurements.gps_position(self.nav[strapdown.P], self.nav[strapdown.V], self.mat_nb(),
                                      self.lever_arm_b, fix.enu, fix.cov, t_e - fix.t, self.n_states)
        cov_prior = self.cov
        corr = self._apply(z)
        if not (reused or fix.std_known) and self.status == NAVIGATING:  # a pending heading swamps the noise
            self.unknown_fix_std.observe(corr.innovation, z[1], cov_prior)
        if not reused:
            self.prev_fix = fix
            self.counters.fixes_rejected += not corr.accepted
            self.rejected_in_row = 0 if corr.accepted else self.rejected_in_row + 1
            self.fix_history.judged(fix, corr.accepted)
        else:
            self.counters.fixes_reused += 1
        self.last_nis = corr.nis
        if corr.accepted:
            self.last_fix_t = max(self.last_fix_t, fix.t)
            return True, corr.nis
        return False, self.last_nis

    def _apply(self, measurement):
        """Gate, update and feed back one ``(z, H, R)``; returns the Correction (its dx is None if rejected)."""
        z, h, r = measurement
        self.cov, corr = kalman.correct(self.cov, z, h, r, self.cfg.gate_probability)
        if corr.accepted:
            dx = corr.dx.copy()
            if self.status == HEADING_PENDING:
                dx[em.YAW] = 0.0  # yaw is unknown yet: do not let a linear update steer it
            self._feed_back(dx)
        return corr

    def _feed_back(self, dx):
        """Subtract the estimated errors from the nav state and biases (error state returns to zero)."""
        self.nav[strapdown.P] -= dx[em.DP]
        self.nav[strapdown.V] -= dx[em.DV]
        strapdown.rotate_attitude(self.nav, dx[em.PHI])
        self.gyro_bias = self.gyro_bias - dx[em.BG]
        self.accel_bias = self.accel_bias - dx[em.BA]
        if self.n_states == em.N_STATES_SF:
            self.gyro_scale = self.gyro_scale - dx[em.SG]
            self.accel_scale = self.accel_scale - dx[em.SA]

    # ------------------------------------------------------------------ heading from course

    def _reset_to_fix(self, fix: Fix, t_e):
        """After too many rejected fixes in a row the INS has diverged: restart at the fix, heading pending.

        Velocity and heading are then taken again from the GPS course (as after alignment),
        since a diverged solution usually means a wrong heading or velocity.
        """
        self.counters.gps_resets += 1
        self.rejected_in_row = 0
        self.fix_history.judged(fix, True)
        self.prev_fix = fix
        self.last_fix_t = fix.t
        self.nav[strapdown.P] = fix.enu - self.mat_nb() @ self.lever_arm_b
        self.nav[strapdown.V] = 0.0
        speed_var = max(float(np.sum(np.diag(self.cov[em.DV, em.DV]))), 1.0)
        self._reset_block(em.index(em.DP, em.DV, em.YAW), np.concatenate([np.diag(fix.cov), np.full(3, speed_var),
                                                         [self.cfg.heading_std**2]]))
        self.status = HEADING_PENDING
        self.heading_history = [(fix, float(frames.euler_from_quat_xyzw(self.nav[strapdown.Q])[2]))]

    def _reset_block(self, idx, variances):
        """Replace the covariance of states ``idx`` by ``variances``, cutting their correlations."""
        self.cov[idx, :] = 0.0
        self.cov[:, idx] = 0.0
        self.cov[idx, idx] = variances

    def _try_heading(self, fix: Fix, t_e) -> bool:
        """Set yaw, velocity and position from the GPS course when the ground speed allows; True if done.

        The course of the chord from an earlier fix is the heading at the chord's middle;
        the INS yaw change since then (gyros are good over seconds) brings it to now.
        """
        yaw_ins = float(frames.euler_from_quat_xyzw(self.nav[strapdown.Q])[2])
        window = HEADING_HISTORY_S if fix.std_known else UNKNOWN_STD_HEADING_HISTORY_S
        self.heading_history = [(f, y) for f, y in self.heading_history if fix.t - f.t <= window]
        if input_checks.jumps([f for f, _ in self.heading_history[-2:]] + [fix], self.cfg.max_speed,
                              self.cfg.max_accel):
            return False  # the fix jumped away from the track: neither a course nor a baseline for one
        for prev, prev_yaw in reversed(self.heading_history):
            d, dt = fix.enu - prev.enu, fix.t - prev.t
            dist = float(np.hypot(d[0], d[1]))
            sigma = float(np.sqrt(fix.cov[0, 0] + prev.cov[0, 0]))
            possible = dist <= self.cfg.max_speed * dt + input_checks.NOISE_SIGMAS * sigma  # else a jump
            if (dt > 0 and dist / dt >= self.cfg.heading_min_speed and dist >= HEADING_BASELINE_SIGMAS * sigma
                    and possible):
                yaw = yaw_from_displacement(d) + 0.5 * float(frames.wrap_angle(yaw_ins - prev_yaw))
                self._set_heading(fix, t_e, yaw, dist / dt, d[2] / dt, sigma / dist)
                return True
        self.heading_history.append((fix, yaw_ins))
        return False

    def _set_heading(self, fix: Fix, t_e, yaw, speed, climb, course_std):
        """Heading (rad), ground speed and climb (m/s) from the course; position from the fix."""
        roll, pitch, _ = frames.euler_from_quat_xyzw(self.nav[strapdown.Q])
        quat = frames.quat_xyzw_from_euler(roll, pitch, yaw)
        vel = np.array([speed * np.cos(yaw), speed * np.sin(yaw), climb])
        self.nav[strapdown.Q] = quat
        self.nav[strapdown.V] = vel
        self.nav[strapdown.P] = fix.enu - Rotation.from_quat(quat).as_matrix() @ self.lever_arm_b
        self.nav[strapdown.P] += vel * (t_e - fix.t)
        # the chord speed is a mean over the baseline: while accelerating it lags by up to half the change
        vel_var = np.diag(fix.cov) * 2.0 + (0.2 * speed) ** 2 + 0.1**2
        self._reset_block(em.index(em.DP, em.DV, em.YAW), np.concatenate([np.diag(fix.cov), vel_var,
                                                         [self.cfg.heading_std**2 + course_std**2]]))
        self.heading_history = []
        self.status = NAVIGATING
        self._update_earth()
