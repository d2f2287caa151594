"""Driver core without ROS: decode bytes, stamp frames by their counter, turn increments into rates."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from imu_driver.bp3010_codec import DEFAULT_FORMAT, FrameBatch, FrameFormat, StreamDecoder


def hull_slope(u, y) -> float:
    """Slope of the line under all points ``(u, y)`` (u increasing) that lies closest to them on average.

    The lower convex hull's edge above the points' mean ``u`` (Moon, Skelly and Towsley's linear
    program for one-way delays); 0 for fewer than two points.
    """
    hull = []
    for p in zip(u, y):
        if hull and p[0] == hull[-1][0]:  # same u: only the lower point can be on the lower hull
            if p[1] >= hull[-1][1]:
                continue
            hull.pop()
        while len(hull) >= 2 and ((hull[-1][0] - hull[-2][0]) * (p[1] - hull[-2][1])
                                  - (hull[-1][1] - hull[-2][1]) * (p[0] - hull[-2][0])) <= 0:
            hull.pop()
        hull.append(p)
    if len(hull) < 2:
        return 0.0
    mean = float(np.mean(u))
    for (u0, y0), (u1, y1) in zip(hull, hull[1:]):
        if u1 >= mean:
            return (y1 - y0) / (u1 - u0)
    return (hull[-1][1] - hull[-2][1]) / (hull[-1][0] - hull[-2][0])


FORWARD_SLEW = 0.25
"""Within an anchor a stamp is at most this many periods later than one period after the last, while a rising offset
is caught up: 1.25 periods stay under WMRA's ``gap_factor`` (1.5) and round to one period in the report's count."""


@dataclass
class FrameClock:
    """Counter -> host time for frames whose reads can only be late, never early; stamps never go back.

    Model: frame n is read at host time ``h = t0 + n P (1 + e) + d`` with an unknown delay
    ``d >= 0`` (scheduling, serial buffering) and drift ``|e| <= max_drift``. With
    ``u = n P`` and the offset ``y = h - u``, every read bounds the true offset from above.
    The window (``window_s``, in ten blocks) keeps each block's most prompt read; the drift
    ``e_hat`` is the slope of the lower convex hull of those points (the edge above their
    mean time: the line under all points closest to them, as in TICSync and Moon et al.'s
    linear program), clipped to ``max_drift``; the offset at ``u`` is
    ``min_i (y_i + e_hat (u - u_i))`` over the kept reads. So only the luckiest read's delay
    enters the stamps, not the scheduling delay of each read: the error is at most the
    smallest delay in the window plus ``|e_hat - e|`` times its age.

    Stamps are ``u + offset``, strictly increasing: when a prompter read lowers the offset by
    more than the next period, stamps advance by ``(1 - slew)`` periods per frame until they
    meet the model again, instead of stepping back; when the offset rises (an early read leaves the window), they
    advance at most ``(1 + FORWARD_SLEW)`` periods per frame, so no gap appears where no frame was lost. A counter
    gap keeps the offset when its
    length (modulo the counter's wrap) can be told from host time; otherwise, and after a
    reconnect, the clock re-anchors on host time, forward only.

    After each anchor the frames of the first ``settle_s`` of host time are held and then stamped
    together on the offset of the most prompt read among them, so the stamps are one period apart
    from the first frame: the first reads at start-up are often a burst of frames that waited
    (a writer or port catching up, a reader not yet scheduled), and an offset taken from them
    alone was up to 95 ms late, slewed back at half a period per frame over the next 12 frames
    (a false sample-rate change and dropout at start-up in sensor_health).
    """

    period_s: float
    max_drift: float = 2e-4
    window_s: float = 10.0
    slew: float = 0.5
    modulo: int = 256
    settle_s: float = 0.5
    reanchors: int = 0
    gaps_bridged: int = 0
    slewed_frames: int = 0
    retime: object = None
    """Optional ``key_s -> host time now known (s), or None``: at each block's end the window's reads are re-timed
    through it (simulated time: the ``/clock`` line a read was timed on improves as deliveries come)."""

    def __post_init__(self):
        self._block_s = self.window_s / 10.0
        self._last_stamp = None
        self._held = []  # device frame indices (arrays) of the reads since the anchor, not stamped while settling
        self._released = np.zeros(0)  # stamps of held frames a reset gave out; the next stamp() returns them first
        self.reset()
        self.ahead_s = 0.0
        """How far the last stamp is ahead of the model (still slewing back), s; negative while a rising offset is
        caught up (:data:`FORWARD_SLEW`)."""

    def reset(self) -> None:
        """Forget counter and offsets (a reconnect or a rate change); stamps still only go forward.

        Frames still held for the settling are stamped first, on the offset seen so far."""
        if self._held:
            self._released = np.concatenate([self._released, self._release()])
        self._settle_until = None  # host time (s) at which the frames held since the anchor are stamped
        self._last_counter = None
        self._x = 0  # frames since the anchor
        self._blocks = deque()  # (block index, u, y, key) of each finished block's most prompt read, in the window
        self._block = None
        self._best = (0.0, np.inf, None)  # (u, y, key) of the current block's most prompt read
        self._z_blocks = np.inf  # min of y - drift * u over the finished blocks
        self.drift = 0.0
        """Estimated drift e_hat of the unit's clock against the host's (dimensionless)."""
        self._prev_x = None
        self.delay_s = 0.0
        """Host time of the last read minus the model stamp of its last frame: that read's delay, s."""

    def offset_s(self, u: float) -> float:
        """Estimated host-minus-device offset at device time ``u`` (s since the anchor)."""
        e = self.drift
        return min(self._z_blocks, self._best[1] - e * self._best[0]) + e * u

    @property
    def held_frames(self) -> int:
        """Frames read since the anchor and not stamped yet (the settling)."""
        return sum(len(x) for x in self._held)

    def stamp(self, counters, host_time_s: float, key_s: float | None = None) -> np.ndarray:
        """Stamps in s of the frames with ``counters`` (n,) that one read returned at ``host_time_s``, after those of
        the frames held before them: none while the clock settles after an anchor, then all the held ones at once.

        A read of no frames (``counters`` empty) ends the settling when its time has come. ``key_s`` (the read's
        wall time, s) lets :attr:`retime` time the read again later."""
        if len(counters) == 0:
            if self._held and host_time_s >= self._settle_until:
                return self._with_released(self._release())
            return self._with_released(np.zeros(0))
        x, gap = self._unwrap(counters)
        if self._last_counter is not None and gap is not None:
            self._bridge_or_reanchor(x, gap, host_time_s)
        if self._block is None:
            self.reanchors += self._last_stamp is not None
            x = x - x[0]  # a new anchor: device time counts from the first frame of this read
            self._settle_until = host_time_s + self.settle_s if self.settle_s > 0 else -np.inf
        u_last = x[-1] * self.period_s
        self._observe(u_last, host_time_s - u_last, key_s)
        self._x, self._last_counter = int(x[-1]), int(counters[-1])
        offset = self.offset_s(u_last)
        self.delay_s = host_time_s - u_last - offset
        if self._held or host_time_s < self._settle_until:
            self._held.append(x)
            return self._with_released(self._release() if host_time_s >= self._settle_until else np.zeros(0))
        return self._with_released(self._forward_only(x * self.period_s + offset, x))

    def _release(self) -> np.ndarray:
        """Stamps of the held frames on the counter model at the offset now known (forward only); none held after."""
        x = np.concatenate(self._held)
        self._held = []
        self._settle_until = -np.inf  # settled: every later read is stamped at once, until the next anchor
        return self._forward_only(x * self.period_s + self.offset_s(x[-1] * self.period_s), x)

    def _with_released(self, stamps: np.ndarray) -> np.ndarray:
        """``stamps`` after those a reset released (the frames held before a re-anchor come first)."""
        if not len(self._released):
            return stamps
        out, self._released = np.concatenate([self._released, stamps]), np.zeros(0)
        return out

    def _unwrap(self, counters):
        """Frames since the anchor of each counter (a step is the shortest one forward), and the last gap's index."""
        last, mod = self._last_counter, self.modulo
        if len(counters) <= 8:  # the usual read: plain Python beats numpy's per-call overhead
            x, gap, prev, acc = [], None, (counters[0] - 1 if last is None else last), self._x
            for i, c in enumerate(counters):
                step = (int(c) - prev) % mod or mod
                if step != 1:
                    gap = i
                acc += step
                x.append(acc)
                prev = int(c)
            return np.array(x), gap
        steps = np.diff(np.concatenate([[counters[0] - 1 if last is None else last], counters])) % mod
        steps[steps == 0] = mod
        gaps = np.flatnonzero(steps != 1)
        return self._x + np.cumsum(steps), (int(gaps[-1]) if len(gaps) else None)

    def _bridge_or_reanchor(self, x: np.ndarray, gap: int, host_time_s: float) -> None:
        """After a counter gap: keep the offset if host time confirms the counter's step, else re-anchor.

        A read later than the model by a quarter of the counter's wrap is either a long delay or
        a gap of whole wraps; the two cannot be told apart, so the clock starts again from host time.
        """
        u = x[-1] * self.period_s
        late = host_time_s - u - self.offset_s(u)
        if abs(late) > self.modulo * self.period_s / 4:
            self.reset()
        else:
            self.gaps_bridged += 1

    def _observe(self, u: float, y: float, key: float | None = None) -> None:
        """Add the offset ``y`` seen at device time ``u`` to the window; refit the drift when a block ends."""
        block = int(u // self._block_s)
        if self._block is not None and block != self._block:
            self._blocks.append((self._block, *self._best))
            self._best = (0.0, np.inf, None)
            while self._blocks and self._blocks[0][0] <= block - 10:
                self._blocks.popleft()
            if self.retime is not None:
                self._retime_blocks()
            if len(self._blocks) >= 5:  # over a shorter baseline the delays' spread outweighs any real drift
                self.drift = float(np.clip(hull_slope([b[1] for b in self._blocks], [b[2] for b in self._blocks]),
                                           -self.max_drift, self.max_drift))
            self._z_blocks = min(y - self.drift * ub for _, ub, y, _ in self._blocks)
        self._block = block
        if y - self.drift * u < self._best[1] - self.drift * self._best[0]:
            self._best = (u, y, key)

    def _retime_blocks(self) -> None:
        """Each kept read's offset from its host time as :attr:`retime` knows it now (where it knows it)."""
        for i, (block, u, y, key) in enumerate(self._blocks):
            host = None if key is None else self.retime(key)
            if host is not None:
                self._blocks[i] = (block, u, host - u, key)

    def _forward_only(self, model: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The model stamps, held strictly increasing: at least ``(1 - slew)`` periods per frame, and within an
        anchor at most ``(1 + FORWARD_SLEW)`` periods, so that a rising offset catches up without a gap."""
        out = model.copy()
        prev = self._last_stamp
        prev_x = None if prev is None else self._prev_x
        for i in range(len(out)):
            if prev is not None:
                same_anchor = prev_x is not None and x[i] > prev_x
                frames = (x[i] - prev_x) if same_anchor else 1
                floor = prev + frames * self.period_s * (1.0 - self.slew)
                # an early read leaving the window raises the offset: as a step it looked like lost frames (a
                # two-host run at 6x on a busy CPU: steps of 8-17 ms at 10, 18 and 27 s, counted as 3 samples
                # missing in the report and a restart of WMRA's window; the counter had lost none)
                ceiling = prev + frames * self.period_s * (1.0 + FORWARD_SLEW) if same_anchor else np.inf
                if out[i] < floor or out[i] > ceiling:
                    self.slewed_frames += 1
                    out[i] = min(max(out[i], floor), ceiling)
            prev, prev_x = out[i], x[i]
        self._last_stamp, self._prev_x = prev, prev_x
        self.ahead_s = out[-1] - model[-1]
        return out


class ClockFollower:
    """Simulated time (``/clock``) at any wall instant, from the messages' receive times.

    Between ``/clock`` messages, and while the executor that would deliver them is busy, a
    node's ROS clock stands still, so a serial read stamped with it looks early: the one
    error a late-only :class:`FrameClock` cannot undo. Here each message ``(recv_i, sim_i)``
    (``recv_i`` the middleware's receive time, which is only ever late) lies on or under the
    line ``sim = a + rate recv``; the estimate is the line over all messages of the last
    ``window_s`` closest to them (upper convex hull, as :func:`hull_slope`), so a late
    delivery does not make the time early and the time runs on between messages.

    The window is long because the line is extrapolated to the newest read: in the demo at 8x
    with two busy loops, a 1 s window's rate erred enough to put the time 10-12 ms
    (simulated) early at its worst reads, a 4 s one 3-6 ms (typically 1 ms: the most prompt
    delivery's delay). The rate is first given after 1 s of messages (after 0.1 s it put the
    first reads up to 12 ms early, after 0.3 s up to 6 ms, and an early read holds the driver's
    stamps early for its whole window).
    """

    def __init__(self, window_s: float = 4.0, max_extrapolation_s: float = 5.0, refit_every: int = 20,
                 min_span_s: float = 1.0, rate_tolerance: float = 5e-4):
        self.window_s, self.max_extrapolation_s, self.refit_every = window_s, max_extrapolation_s, refit_every
        self.min_span_s = min_span_s
        """A clock that moves gives no time until its rate is measured over this much wall time (s)."""
        self.rate_tolerance = rate_tolerance
        """Relative rate beyond which the window's thirds overrule its whole (:meth:`_rate`)."""
        self._sim = deque()
        self._recv = deque()
        self.rate = 0.0
        self._best = None  # max of sim_i - rate * recv_i, both relative to the first message (precision)
        self._ref = None
        self._count = 0
        self._standing_since = None  # receive time of the first message of the run standing at the clock's end
        self.jumps = 0

    def update(self, sim_s: float, received_s: float) -> None:
        """Add a ``/clock`` message: simulated time ``sim_s`` received at wall time ``received_s`` (s)."""
        if self._sim and sim_s - self._ref[0] < self._sim[-1]:  # the simulated clock went back: a new run
            self._sim.clear()
            self._recv.clear()
            self.jumps += 1
        elif len(self._sim) >= 2 and self._sim[-1] == self._sim[-2] != sim_s - self._ref[0]:
            # moving again after a pause: the paused messages are not on the new line
            self._sim.clear()
            self._recv.clear()
        if not self._sim:
            self._ref = (sim_s, received_s)
            self.rate, self._count = 0.0, 0
        self._sim.append(sim_s - self._ref[0])
        self._recv.append(received_s - self._ref[1])
        if len(self._sim) >= 2 and self._sim[-1] == self._sim[-2]:
            self._standing_since = self._recv[-2] if self._standing_since is None else self._standing_since
        else:
            self._standing_since = None
        while self._recv[-1] - self._recv[0] > self.window_s and len(self._recv) > 2:
            self._sim.popleft()
            self._recv.popleft()
        self._count += 1
        sim, recv = np.array(self._sim), np.array(self._recv)
        if self._count % self.refit_every == 1 or len(sim) < 2 * self.refit_every:
            self.rate = max(0.0, self._rate(recv, sim)) if recv[-1] > recv[0] else 0.0
        self._best = float(np.max(sim - self.rate * recv))

    def _rate(self, recv: np.ndarray, sim: np.ndarray) -> float:
        """Simulated s per wall s: the hull's over the whole window, unless the median of its thirds' differs.

        Deliveries all late by a few ms for the clock's first second, then prompt (a CPU busy at
        start-up), bend the hull: the whole window's line joins the first late delivery to the
        prompt ones, its rate 5 ms / 1.5 s too high until the prompt ones outnumber the late,
        and every read timed on it early (CI, 3x: 16 ms of simulated time for 10 s). Each third
        without the bend has the rate; the whole window's, less noisy, is kept when they agree.
        """
        whole = -hull_slope(recv, -sim)
        if recv[-1] - recv[0] < 3 * self.min_span_s / 2:
            return whole
        edges = np.searchsorted(recv, recv[0] + (recv[-1] - recv[0]) * np.array([1.0, 2.0]) / 3)
        median = float(np.median([-hull_slope(r, -s) for r, s in zip(np.split(recv, edges), np.split(sim, edges))]))
        return whole if abs(whole - median) <= self.rate_tolerance * median else median

    @property
    def span_s(self) -> float:
        """Wall time (s) between the oldest and the newest message kept."""
        return self._recv[-1] - self._recv[0] if self._recv else 0.0

    def known_at(self, wall_s: float):
        """Simulated time at a past ``wall_s`` (s) inside the span of the messages kept, else None: the line
        re-read there, after more deliveries, is at least as close as the one the read was first timed on."""
        if not self._recv or not self._recv[0] <= wall_s - self._ref[1] <= self._recv[-1]:
            return None
        return self.now(wall_s)

    def now(self, wall_s: float):
        """Simulated time at ``wall_s`` (s; also a past one); None before the clock's rate is known, after the last
        message of a standing clock, or when no message came for ``max_extrapolation_s``."""
        if self._best is None:
            return None
        wall = wall_s - self._ref[1]
        if self._standing_since is not None:  # standing at its end: its time is known only up to its last message
            if wall > self._recv[-1]:
                # it may have started since (the scenario player's frames and its first moving /clock start
                # together), and a time held at the standing value, or a line bent by it, is early, which the
                # driver's frame clock keeps for its whole window (issue 29: reads made 6 ms of wall time before
                # the first moving /clock came stamped 48 ms early for 10 s at 8x; after a 3-s stand mid-run, 31 ms)
                return None
            if wall >= self._standing_since:
                return self._ref[0] + self._sim[-1]
        paused = len(self._sim) >= 2 and self._sim[-1] == self._sim[0]
        if not paused and self._recv[-1] - self._recv[0] < self.min_span_s:
            return None  # moving (or not known to stand still) at a rate not yet measured
        if wall > self._recv[-1] + self.max_extrapolation_s:
            # /clock has gone quiet: no time. Up to then the line runs on: held at its end 1 s after the last
            # delivery (as before), a read after a 1.1 s gap in deliveries (RATE=1, CPU busy) was 106 ms early,
            # and one early read sets the driver's stamps for its whole window (10 s).
            return None
        return self._ref[0] + self._best + self.rate * wall  # on or above every message: never behind /clock


class SimTimeStamper:
    """Stamps reads on simulated time (``/clock``, through a :class:`ClockFollower`), never on a time not known.

    A read whose simulated time is not known yet is held, and stamped once it is; one held for longer
    than ``hold_s`` (s of wall time) is dropped and its frames counted in ``frames_before_clock``.
    The reads timed while the follower's line spans less than ``retime_span_s`` (s of wall time) are timed
    again as it grows (:attr:`FrameClock.retime`): a busy CPU can deliver every ``/clock`` message of
    that line's first second late. Later reads are not: re-timed on every refit, the whole window's
    offsets moved with the line's rate, and at 15.6x the stamps wandered 13-19 ms (simulated) against
    2-3 ms.
    """

    def __init__(self, core: "DriverCore", follower: ClockFollower, hold_s: float = 2.0,
                 retime_span_s: float = 2.0):
        self.core, self.follower, self.hold_s, self.retime_span_s = core, follower, hold_s, retime_span_s
        core.clock.retime = follower.known_at
        self._pending = deque()  # (wall time s, frames) not stamped yet, oldest first
        self.frames_before_clock = 0

    def stamp(self, batch, wall_s: float) -> list:
        """Stamped samples (:class:`ImuSamples`, oldest read first) of ``batch`` read at wall time ``wall_s`` (s)
        and of the held reads whose time is now known."""
        if len(batch):
            self._pending.append((wall_s, batch))
        out = []
        while self._pending:
            wall, held = self._pending[0]
            sim = self.follower.now(wall)
            if sim is not None:
                young = self.follower.span_s < self.retime_span_s
                out.append(self.core.stamp(held, sim, key_s=wall if young else None))
            elif wall < wall_s - self.hold_s:
                self.frames_before_clock += len(held)
            else:
                break  # the later reads are no better known (a rate not measured, a standing clock's last message)
            self._pending.popleft()
        if not self._pending and self.core.holding:  # no frames came: the held ones' settling may be over
            sim = self.follower.now(wall_s)
            if sim is not None:
                out.append(self.core.stamp(FrameBatch.empty(), sim))
        return out


@dataclass
class ImuSamples:
    """Samples ready to publish: ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray


class DriverCore:
    """Bytes in, stamped rate samples out, with the counters the diagnostics report."""

    def __init__(self, rate_hz: float, fmt: FrameFormat = DEFAULT_FORMAT, **clock):
        self.rate_hz = rate_hz
        self.decoder = StreamDecoder(fmt=fmt)
        self.clock = FrameClock(1.0 / rate_hz, modulo=fmt.counter_modulo, **clock)
        self._waiting = None  # (gyro (n, 3) rad/s, accel (n, 3) m/s^2) of the samples the clock holds, oldest first

    def feed(self, data: bytes, host_time_s: float) -> ImuSamples:
        """Decode ``data`` read at ``host_time_s``; stamp the frames by their counters."""
        return self.stamp(self.decoder.feed(data), host_time_s)

    def stamp(self, batch, host_time_s: float, key_s: float | None = None) -> ImuSamples:
        """Stamp decoded frames (a ``FrameBatch``) read at ``host_time_s``; rates from increments. The samples come
        out in order once stamped: those the clock holds while it settles come out with a later read's. ``key_s``:
        see :meth:`FrameClock.stamp`."""
        t = self.clock.stamp(batch.counter, host_time_s, key_s)
        dt = 1.0 / self.rate_hz
        gyro, accel = batch.dtheta / dt, batch.dv / dt
        if self._waiting is not None:  # samples held for their stamps go first
            gyro, accel = np.vstack([self._waiting[0], gyro]), np.vstack([self._waiting[1], accel])
        n = len(t)
        self._waiting = (gyro[n:], accel[n:]) if n < len(gyro) else None
        return ImuSamples(t, gyro[:n], accel[:n])

    @property
    def holding(self) -> bool:
        """Samples read and not stamped yet (the clock settles after an anchor)."""
        return self._waiting is not None

    def reconnected(self) -> None:
        """Drop partial bytes and the counter anchor after the port came back."""
        self.decoder.reset()
        self.clock.reset()

    def set_rate(self, rate_hz: float) -> None:
        """A new output rate: new period, new anchor (stamps still only go forward)."""
        self.rate_hz = rate_hz
        self.clock.period_s = 1.0 / rate_hz
        self.reconnected()
