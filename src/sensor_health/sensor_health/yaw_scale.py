"""The yaw gyro's scale factor against the GNSS course: ``scale_factor_change`` on gz, where turns make it observable.

Over a segment of about ``SEGMENT_S`` s between two GNSS velocity epochs (course and speed from successive fixes,
speed above ``V_MIN_M_S``), the integral of gz equals ``a`` times the course change ``u`` plus the bias times the
duration: ``a`` is -1 for a z-up unit (course is clockwise), +1 for z-down, times the unit's own scale factor and
the mount's tilt; it is learned in a warm-up that needs turns (``WARMUP_TURN_RAD2`` of summed squared course
change). A scale change ``delta`` adds ``delta a u`` to the residual: nothing on a straight, most in a hard turn.
The test is a two-sided CUSUM of the log-likelihood ratio for a design change of ``DESIGN_STEP``: a straight adds
no evidence either way, so the statistic waits for the next turn. The residual's variance is the course noise
(GNSS velocity sd / speed at both ends, estimated robustly from the record's own residuals, the MAD of the
last SIGMA_SEGMENTS segments) plus a ``REL_MODEL_ERROR`` of the turn (body roll, sideslip). Its threshold comes
from Monte Carlo when the warm-up ends (:func:`llr_threshold`: the record's own information per segment, the
monitor's own errors in the noise sd and the ratio), at the package's false-alarm budget per test.

No ROS, no simulator. Angles rad, rates rad/s, speeds m/s, times s.
"""
from __future__ import annotations

import numpy as np

from nav_core.earth import radii
from sensor_health import thresholds as thr
from sensor_health.events import Z95, Event

SEGMENT_S = 10.0
STRAIGHT_EPOCH_RAD = 0.03
"""Course change between two velocity epochs below which the vehicle is on a straight (a segment may end)."""
MAX_SEGMENT_S = 60.0
V_MIN_M_S = 3.0
"""Below this speed the course from two fixes is noise."""
MAX_FIX_GAP_S = 2.5
WARMUP_TURN_RAD2 = 4.0
"""Summed squared course change (rad^2) before ``a`` is trusted: about two 90-degree turns."""
WARMUP_SEGMENTS = 20
WARMUP_RATIO_SD = 0.2 * 0.01
"""The warm-up lasts until the yaw ratio's sd is this fraction of it (a fifth of DESIGN_STEP)."""
STRAIGHT_RAD = 0.1
"""A segment turning less than this is a straight: it updates the bias and the noise, not the scale."""
DESIGN_STEP = 0.01
"""The CUSUM is tuned to a 1 % scale change."""
REL_MODEL_ERROR = 0.003
"""Relative error of yaw = course over a turn (cos of the body roll, sideslip), as extra sd."""
SIGMA_VEL_FLOOR_M_S = 0.005
SIGMA_SEGMENTS = 60
"""The course noise is the MAD of the last this many segments' residuals (turns too: a scale change only raises
it, which makes the test slower, not falsely alarmed)."""
HISTORY_SEGMENTS = 120
NOT_OBSERVABLE = "not observable on this record"


def llr_threshold(w2: np.ndarray, ratio_sd: float, target_segments: float, records: int = 100,
                  segments: int = 400, seed: int = 0) -> float:
    """CUSUM threshold on the LLR for a DESIGN_STEP change whose run length on healthy records reaches
    ``target_segments`` (one side), by Monte Carlo with run lengths measured. The segments' information ``w2``
    (the design step's squared signal-to-noise) is drawn from this record's own warm-up, and each simulated record
    carries the monitor's own estimation errors for the whole record: its noise sd from the MAD of SIGMA_SEGMENTS
    residuals, its yaw ratio off by ``ratio_sd`` (relative sd of the learned ratio)."""
    rng = np.random.default_rng(seed)
    w = np.sqrt(rng.choice(np.asarray(w2, float), size=(segments, records)))
    f = 1.4826 * np.median(np.abs(rng.normal(size=(SIGMA_SEGMENTS, records))), axis=0)
    ratio_err = rng.normal(0.0, ratio_sd / DESIGN_STEP, records)
    z = (rng.normal(size=(segments, records)) + w * ratio_err) / f
    llr = np.hstack([w * z - w**2 / 2, -w * z - w**2 / 2])
    return float(thr.cusum_threshold(llr, 0.0, target_segments))


