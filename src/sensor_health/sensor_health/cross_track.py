"""The yaw gyro against the GNSS track: ``bias_shift`` on gz while the vehicle moves.

Each GNSS chord (one fix to the next) is compared with the heading the gyro gives at its middle: the chord's
sideways part, summed along the window, is the track's lateral drift from a dead reckoning that uses the chords'
lengths and the gyro's heading. A gz bias turns that heading by the bias times the time, so the drift grows with
the distance times the time, while the fixes' noise does not add up (successive chords share their ends).

Over a window of ``WINDOW_EPOCHS`` fixes the drift is fitted by generalised least squares on: a constant, the
heading offset at the window's start (times the distance), the bias change (times the distance-weighted time) and,
where the window turns, a scale error of the gyro (times the distance-weighted turn of its heading, so a turn does
not pass for a bias; on a straight that column is noise, and the GNSS course's turn there is the drift itself): this
learns the drive's bias (its slow average) and the fixes' noise. The
covariance carries the gyro's own angle random walk (the heading error it integrates is a random walk: the test
cannot beat it, a gz bias is seen no faster than the gyro's white noise allows) and the fixes' white noise (the
robust sd of the recent windows' residuals).

The test is sequential: at each fix, a generalised likelihood ratio over the last ``SPAN_EPOCHS`` chords for a step
of the bias (against the learned one) at each chord (a window-limited GLR: a step is tested on all the fixes since
it, not diluted in a fixed window), the learned bias' lag a random effect in the covariance. Its gate on the largest
|z| comes from Monte Carlo on the model's noise through the same span (the heading's random walk, the fixes' white
noise, the learned bias' error), for the test's share of the budget, one test per fix. (A CUSUM tuned to the 10 x
step was tried beside it and not kept: README "Measured".)

The sign of gz against the course (z up or down) is learned from the first turns. Assumes the course is the
heading (no sideslip, a mount without a yaw that changes) and x forward. No ROS, no simulator. Times s, angles rad,
distances m.
"""
from __future__ import annotations

import functools

import numpy as np
from scipy.signal import lfilter

from sensor_health import thresholds as thr
from sensor_health.along_track import chord_en, robust_sd
from sensor_health.events import Event, bias_shift_event

