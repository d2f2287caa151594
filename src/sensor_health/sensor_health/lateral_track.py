"""The lateral accelerometer on the straights of a drive: ``bias_shift`` on ay while the GNSS says the vehicle moves.

A land vehicle's ay is its lateral acceleration (the speed times the yaw rate) plus gravity through its roll; on a
straight at speed both are nil, so ay's 1-s mean is its bias plus its white noise (0.002 m/s^2 for a MEMS unit,
a tenth of a 10x bias-sd step). In turns the motion is hundreds of times the step, and ay - v gz (the speed from
the GNSS) would carry gz's own bias times v (a 2e-3 rad/s gz step moves it by 0.03 m/s^2 at 15 m/s, more than the
ay step): so the test uses the straights only, where it needs neither gz's bias nor a model of the body's roll.

A 1-s block is a straight where gz's mean in it and in the blocks either side stays within ``STRAIGHT_SD`` of its
sd of gz's level on straights (so a turn's first and last fraction of a second is not one), and at speed where a
GNSS chord across it is faster than ``V_MIN_M_S`` (standing still the unit may be tilted by a hand or a knock).
The test: the mean of the last ``TEST_BLOCKS`` straight blocks against the level learned on the earlier straights
(an exponential average over ``REFERENCE_BLOCKS``, which lags the bias' wander), standardised by the robust sd of
that difference on this drive (floored at the model's white noise and bias instability: the road's own camber and
the wander are measured, not assumed). Its gate on |z| comes from Monte Carlo on white noise through the same
statistic, for the test's share of the budget (one test per straight second).

Assumes y is the body's lateral axis and z vertical, a road without changes of camber on its straights (a camber
change of 0.1 degree is 0.017 m/s^2 on ay: a bias to this test). No ROS, no simulator. Times s, m/s^2, rad/s.
"""
from __future__ import annotations

import functools

import numpy as np
from scipy.signal import lfilter

from sensor_health import thresholds as thr
from sensor_health.along_track import chord_en
from sensor_health.events import Event, bias_shift_event

TEST_BLOCKS = 3
REFERENCE_BLOCKS = 60.0
"""Time constant of the learned level, in straight blocks."""
WARMUP_BLOCKS = 120
"""Straight blocks before the test starts (the level and the drive's own sd need them)."""
SD_BLOCKS = 600
"""The test's sd is the robust sd of its numerator over this many recent straight blocks."""
SPAN_BLOCKS = 120
"""Straight blocks kept for the change point."""
STRAIGHT_SD = 4.0
V_MIN_M_S = 3.0
MAX_FIX_GAP_S = 2.5
NOT_OBSERVABLE = "not observable on this record"


@functools.lru_cache(maxsize=8)
def z_gate(budget_per_test_10h: float, blocks: int = 30000, seed: int = 0) -> float:
    """|z| gate for ``budget_per_test_10h`` false events per 10 h at one test per straight second: Monte Carlo on
    white 1-s means through the same learned level, test mean and robust sd (exponential tail)."""
    r = np.random.default_rng(seed).normal(size=blocks)
    a = 1.0 / REFERENCE_BLOCKS
    # the level learned up to the block before the test's: ref[k] = (1 - a) ref[k-1] + a r[k-1], ref[0] = r[0]
    ref = np.r_[r[0], lfilter([a], [1.0, -(1.0 - a)], r[:-1], zi=[(1.0 - a) * r[0]])[0]]
    m = np.convolve(r, np.ones(TEST_BLOCKS) / TEST_BLOCKS, "valid")
    dev = m - ref[:len(m)]  # the level before the test's first block
    every = 20  # the robust sd moves slowly: taken every 20 blocks, as cheap as the test's own
    run = np.lib.stride_tricks.sliding_window_view(np.abs(dev), SD_BLOCKS)[::every]
    sd = np.repeat(1.4826 * np.median(run, axis=1), every)[:len(dev) - SD_BLOCKS + 1]
    z = np.abs(dev[SD_BLOCKS - 1:]) / np.maximum(sd, np.sqrt(1.0 / TEST_BLOCKS))
    return thr.exp_tail_threshold(z, budget_per_test_10h / thr.SECONDS_PER_10H)