class YawScaleMonitor:
    """Streaming: :meth:`push_gnss` fixes, :meth:`push_imu` gz samples; both return the events they complete."""

    def __init__(self, model, budget_per_test_10h: float):
        self.arw = float(model.gyro.white_noise[2])
        self.bias_sd = float(model.gyro.bias_instability[2])
        """The bias wanders by about this (rad/s) between the straights that update it."""
        self.target_segments = thr.SECONDS_PER_10H / SEGMENT_S / budget_per_test_10h / 2
        self.h = np.inf
        """Set when the warm-up ends, from this record's own information per segment (Monte Carlo)."""
        self.fix = None
        self.prev, self.prev_change = None, np.inf
        """(mid time, course, speed) of the last velocity epoch."""
        self.anchor = None
        self.u_acc = 0.0
        self.queue = []
        self.imu_t, self.imu_cum = np.zeros(0), np.zeros(0)
        self._last_gz = 0.0
        self.warm = []
        self.a = self.b = self.sigma_vel = None
        self.resid = []
        self.pos = self.neg = 0.0
        self.start = [None, None]
        self.hist = []
        self.segments = 0
        self.turn_rad2 = 0.0
        self.fixes = 0
        self.trace_t, self.trace_cusum = [], []

    # ------------------------------------------------------------------ input

    def push_gnss(self, t, lat_rad, lon_rad) -> list:
        """Fixes t (m,) s, lat, lon (m,) rad -> events completed."""
        for tk, la, lo in zip(np.atleast_1d(t), np.atleast_1d(lat_rad), np.atleast_1d(lon_rad)):
            if np.isfinite(la) and np.isfinite(lo):
                self._fix(float(tk), float(la), float(lo))
        return self._process()

    def push_imu(self, t, gz) -> list:
        """gz samples (m,) rad/s at t (m,) s -> events completed (segments the IMU now covers)."""
        t = np.asarray(t, float)
        gz = np.asarray(gz, float)
        if len(t) == 0:
            return []
        t0 = self.imu_t[-1] if len(self.imu_t) else t[0]
        g0 = self._last_gz if len(self.imu_t) else gz[0]
        tt, gg = np.r_[t0, t], np.r_[g0, gz]
        inc = 0.5 * (gg[1:] + gg[:-1]) * np.diff(tt)  # non-finite samples make the integral NaN: segment skipped
        base = self.imu_cum[-1] if len(self.imu_cum) else 0.0
        cum = base + np.cumsum(inc)
        self.imu_t, self.imu_cum = np.r_[self.imu_t, t], np.r_[self.imu_cum, cum]
        self._last_gz = gz[-1]
        events = self._process()  # before the trim: a long push must not drop the samples its queued fixes need
        keep = self.imu_t >= self.imu_t[-1] - 6 * SEGMENT_S - 60.0
        if (~keep).sum() > len(t):
            self.imu_t, self.imu_cum = self.imu_t[keep], self.imu_cum[keep]
        return events

    def _fix(self, t, lat, lon):
        self.fixes += 1
        last, self.fix = self.fix, (t, lat, lon)
        if last is None or t <= last[0]:
            return
        dt = t - last[0]
        rn, re = radii(lat)
        vn, ve = (lat - last[1]) * rn / dt, (lon - last[2]) * re * np.cos(lat) / dt
        speed, course, mid = float(np.hypot(vn, ve)), float(np.arctan2(ve, vn)), 0.5 * (t + last[0])
        if dt > MAX_FIX_GAP_S or speed < V_MIN_M_S:
            self.anchor, self.prev = None, None
            return
        if self.anchor is None:
            self.anchor, self.u_acc, self.prev = (mid, speed), 0.0, (mid, course, speed)
            self.prev_change = np.inf
            return
        change = float(np.angle(np.exp(1j * (course - self.prev[1]))))
        straight = abs(change) < STRAIGHT_EPOCH_RAD and abs(self.prev_change) < STRAIGHT_EPOCH_RAD
        self.u_acc += change
        self.prev, self.prev_change = (mid, course, speed), change
        # a segment ends on a straight (two epochs without a turn): there the chord's course is the heading at the
        # interval's middle (in a turn it is not, by up to half the interval's turn when the turn starts inside it)
        span = mid - self.anchor[0]
        if span >= SEGMENT_S - 1e-9 and (straight or span >= MAX_SEGMENT_S):
            self.queue.append((self.anchor[0], mid, self.u_acc, self.anchor[1], speed, t))
            self.anchor, self.u_acc = (mid, speed), 0.0

    # ------------------------------------------------------------------ segments

    def _process(self) -> list:
        events = []
        while self.queue and len(self.imu_t) and self.imu_t[-1] >= self.queue[0][1]:
            ma, mb, u, va, vb, t_fix = self.queue.pop(0)
            if self.imu_t[0] > ma:
                continue
            y = float(np.diff(np.interp([ma, mb], self.imu_t, self.imu_cum))[0])
            if np.isfinite(y):
                events += self._segment(ma, mb, u, va, vb, y, t_fix)
        return events

    def _noise_var(self, T, u, va, vb):
        course = self.sigma_vel**2 * (1 / va**2 + 1 / vb**2)
        return course + self.arw**2 * T + (self.bias_sd * T) ** 2 + (REL_MODEL_ERROR * u) ** 2

    def _segment(self, ma, mb, u, va, vb, y, t_fix) -> list:
        self.segments += 1
        T = mb - ma
        if self.a is None:
            self.warm.append((u, T, y, va, vb))
            self.turn_rad2 += u * u
            if len(self.warm) >= WARMUP_SEGMENTS and self.turn_rad2 >= WARMUP_TURN_RAD2 \
                    and len(self.warm) % 5 == 0:
                self._learn()
            return []
        self.turn_rad2 += u * u
        r = y - self.a * u - self.b * T
        s = self._noise_var(T, u, va, vb)
        if abs(u) < STRAIGHT_RAD:
            self.b += 0.05 * r / T
        self.resid = (self.resid + [r / np.sqrt(1 / va**2 + 1 / vb**2)])[-SIGMA_SEGMENTS:]
        self.sigma_vel = max(1.4826 * float(np.median(np.abs(self.resid))), SIGMA_VEL_FLOOR_M_S)
        x = self.a * u
        w = DESIGN_STEP * x / np.sqrt(s)
        zr = r / np.sqrt(s)
        pos = max(0.0, self.pos + w * zr - w * w / 2)
        neg = max(0.0, self.neg - w * zr - w * w / 2)
        if self.pos == 0 and pos > 0:
            self.start[0] = ma
        if self.neg == 0 and neg > 0:
            self.start[1] = ma
        self.pos, self.neg = pos, neg
        self.hist.append((ma, mb, x, r, s))
        self.hist = self.hist[-HISTORY_SEGMENTS:]
        self.trace_t.append(t_fix)
        self.trace_cusum.append(max(pos, neg))
        if max(pos, neg) <= self.h:
            return []
        return [self._event(t_fix, max(pos, neg))]

    def _learn(self):
        """Yaw ratio and bias by weighted least squares over the warm-up, once the ratio is known to
        WARMUP_RATIO_SD of itself (a wrong ratio looks like a scale change to the CUSUM); else keep collecting."""
        u, T, y, va, vb = np.array(self.warm).T
        A = np.column_stack([u, T])
        ab, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ ab
        self.resid = list((r / np.sqrt(1 / va**2 + 1 / vb**2))[-SIGMA_SEGMENTS:])
        self.sigma_vel = max(1.4826 * float(np.median(np.abs(self.resid))), SIGMA_VEL_FLOOR_M_S)
        w = 1.0 / self._noise_var(T, u, va, vb)
        cov = np.linalg.inv(A.T @ (A * w[:, None]))
        ab = cov @ (A.T @ (w * y))
        if np.sqrt(cov[0, 0]) > WARMUP_RATIO_SD * abs(ab[0]):
            self.sigma_vel = None
            return
        self.a, self.b = float(ab[0]), float(ab[1])
        w2 = (DESIGN_STEP * self.a * u) ** 2 * w
        self.h = llr_threshold(w2, float(np.sqrt(cov[0, 0])) / abs(self.a), self.target_segments)
        self.warm = []

    def _event(self, t_fix, cusum) -> Event:
        """Change point (maximum GLR over the stored segments), the relative scale change and its 95 % interval."""
        ma, mb, x, r, s = np.array(self.hist).T
        num = np.cumsum((x * r / s)[::-1])[::-1]
        info = np.cumsum((x * x / s)[::-1])[::-1]
        glr = num**2 / np.maximum(info, 1e-300)
        j = int(np.argmax(glr))
        delta, sd = float(num[j] / info[j]), float(1 / np.sqrt(info[j]))
        self.a *= 1 + delta
        self.pos = self.neg = 0.0
        self.hist = []
        return Event(t_fix, float(ma[j]), "scale_factor_change", ["gz"], "WARN", delta,
                     [delta - Z95 * sd, delta + Z95 * sd],
                     f"gz scale factor changed by {100 * delta:+.2f} % (yaw against the GNSS course in turns)",
                     {"cusum": float(cusum), "threshold": self.h})

    def observability(self) -> str:
        """Whether this record's motion made the scale factor observable, in words."""
        if self.fixes == 0:
            return f"{NOT_OBSERVABLE}: no GNSS fixes"
        if self.a is None:
            return (f"{NOT_OBSERVABLE}: {self.segments} GNSS segments at speed turned {self.turn_rad2:.2f} rad^2 "
                    f"(needs at least {WARMUP_TURN_RAD2:g} rad^2 over {WARMUP_SEGMENTS} segments, and enough to "
                    f"know the yaw ratio to {100 * WARMUP_RATIO_SD:g} %)")
        return (f"observable: yaw ratio {self.a:.5f} learned, {self.segments} segments of {SEGMENT_S:g} s, "
                f"GNSS velocity noise {self.sigma_vel:.3f} m/s")