WINDOW_EPOCHS = 25
SPAN_EPOCHS = 60
"""Chords a step is looked for in (the GLR's span): a step this old has been named or is not one."""
MIN_AFTER_EPOCHS = 2
WARMUP_EPOCHS = 40
REFERENCE_EPOCHS = 120.0
V_MIN_M_S = 3.0
MAX_FIX_GAP_S = 2.5
SIGN_TURN_RAD = 0.5
"""Summed |course change| in turns (rad) before the sign of gz against the course is trusted."""
SCALE_PREFERENCE = 10.0
"""A scale step must fit the window better than a bias step by this much (GLS chi-square) to silence the event:
with a turn in the window either can mimic the other a little."""
UNDECIDED_TURN_RAD = 0.5
"""A step whose bias and scale fits are within SCALE_PREFERENCE of each other, with the GNSS course turning this much
after it, waits for more fixes (a scale step seen a few fixes into a turn fits a bias step as well)."""
SCALE_COLUMN_TURN_RAD = 0.1
"""The span's course must turn this much for the GLR to fit a scale error too (on a straight it is noise)."""
REFERENCE_LAG_EPOCHS = 120.0
"""Correlation time (fixes) of the learned bias' error in the gate's Monte Carlo."""
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
        self.budget = float(budget_per_test_10h)
        self.gate = None
        """The GLR's gate on max |z|, from Monte Carlo when the test first runs (it needs the drive's speed and the
        fixes' noise)."""
        self.imu_t, self.imu_psi = np.zeros(0), np.zeros(0)
        self._last = None
        self.fix, self.queue = None, []
        self.chords = []
        """(t_mid, length, course, gyro angle at the middle) of the chords at speed since the last restart."""
        self.sign_votes = 0.0
        self.sign = 0.0
        self.ref, self.n_ref = None, 0
        self.refs = []
        """(learned bias rad/s, its sd) after each of the last SPAN_EPOCHS - WINDOW_EPOCHS windows: the GLR takes the
        oldest, learned before the span's last chords (a step is not learned into the bias it is tested against)."""
        self.mad = []
        self.sig = SIGMA_FLOOR_M
        """The fixes' noise sd (m): the robust sd of the recent windows' residuals, floored."""
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
        events = self._process()  # before the trim: a long push must not drop the samples its queued fixes need
        keep = self.imu_t >= self.imu_t[-1] - 30.0
        if (~keep).sum() > len(t):
            self.imu_t, self.imu_psi = self.imu_t[keep], self.imu_psi[keep]
        return events

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
        self.chords = (self.chords + [(0.5 * (tk + last[0]), length, course, psi_mid)])[-SPAN_EPOCHS:]
        if len(self.chords) < WINDOW_EPOCHS or self.sign == 0.0:
            return []
        return self._window(tk)

    def _window(self, tk) -> list:
        """GLS of the summed lateral drift on [1, distance, distance-weighted time, distance-weighted turn (in a
        turn)]."""
        _, tau, length, _, y, turn = self._drift(0.0 if self.ref is None else self.ref, WINDOW_EPOCHS)
        x = self._base(length, turn)
        x = np.column_stack([x[:, :2], np.cumsum(length * tau), x[:, 2:]])
        self.windows += 1
        ci = self._inverse_covariance(length, tau)
        x = separable_columns(x, ci)
        info = np.linalg.pinv(x.T @ ci @ x)
        if not info[2, 2] > 0.0:
            return []
        coef = info @ (x.T @ ci @ y)
        resid = y - x @ coef
        # the fixes' noise from the residual's first differences (the random walk's share there is small)
        self.mad = (self.mad + [float(np.median(np.abs(np.diff(resid)))) / np.sqrt(2)])[-NOISE_WINDOWS:]
        self.sig = max(robust_sd(self.mad, 1.0), SIGMA_FLOOR_M)
        db, sd = float(coef[2]), float(np.sqrt(info[2, 2] + self.bias_sd**2))
        if self.ref is None:
            self.ref = db
            return []
        self.n_ref += 1
        if self.n_ref > WARMUP_EPOCHS - WINDOW_EPOCHS:
            stat, z = self._glr()
            self.trace_t.append(tk)
            self.trace_z.append(z)
            if stat > self._gate():
                event = self._event(tk, z, stat)
                if event != "undecided":
                    return [event] if event is not None else []
                return []
        self.ref += db / min(self.n_ref, REFERENCE_EPOCHS)  # ``heading`` has the learned bias out: db is the change
        # overlapping windows: n of them average ~n + WINDOW_EPOCHS fixes' worth
        learned_sd = float(np.sqrt(info[2, 2] * WINDOW_EPOCHS / (min(self.n_ref, REFERENCE_EPOCHS) + WINDOW_EPOCHS)))
        self.refs = (self.refs + [(self.ref, learned_sd)])[-(SPAN_EPOCHS - WINDOW_EPOCHS):]
        return []

    def _glr(self) -> tuple[float, float]:
        """The GLR's largest |z| over the span's onsets and that z (signed) of a bias step against the learned bias."""
        ref, learned_sd = self.refs[0]
        _, tau, length, _, y, turn = self._drift(ref)
        step, sd = glr(self._inverse_covariance(length, tau, np.hypot(self.bias_sd, learned_sd)),
                       self._base(length, turn), step_columns(tau, length), y)
        z = step / sd
        j = int(np.argmax(np.abs(z)))
        return float(abs(z[j])), float(z[j])

    @staticmethod
    def _base(length, turn):
        """The free columns (n, 2 or 3): a constant, the heading offset (the distance) and, where the span turns by
        SCALE_COLUMN_TURN_RAD, a scale error (the distance-weighted turn of the gyro, the learned bias out: the
        GNSS course's turn carries the chords' noise, which on a straight is the drift itself)."""
        cols = [np.ones(len(length)), np.cumsum(length)]
        if np.ptp(turn) > SCALE_COLUMN_TURN_RAD:
            cols.append(np.cumsum(length * turn))
        return np.column_stack(cols)

    def _gate(self) -> float:
        """The test's gate for this drive's chord length and fixes' noise (Monte Carlo, cached)."""
        if self.gate is None:
            rel = float(np.median(np.array(self.chords)[:, 1])) / self.sig  # rad/s -> fixes' sd per s of a chord
            arw = float(f"{self.arw * rel:.2g}")
            self.gate = glr_gate(self.budget, arw, float(f"{self.bias_sd * rel:.2g}"))
        return self.gate

    def _drift(self, ref, n=None):
        """The last ``n`` (None: all) chords' times (s) and times from the first (s), lengths (m), courses (rad) and
        summed lateral drift (m) against the gyro's heading less the learned bias' drift ``ref`` (rad/s: y's
        slope), and that heading's turn from the first chord (rad)."""
        tm, length, course, psi = np.array(self.chords[-n:] if n else self.chords).T
        tau = tm - tm[0]
        turn = self.sign * (psi - psi[0]) + ref * tau
        y = np.cumsum(length * np.sin(np.angle(np.exp(1j * (course - course[0] - turn)))))
        return tm, tau, length, course, y, turn

    def _inverse_covariance(self, length, tau, ref_sd=0.0):
        """Inverse covariance (1/m^2) of the summed drift: the gyro's white noise makes its heading error a random
        walk W, and the drift sums length_j W(tau_j); plus the fixes' noise from the recent residuals; plus, with
        ``ref_sd`` (rad/s), the learned bias' error (a constant drift rate across the span)."""
        return drift_inverse_covariance(length, tau, self.arw, self.sig, ref_sd)

    @staticmethod
    def _course_turn(course):
        """The GNSS course's turn from the window's start (unwrapped), rad: the scale error's regressor (the gyro's
        own turn would carry the bias' drift too)."""
        return np.unwrap(course) - course[0]

    def _event(self, tk, z, stat) -> Event | str | None:
        """Change point: the step of the heading drift's slope (GLS over the window, each chord as the start). None
        when a step of the gyro's scale (the heading error growing with the course's turn from some chord on) fits
        the window better: a scale change in a turn looks like a bias step to the test, and is the scale-factor
        test's to name (the test restarts either way). "undecided" (no restart) when neither fits better and the
        course turned after the step."""
        tm, tau, length, course, y, _ = self._drift(self.refs[0][0])
        ci = self._inverse_covariance(length, tau)
        turned = self._course_turn(course)
        js = np.arange(2, len(y) - 2)
        after = tau[None, :] >= tau[js, None]
        bias_steps = np.cumsum(length * (tau[None, :] - tau[js, None]) * after, axis=1)
        scale_steps = np.cumsum(length * (turned[None, :] - turned[js, None]) * after, axis=1)
        common = np.broadcast_to(np.column_stack([np.ones(len(y)), np.cumsum(length), np.cumsum(length * turned)]),
                                 (len(js), len(y), 3))
        bias_score, step, info = self._gls_scores(np.concatenate([common[..., :2], bias_steps[..., None],
                                                                  common[..., 2:]], axis=2), ci, y)
        scale_score, _, _ = self._gls_scores(np.concatenate([common, scale_steps[..., None]], axis=2), ci, y)
        k = int(np.argmin(bias_score))
        best = (float(bias_score[k]), int(js[k]), float(step[k]), float(np.sqrt(info[k])))
        best_scale = float(np.min(scale_score))
        if abs(best_scale - best[0]) < SCALE_PREFERENCE and np.ptp(turned[best[1]:]) > UNDECIDED_TURN_RAD:
            return "undecided"
        self.ref, self.n_ref, self.chords, self.refs = None, 0, [], []
        if best_scale < best[0] - SCALE_PREFERENCE:
            return None
        _, j, step, sd = best
        step *= -self.sign  # the heading drift's slope is minus the bias (in gz's sign)
        return bias_shift_event(tk, float(tm[j]), "gz", step, sd,
                                f"gz mean stepped by {step:.3g} rad/s (against the GNSS track, {abs(z):.1f} sd)",
                                {"z": float(z), "glr": float(stat), "gate": self._gate()})

    @staticmethod
    def _gls_scores(x, ci, y):
        """GLS of y (n,) on each design x (J, n, p) (inverse covariance ci): the chi-square of the residual (J,), the
        3rd coefficient (J,) and its variance (J,). pinv as the window's: a degenerate design must not crash the
        node."""
        xtc = np.swapaxes(x, 1, 2) @ ci
        info = np.linalg.pinv(xtc @ x)
        coef = info @ (xtc @ y)[..., None]
        r = y - (x @ coef)[..., 0]
        return np.einsum("jn,nm,jm->j", r, ci, r), coef[:, 2, 0], info[:, 2, 2]

    def observability(self) -> str:
        """Whether this record made a gz bias step observable against the GNSS track, in words."""
        if self.fixes == 0:
            return f"{NOT_OBSERVABLE}: no GNSS fixes"
        if self.sign == 0.0:
            return f"{NOT_OBSERVABLE}: no turns at speed yet (the sign of gz against the course is unknown)"
        if self.windows == 0:
            return f"{NOT_OBSERVABLE}: no {WINDOW_EPOCHS} successive fixes at {V_MIN_M_S:g} m/s or more"
        return f"observable: {self.windows} windows of {WINDOW_EPOCHS} fixes at speed"