class LateralTrackMonitor:
    """Streaming: :meth:`push_imu` gz and ay samples, :meth:`push_gnss` fixes; both return the events they complete."""

    def __init__(self, ay_white: float, gz_white: float, ay_bias_sd: float, budget_per_test_10h: float):
        """The model's white noise of ay (m/s^2/sqrt(Hz)) and gz (rad/s/sqrt(Hz)), ay's bias instability (m/s^2)."""
        self.gate = z_gate(budget_per_test_10h)
        self.sd_floor = float(np.hypot(ay_white / np.sqrt(TEST_BLOCKS), ay_bias_sd))
        self.gz_gate = STRAIGHT_SD * float(gz_white)
        self.acc = None
        """The block being summed: [second, n, sum gz, sum ay]."""
        self.blocks = []
        """Finished 1-s blocks not yet tested: (start s, gz mean, ay mean)."""
        self.chords = []
        """(t0, t1, speed m/s) of the recent GNSS chords."""
        self.fix = None
        self.gz_level, self.gz_recent = 0.0, []
        self.straight = []
        """(start s, ay mean) of the straight blocks at speed since the last restart."""
        self.ref, self.refs, self.n_ref, self.devs = None, [], 0, []
        self.tested = 0
        self.trace_t, self.trace_z = [], []

    def push_imu(self, t, gz, ay) -> list:
        """gz (rad/s) and ay (m/s^2) samples at t (m,) s -> events of the blocks they complete."""
        sec = np.floor(np.asarray(t, float))
        gz, ay = np.asarray(gz, float), np.asarray(ay, float)
        cuts = np.flatnonzero(np.diff(sec)) + 1
        for s, g, a in zip(np.split(sec, cuts), np.split(gz, cuts), np.split(ay, cuts)):
            if not len(s):
                continue
            if self.acc is not None and s[0] != self.acc[0]:
                self._close()
            if self.acc is None:
                self.acc = [s[0], 0, 0.0, 0.0]
            self.acc[1] += len(s)
            self.acc[2] += float(np.sum(g))
            self.acc[3] += float(np.sum(a))
        return self._process()

    def push_gnss(self, t, lat_rad, lon_rad) -> list:
        """Fixes t (m,) s, lat, lon (m,) rad -> events completed."""
        for tk, la, lo in zip(np.atleast_1d(t), np.atleast_1d(lat_rad), np.atleast_1d(lon_rad)):
            if not (np.isfinite(la) and np.isfinite(lo)):
                continue
            last, self.fix = self.fix, (float(tk), float(la), float(lo))
            if last is not None and 0.0 < tk - last[0] <= MAX_FIX_GAP_S:
                speed = float(np.hypot(*chord_en(last[1], last[2], la, lo))) / (tk - last[0])
                self.chords.append((last[0], float(tk), speed))
        return self._process()

    def _close(self):
        s, n, sg, sa = self.acc
        self.acc = None
        if n and np.isfinite(sg) and np.isfinite(sa):
            self.blocks.append((s, sg / n, sa / n))
        else:
            self.blocks.append((s, np.nan, np.nan))

    def _process(self) -> list:
        """Test the blocks whose neighbours are done and whose speed a chord gives."""
        events = []
        while len(self.blocks) >= 3:
            (s0, g0, _), (s1, g1, a1), (s2, g2, _) = self.blocks[:3]
            fix_t = self.fix[0] if self.fix else -np.inf
            if fix_t < s1 + 1.0 and len(self.blocks) < 30:
                break  # wait for the chord across the block
            self.blocks.pop(0)
            events += self._block(s1, (g0, g1, g2), a1, s2 - s0 == 2.0)
        return events

    def _block(self, s, gz3, ay, contiguous) -> list:
        if abs(gz3[1] - self.gz_level) < 5 * self.gz_gate:  # gz's level on straights (its bias), slowly
            self.gz_recent = (self.gz_recent + [gz3[1]])[-120:]
            self.gz_level = float(np.median(self.gz_recent))
        while self.chords and self.chords[0][1] < s:
            self.chords.pop(0)  # chords end before this block: the blocks come in time order
        moving = any(c0 <= s + 0.5 <= c1 and v >= V_MIN_M_S for c0, c1, v in self.chords[:4])
        straight = contiguous and all(abs(g - self.gz_level) < self.gz_gate for g in gz3)
        if not (moving and straight and np.isfinite(ay)):
            return []
        self.straight = (self.straight + [(s, ay)])[-SPAN_BLOCKS:]
        if self.ref is None:
            self.ref, self.refs = ay, [ay]
            return []
        if len(self.refs) >= TEST_BLOCKS:
            # the test's mean against the level learned up to the block before its first (not learned into it)
            dev = float(np.mean([b[1] for b in self.straight[-TEST_BLOCKS:]])) - self.refs[-TEST_BLOCKS]
            self.devs = (self.devs + [dev])[-SD_BLOCKS:]
            self.n_ref += 1
            if self.n_ref > WARMUP_BLOCKS:
                sd = max(1.4826 * float(np.median(np.abs(self.devs))), self.sd_floor)
                z = dev / sd
                self.tested += 1
                self.trace_t.append(s + 1.0)
                self.trace_z.append(z)
                if abs(z) > self.gate:
                    return [self._event(s + 2.0, z, sd)]
        self.ref += (ay - self.ref) / min(len(self.straight), REFERENCE_BLOCKS)
        self.refs = (self.refs + [self.ref])[-TEST_BLOCKS:]
        return []

    def _event(self, tk, z, sd) -> Event:
        """Change point: among the last straights (the test's mean held the step, or it would have fired before),
        the start of the run whose mean departs most from the level learned before them (maximum likelihood)."""
        s, a = np.array(self.straight).T
        level = self.refs[0]
        n = len(a)
        j = np.arange(max(1, n - 2 * TEST_BLOCKS), n)
        tail = np.cumsum((a - level)[::-1])[::-1][j]
        best = int(j[np.argmax(tail**2 / (n - j))])
        step = float(a[best:].mean() - level)
        sd_step = sd * np.sqrt(TEST_BLOCKS / (n - best))
        # a step in a turn is somewhere between the straights either side of it
        onset = float(s[best]) if s[best] - s[best - 1] <= 1.0 else 0.5 * (s[best - 1] + 1.0 + s[best])
        self.ref, self.refs, self.n_ref, self.straight, self.devs = None, [], 0, [], []
        return bias_shift_event(tk, onset, "ay", step, sd_step,
                                f"ay mean stepped by {step:.3g} m/s^2 (on the straights at speed, {abs(z):.1f} sd)",
                                {"z": float(z), "gate": self.gate})

    def observability(self) -> str:
        """Whether this record made an ay bias step observable (straights at speed with GNSS), in words."""
        if not self.chords:
            return f"{NOT_OBSERVABLE}: no GNSS fixes (the speed)"
        if self.tested == 0:
            return f"{NOT_OBSERVABLE}: no {WARMUP_BLOCKS} s of straights at {V_MIN_M_S:g} m/s or more"
        return f"observable: {self.tested} straight seconds at speed tested"
