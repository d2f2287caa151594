"""The yaw gyro against the GNSS track: ``bias_shift`` on gz while the vehicle moves.

Each GNSS chord (one fix to the next) is compared with the heading the gyro gives at its middle: the chord's
sideways part, summed along the window, is the track's lateral drift from a dead reckoning that uses the chords'
lengths and the gyro's heading. A gz bias turns that heading by the bias times the time, so the drift grows with
the distance times the time, while the fixes' noise does not add up (successive chords share their ends).

Over a window of ``WINDOW_EPOCHS`` fixes the drift is fitted by generalised least squares on: a constant, the
heading offset at the window's start (times the distance), the bias change (times the distance-weighted time) and
a scale error of the gyro (times the distance-weighted turn of the GNSS course, so a turn does not pass for a
bias). The
covariance carries the gyro's own angle random walk (the heading error it integrates is a random walk: the test
cannot beat it, a gz bias is seen no faster than the gyro's white noise allows) and the fixes' white noise (the
robust sd of the recent windows' residuals). The bias change against the bias learned over the drive, in sd, is
gated at the normal quantile of the package's budget per test, one test per fix.

The sign of gz against the course (z up or down) is learned from the first turns. Assumes the course is the
heading (no sideslip, a mount without a yaw that changes) and x forward. No ROS, no simulator. Times s, angles rad,
distances m.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from sensor_health import thresholds as thr
from sensor_health.along_track import chord_en, robust_sd
from sensor_health.events import Event, bias_shift_event

WINDOW_EPOCHS = 25
WARMUP_EPOCHS = 40
REFERENCE_EPOCHS = 120.0
V_MIN_M_S = 3.0
MAX_FIX_GAP_S = 2.5
SIGN_TURN_RAD = 0.5
"""Summed |course change| in turns (rad) before the sign of gz against the course is trusted."""
SCALE_PREFERENCE = 10.0
"""A scale step must fit the window better than a bias step by this much (GLS chi-square) to silence the event:
with a turn in the window either can mimic the other a little."""
NOISE_WINDOWS = 60
SIGMA_FLOOR_M = 0.005
NOT_OBSERVABLE = "not observable on this record"


class CrossTrackMonitor:
    """Streaming: :meth:`push_gnss` fixes, :meth:`push_imu` gz samples; both return the events they complete."""

    def __init__(self, arw_rad_sqrt_s: float, budget_per_test_10h: float, bias_sd_rad_s: float = 0.0):
        """``arw_rad_sqrt_s``: the model's white noise of gz; ``bias_sd_rad_s``: its bias instability (the wander the
        learned bias lags behind, added to the bias change's variance)."""
        self.arw = float(arw_rad_sqrt_s)
        self.bias_sd = float(bias_sd_rad_s)
        self.gate = float(stats.norm.isf(budget_per_test_10h / thr.SECONDS_PER_10H / 2))
        self.imu_t, self.imu_psi = np.zeros(0), np.zeros(0)
        self._last = None
        self.fix, self.queue = None, []
        self.chords = []
        """(t_mid, length, course, gyro angle at the middle) of the chords at speed since the last restart."""
        self.sign_votes = 0.0
        self.sign = 0.0
        self.ref, self.n_ref = None, 0
        self.mad = []
        self.fixes = self.windows = 0
        self.trace_t, self.trace_z = [], []

    def push_imu(self, t, gz) -> list:
        """gz samples (m,) rad/s at t (m,) s -> events of the fixes they now cover."""
        t, gz = np.asarray(t, float), np.asarray(gz, float)
        if len(t) == 0:
            return []
        t0, g0, p0 = self._last if self._last is not None else (t[0], gz[0], 0.0)
        tt, gg = np.r_[t0, t], np.r_[g0, gz]
        psi = p0 + np.cumsum(0.5 * (gg[1:] + gg[:-1]) * np.diff(tt))
        self._last = (t[-1], gz[-1], psi[-1])
        self.imu_t, self.imu_psi = np.r_[self.imu_t, t], np.r_[self.imu_psi, psi]
        keep = self.imu_t >= self.imu_t[-1] - 30.0
        if (~keep).sum() > len(t):
            self.imu_t, self.imu_psi = self.imu_t[keep], self.imu_psi[keep]
        return self._process()

    def push_gnss(self, t, lat_rad, lon_rad) -> list:
        """Fixes t (m,) s, lat, lon (m,) rad -> events completed."""
        for tk, la, lo in zip(np.atleast_1d(t), np.atleast_1d(lat_rad), np.atleast_1d(lon_rad)):
            if np.isfinite(la) and np.isfinite(lo):
                self.fixes += 1
                self.queue.append((float(tk), float(la), float(lo)))
        return self._process()

    def _process(self) -> list:
        events = []
        while self.queue and len(self.imu_t) and self.imu_t[-1] >= self.queue[0][0]:
            tk, la, lo = self.queue.pop(0)
            if self.imu_t[0] > tk:
                self.chords, self.fix = [], None
                continue
            events += self._fix(tk, la, lo)
        return events

    def _fix(self, tk, la, lo) -> list:
        last, self.fix = self.fix, (tk, la, lo)
        if last is None:
            return []
        dt, c = tk - last[0], chord_en(last[1], last[2], la, lo)
        length = float(np.hypot(*c))
        inside = (self.imu_t >= last[0]) & (self.imu_t <= tk)
        # the chord's direction is the heading averaged over it (at its middle only where the turn rate is constant)
        psi_mid = float(np.mean(self.imu_psi[inside])) if inside.any() else float("nan")
        if dt <= 0 or dt > MAX_FIX_GAP_S or length / dt < V_MIN_M_S or not np.isfinite(psi_mid):
            self.chords = []
            return []
        course = float(np.arctan2(c[1], c[0]))  # from east, counter-clockwise
        if self.chords:
            d_course = float(np.angle(np.exp(1j * (course - self.chords[-1][2]))))
            d_psi = psi_mid - self.chords[-1][3]
            if abs(d_psi) > 0.02 and self.sign == 0.0:
                self.sign_votes += d_course * np.sign(d_psi)
                if abs(self.sign_votes) > SIGN_TURN_RAD:
                    self.sign = float(np.sign(self.sign_votes))
        self.chords = (self.chords + [(0.5 * (tk + last[0]), length, course, psi_mid)])[-WINDOW_EPOCHS:]
        if len(self.chords) < WINDOW_EPOCHS or self.sign == 0.0:
            return []
        return self._window(tk)

    def _window(self, tk) -> list:
        """GLS of the summed lateral drift on [1, distance, distance-weighted time, distance-weighted turn]."""
        _, tau, length, course, y = self._drift(0.0 if self.ref is None else self.ref)
        x = np.column_stack([np.ones(len(y)), np.cumsum(length), np.cumsum(length * tau),
                             np.cumsum(length * self._course_turn(course))])
        self.windows += 1
        ci = self._inverse_covariance(length, tau)
        info = np.linalg.inv(x.T @ ci @ x)
        coef = info @ (x.T @ ci @ y)
        resid = y - x @ coef
        # the fixes' noise from the residual's first differences (the random walk's share there is small)
        self.mad = (self.mad + [float(np.median(np.abs(np.diff(resid)))) / np.sqrt(2)])[-NOISE_WINDOWS:]
        db, sd = float(coef[2]), float(np.sqrt(info[2, 2] + self.bias_sd**2))
        if self.ref is None:
            self.ref = db
            return []
        z = db / sd  # ``heading`` already has the learned bias taken out: db is the change
        self.n_ref += 1
        self.trace_t.append(tk)
        self.trace_z.append(z)
        if self.n_ref > WARMUP_EPOCHS - WINDOW_EPOCHS and abs(z) > self.gate:
            event = self._event(tk, z)
            return [event] if event is not None else []
        self.ref += db / min(self.n_ref, REFERENCE_EPOCHS)
        return []

    def _drift(self, ref):
        """The window's chord times (s) and times from its start (s), lengths (m), courses (rad) and summed lateral
        drift (m) against the gyro's heading less the learned bias' drift ``ref`` (rad/s: y's slope)."""
        tm, length, course, psi = np.array(self.chords).T
        tau = tm - tm[0]
        heading = course[0] + self.sign * (psi - psi[0]) + ref * tau
        y = np.cumsum(length * np.sin(np.angle(np.exp(1j * (course - heading)))))
        return tm, tau, length, course, y

    def _inverse_covariance(self, length, tau):
        """Inverse covariance (1/m^2) of the summed drift: the gyro's white noise makes its heading error a random
        walk W, and the drift sums length_j W(tau_j); plus the fixes' noise from the recent residuals."""
        lw = np.tril(np.ones((len(tau), len(tau)))) * length
        sig = max(robust_sd(self.mad, 1.0) if self.mad else SIGMA_FLOOR_M, SIGMA_FLOOR_M)
        return np.linalg.inv(self.arw**2 * lw @ np.minimum.outer(tau, tau) @ lw.T + sig**2 * np.eye(len(tau)))

    @staticmethod
    def _course_turn(course):
        """The GNSS course's turn from the window's start (unwrapped), rad: the scale error's regressor (the gyro's
        own turn would carry the bias' drift too)."""
        return np.unwrap(course) - course[0]

    def _event(self, tk, z) -> Event | None:
        """Change point: the step of the heading drift's slope (GLS over the window, each chord as the start). None
        when a step of the gyro's scale (the heading error growing with the course's turn from some chord on) fits
        the window better: a scale change in a turn looks like a bias step to the test, and is the scale-factor
        test's to name (the test restarts either way)."""
        tm, tau, length, course, y = self._drift(self.ref)
        ci = self._inverse_covariance(length, tau)
        turned = self._course_turn(course)
        best, best_scale = None, np.inf
        for j in range(2, len(y) - 2):
            base = [np.ones(len(y)), np.cumsum(length)]
            after = tau >= tau[j]
            constant_scale = np.cumsum(length * turned)
            for kind, extra in (("bias", [np.cumsum(length * (tau - tau[j]) * after), constant_scale]),
                                ("scale", [constant_scale, np.cumsum(length * (turned - turned[j]) * after)])):
                x = np.column_stack(base + extra)
                info = np.linalg.inv(x.T @ ci @ x)
                coef = info @ (x.T @ ci @ y)
                r = y - x @ coef
                score = float(r @ ci @ r)
                if kind == "scale":
                    best_scale = min(best_scale, score)
                elif best is None or score < best[0]:
                    best = (score, j, float(coef[2]), float(np.sqrt(info[2, 2])))
        self.ref, self.n_ref, self.chords = None, 0, []
        if best_scale < best[0] - SCALE_PREFERENCE:
            return None
        _, j, step, sd = best
        step *= -self.sign  # the heading drift's slope is minus the bias (in gz's sign)
        return bias_shift_event(tk, float(tm[j]), "gz", step, sd,
                                f"gz mean stepped by {step:.3g} rad/s (against the GNSS track, {abs(z):.1f} sd)",
                                {"z": float(z), "gate": self.gate})

    def observability(self) -> str:
        """Whether this record made a gz bias step observable against the GNSS track, in words."""
        if self.fixes == 0:
            return f"{NOT_OBSERVABLE}: no GNSS fixes"
        if self.sign == 0.0:
            return f"{NOT_OBSERVABLE}: no turns at speed yet (the sign of gz against the course is unknown)"
        if self.windows == 0:
            return f"{NOT_OBSERVABLE}: no {WINDOW_EPOCHS} successive fixes at {V_MIN_M_S:g} m/s or more"
        return f"observable: {self.windows} windows of {WINDOW_EPOCHS} fixes at speed"