def drift_inverse_covariance(length, tau, arw, sig, ref_sd=0.0) -> np.ndarray:
    """Inverse covariance (1/m^2) of the summed lateral drift over chords of ``length`` (m) at ``tau`` (s): the
    heading's random walk (``arw`` rad/sqrt(s)) summed along the chords, the fixes' white noise ``sig`` (m) and a
    constant drift rate of sd ``ref_sd`` (rad/s: the learned bias' error)."""
    # L M L^T with L the length-weighted lower-triangular sum, as two cumulative sums (O(n^2))
    walk = np.cumsum(np.cumsum(length[:, None] * np.minimum.outer(tau, tau), axis=0) * length, axis=1)
    u = np.cumsum(length * tau)
    cov = arw**2 * walk + sig**2 * np.eye(len(tau)) + ref_sd**2 * np.outer(u, u)
    return np.linalg.inv(cov)


def step_columns(tau, length) -> np.ndarray:
    """The summed drift (m per rad/s) of a bias step at each chord from the 3rd to the MIN_AFTER_EPOCHS-th last."""
    js = np.arange(2, len(tau) - MIN_AFTER_EPOCHS)
    return np.cumsum(length * np.maximum(tau[None, :] - tau[js, None], 0.0), axis=1)


def separable_columns(x, ci, max_condition: float = 1e10):
    """The design ``x`` (n, 3 or 4) without its scale column (the 4th) where that column and the drift's
    time column cannot be told apart (a turn at one rate through the whole window: a scale error there is a bias)."""
    if x.shape[1] < 4:
        return x
    normal = x.T @ ci @ x
    d = np.sqrt(np.maximum(np.diag(normal), 1e-300))
    if np.linalg.cond(normal / np.outer(d, d)) > max_condition:
        return x[:, :3]
    return x


