"""Driver core without ROS: decode bytes, stamp frames by their counter, turn increments into rates."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imu_driver.bp3010_codec import DEFAULT_FORMAT, FrameFormat, StreamDecoder


@dataclass
class FrameClock:
    """Stamps frames by counter x nominal period from a host-time anchor, so read jitter stays out.

    The anchor is the host time of the first frame; it is set again (re-anchored)
    after a gap in the counter, after a reconnect, and when the prediction
    drifts more than ``max_offset_s`` from host time either way (clock drift,
    or a stall). ``max_offset_s`` must exceed the read jitter, which under
    simulated time grows with the playback rate.
    """

    period_s: float
    max_offset_s: float = 0.1
    modulo: int = 256
    reanchors: int = 0

    def __post_init__(self):
        self._anchor_time = None
        self._frames_since_anchor = 0
        self._last_counter = None

    def reset(self) -> None:
        """Forget the anchor (after a reconnect or a rate change)."""
        self._anchor_time = None
        self._last_counter = None

    def stamp(self, counter: int, host_time_s: float) -> float:
        """Stamp in s of the frame with ``counter`` received at ``host_time_s``."""
        if self._anchor_time is not None:
            step = (counter - self._last_counter) % self.modulo
            self._frames_since_anchor += step
            predicted = self._anchor_time + self._frames_since_anchor * self.period_s
            if step == 1 and abs(host_time_s - predicted) <= self.max_offset_s:
                self._last_counter = counter
                return predicted
            self.reanchors += 1
        self._anchor_time = host_time_s
        self._frames_since_anchor = 0
        self._last_counter = counter
        return host_time_s


@dataclass
class ImuSamples:
    """Samples ready to publish: ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray


class DriverCore:
    """Bytes in, stamped rate samples out, with the counters the diagnostics report."""

    def __init__(self, rate_hz: float, fmt: FrameFormat = DEFAULT_FORMAT, max_offset_s: float = 0.1):
        self.rate_hz = rate_hz
        self.decoder = StreamDecoder(fmt=fmt)
        self.clock = FrameClock(1.0 / rate_hz, max_offset_s, fmt.counter_modulo)

    def feed(self, data: bytes, host_time_s: float) -> ImuSamples:
        """Decode ``data`` read at ``host_time_s``; frames of one read are spaced by the nominal period."""
        batch = self.decoder.feed(data)
        n = len(batch)
        t = np.empty(n)
        for i in range(n):
            # Frames that arrived together were made one period apart, the last one just before the read.
            t[i] = self.clock.stamp(int(batch.counter[i]), host_time_s - (n - 1 - i) / self.rate_hz)
        dt = 1.0 / self.rate_hz
        return ImuSamples(t, batch.dtheta / dt, batch.dv / dt)

    def reconnected(self) -> None:
        """Drop partial bytes and the time anchor after the port came back."""
        self.decoder.reset()
        self.clock.reset()