def glr(ci, base, steps, y) -> tuple[np.ndarray, np.ndarray]:
    """GLS coefficient (..., m) and its sd (m,) of each step column (rows of ``steps`` (m, n)) of y (..., n) with the
    ``base`` (n, p) columns free (inverse covariance ``ci`` (n, n))."""
    cb = ci @ base
    rs = steps @ (ci - cb @ np.linalg.pinv(base.T @ cb) @ cb.T)
    info = np.maximum(np.einsum("jn,jn->j", rs, steps), 1e-300)
    return (y @ rs.T) / info, 1.0 / np.sqrt(info)


def simulated_drifts(epochs: int, arw_rel: float, ref_sd_rel: float, rng) -> np.ndarray:
    """Summed lateral drifts (epochs, SPAN_EPOCHS) of the spans ending at successive fixes on a straight at constant
    speed, on the model's noise alone (1-s chords; units of the chord length and the fixes' noise sd: the heading's
    random walk ``arw_rel`` = arw length / sig per sqrt(s), the learned bias' error ``ref_sd_rel`` = its sd length /
    sig per s, slow: AR(1) over REFERENCE_LAG_EPOCHS)."""
    n = SPAN_EPOCHS
    total = epochs + n
    fix = rng.normal(size=total + 1)
    course_err = np.diff(fix)  # a chord's sideways error: its end fixes' difference over its length (1)
    heading_err = np.cumsum(arw_rel * rng.normal(size=total))
    a = np.exp(-1.0 / REFERENCE_LAG_EPOCHS)
    e = rng.normal(size=epochs) * ref_sd_rel * np.sqrt(1 - a * a)
    e[0] = ref_sd_rel * rng.normal()  # the stationary start
    ref_err = lfilter([1.0], [1.0, -a], e)
    d = np.lib.stride_tricks.sliding_window_view(course_err - heading_err, n)[:epochs]
    return np.cumsum(d - d[:, :1] - ref_err[:, None] * np.arange(n), axis=1)


def straight_glr_z(y, arw_rel: float, ref_sd_rel: float) -> np.ndarray:
    """The GLR's z (epochs, m) of each step on simulated drifts ``y`` (epochs, SPAN_EPOCHS) (straight, 1-s chords)."""
    n = y.shape[-1]
    tau, length = np.arange(n, dtype=float), np.ones(n)
    step, sd = glr(drift_inverse_covariance(length, tau, arw_rel, 1.0, ref_sd_rel),
                   np.column_stack([np.ones(n), np.cumsum(length)]), step_columns(tau, length), y)
    return step / sd


@functools.lru_cache(maxsize=32)
def glr_gate(budget_per_test_10h: float, arw_rel: float, ref_sd_rel: float, epochs: int = 20000,
             seed: int = 0) -> float:
    """Gate on the GLR's max |z| for ``budget_per_test_10h`` false events per 10 h at one test per 1-s fix: Monte
    Carlo through the same span on :func:`simulated_drifts` (exponential tail)."""
    z = straight_glr_z(simulated_drifts(epochs, arw_rel, ref_sd_rel, np.random.default_rng(seed)), arw_rel,
                       ref_sd_rel)
    return thr.exp_tail_threshold(np.abs(z).max(axis=1), budget_per_test_10h / thr.SECONDS_PER_10H)
