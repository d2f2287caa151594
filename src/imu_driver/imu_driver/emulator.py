"""BP3010 emulator core: increment sources, fault injection and a pseudo-terminal port. No ROS.

The emulator behaves like the unit: it streams frames at the selected rate
whether or not anyone reads (bytes nobody reads are lost), answers the
rate-select command ``7B 88..8B`` and can be unplugged and plugged back
(the port's symlink disappears and comes back pointing at a new pty).
"""
from __future__ import annotations

import os
import select
import threading
import time
import tty
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imu_driver.bp3010_codec import DEFAULT_FORMAT, RATE_SELECT, FrameFormat, encode_counts, to_counts
from nav_core import earth
from nav_core.units import DEG

BASE_RATE_HZ = 64
SCENARIOS = ("still", "rotating")
RATE_BY_CODE = {code[1]: rate for rate, code in RATE_SELECT.items()}


def builtin_increments(scenario: str, n: int, rate_hz: float = BASE_RATE_HZ, seed: int = 0,
                       lat_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray]:
    """Increments dθ (n, 3) rad and dv (n, 3) m/s of a level unit, ``still`` or ``rotating`` at 30 deg/s yaw."""
    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; choose one of {SCENARIOS}")
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    lat = lat_deg * DEG
    rate = np.array([0.0, 0.0, earth.RATE * np.sin(lat)])
    if scenario == "rotating":
        rate[2] += 30.0 * DEG
    force = np.array([0.0, 0.0, earth.normal_gravity(lat)])
    # ADXRS300/ADXL210-grade white noise: 0.05 deg/sqrt(s), 1.2 mm/s/sqrt(s).
    dtheta = rate * dt + rng.normal(0.0, 0.05 * DEG * np.sqrt(dt), (n, 3))
    dv = force * dt + rng.normal(0.0, 1.2e-3 * np.sqrt(dt), (n, 3))
    return dtheta, dv


def increments_from_rates(t, gyro, accel) -> tuple[np.ndarray, np.ndarray]:
    """Increments (rate x interval) from sampled rates (n, 3) rad/s and specific force (n, 3) m/s^2."""
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if len(t) > 1 else 1.0 / BASE_RATE_HZ))
    return gyro * dt[:, None], accel * dt[:, None]


@dataclass
class FaultPlan:
    """Faults to inject: per-frame probabilities, periodic garbage bursts, unplug windows (s from start)."""

    flip_probability: float = 0.0
    drop_probability: float = 0.0
    garbage_every_s: float = 0.0
    garbage_bytes: int = 40
    disconnect_at_s: tuple = ()
    disconnect_for_s: float = 5.0
    seed: int = 0

    def damage(self, frame: bytes, rng) -> bytes:
        """The frame after random byte flips and drops."""
        out = bytearray(frame)
        if self.flip_probability and rng.random() < self.flip_probability:
            out[rng.integers(len(out))] ^= int(rng.integers(1, 256))
        if self.drop_probability and rng.random() < self.drop_probability:
            del out[rng.integers(len(out))]
        return bytes(out)


class PtyPort:
    """A pseudo-terminal whose slave side is reachable at a stable symlink, like a udev by-id link."""

    def __init__(self, link: Path):
        self.link = Path(link)
        self.master = self.slave = None
        self.plug()

    def plug(self) -> None:
        """Open a new pty pair and point the link at its slave."""
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no CR/LF translation: binary frames pass untouched
        os.set_blocking(self.master, False)
        tmp = self.link.with_name(self.link.name + ".new")
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(os.ttyname(self.slave))
        tmp.replace(self.link)

    def unplug(self) -> None:
        """Remove the link and close the pty: readers see the device vanish."""
        self.link.unlink(missing_ok=True)
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)
        self.master = self.slave = None

    def write(self, data: bytes) -> int:
        """Write what the pty buffer takes now; the rest is lost as on a real UART. Returns bytes written."""
        try:
            return os.write(self.master, data)
        except (BlockingIOError, OSError):
            return 0

    def read_commands(self) -> bytes:
        """Bytes the host sent (rate-select commands), without blocking."""
        if self.master is None or not select.select([self.master], [], [], 0)[0]:
            return b""
        try:
            return os.read(self.master, 256)
        except OSError:
            return b""


class SerialPort:
    """A real serial port (pyserial) with the same interface as :class:`PtyPort`."""

    def __init__(self, device: str, baud: int):
        import serial

        self.link = device
        self._serial = serial.Serial(device, baud, timeout=0, write_timeout=0)

    def plug(self) -> None:
        """Reopen the port."""
        self._serial.open()

    def unplug(self) -> None:
        """Close the port."""
        self._serial.close()

    def write(self, data: bytes) -> int:
        """Write without blocking; returns bytes written."""
        try:
            return self._serial.write(data) or 0
        except Exception:  # pyserial raises SerialTimeoutException on a full buffer
            return 0

    def read_commands(self) -> bytes:
        """Bytes the host sent."""
        return self._serial.read(256) if self._serial.is_open else b""


@dataclass
class EmulatorStats:
    """What the emulator did, for the tests to compare with the driver's diagnostics."""

    frames_sent: int = 0
    frames_damaged: int = 0
    garbage_bursts: int = 0
    disconnects: int = 0
    bytes_lost: int = 0
    rate_hz: int = BASE_RATE_HZ


class Emulator:
    """Streams frames of 64 Hz counts (n, 6) to a port at the selected rate, with faults, in (scaled) real time."""

    def __init__(self, port, counts: np.ndarray, fmt: FrameFormat = DEFAULT_FORMAT, faults: FaultPlan = None,
                 speed: float = 1.0, loop: bool = False, log=print):
        self.port, self.counts, self.fmt = port, counts, fmt
        self.faults = faults or FaultPlan()
        self.speed, self.loop, self.log = speed, loop, log
        self.stats = EmulatorStats()
        self._rng = np.random.default_rng(self.faults.seed)
        self._pending = b""
        self._stop = threading.Event()

    def stop(self) -> None:
        """End :meth:`run` after the frame in progress (from another thread)."""
        self._stop.set()

    def _handle_commands(self) -> None:
        self._pending += self.port.read_commands()
        while len(self._pending) >= 2:
            idx = self._pending.find(b"\x7b")
            if idx < 0 or idx + 1 >= len(self._pending):
                self._pending = self._pending[idx:] if idx >= 0 else b""
                return
            code = self._pending[idx + 1]
            self._pending = self._pending[idx + 2:]
            if code in RATE_BY_CODE:
                self.stats.rate_hz = RATE_BY_CODE[code]
                self.log(f"RATE {self.stats.rate_hz}")

    def run(self, max_frames: int | None = None, start: float | None = None) -> EmulatorStats:
        """Stream until the source ends (or ``max_frames``); returns the stats.

        ``start``: monotonic time (s) at which the first frame's period begins (default: now), so a
        caller that keeps its own clock for the same run (``/clock``) shares this one's zero.
        """
        start = time.monotonic() if start is None else start
        next_garbage = self.faults.garbage_every_s or float("inf")
        unplug_windows = sorted(self.faults.disconnect_at_s)
        counter, index, t_model = 0, 0, 0.0
        while (max_frames is None or self.stats.frames_sent < max_frames) and not self._stop.is_set():
            self._handle_commands()
            factor = BASE_RATE_HZ // self.stats.rate_hz
            if index + factor > len(self.counts):
                if not self.loop:
                    break
                index = 0
            frame_counts = self.counts[index:index + factor].sum(axis=0, keepdims=True)
            index += factor
            t_model += factor / BASE_RATE_HZ
            self._sleep_until(start + t_model / self.speed)
            if unplug_windows and t_model >= unplug_windows[0]:
                self._unplugged(unplug_windows.pop(0))
                # The unit kept running while unplugged: those frames are gone.
                skipped = int(self.faults.disconnect_for_s * self.stats.rate_hz)
                counter += skipped
                index = (index + skipped * factor) % max(len(self.counts), 1) if self.loop else index + skipped * factor
                t_model += skipped * factor / BASE_RATE_HZ
                continue
            frame = encode_counts([counter], frame_counts, 0, self.fmt)
            counter += 1
            damaged = self.faults.damage(frame, self._rng)
            self.stats.frames_damaged += damaged != frame
            if t_model >= next_garbage:
                damaged += self._rng.integers(0, 256, self.faults.garbage_bytes, dtype=np.uint8).tobytes()
                self.stats.garbage_bursts += 1
                next_garbage += self.faults.garbage_every_s
            self.stats.bytes_lost += len(damaged) - self.port.write(damaged)
            self.stats.frames_sent += 1
        return self.stats

    def _unplugged(self, at_s: float) -> None:
        self.log(f"UNPLUG at {at_s:.1f} s for {self.faults.disconnect_for_s:.1f} s")
        self.port.unplug()
        self.stats.disconnects += 1
        time.sleep(self.faults.disconnect_for_s / self.speed)
        self.port.plug()
        self.log(f"PLUG {self.port.link}")

    @staticmethod
    def _sleep_until(deadline: float) -> None:
        delay = deadline - time.monotonic()
        if delay > 0:
            time.sleep(delay)


def counts_from_source(source: str, seconds: float, seed: int, fmt: FrameFormat = DEFAULT_FORMAT,
                       topic: str = "imu/data_raw") -> np.ndarray:
    """64 Hz counts (n, 6) from a built-in scenario name, a BP3010 .bin stream, or a recording (CSV or bag)."""
    if source in SCENARIOS:
        return to_counts(*builtin_increments(source, int(round(seconds * BASE_RATE_HZ)), seed=seed), fmt)
    path = Path(source)
    if path.suffix == ".bin":
        from imu_driver.bp3010_codec import StreamDecoder

        dec = StreamDecoder(fmt=fmt, lookahead=True)  # offline: catch sync-valued drops
        raw = path.read_bytes()
        batch = dec.feed(raw)
        tail = dec.flush()
        dtheta = np.vstack([batch.dtheta, tail.dtheta])
        dv = np.vstack([batch.dv, tail.dv])
        if len(dtheta) == 0:
            raise ValueError(f"{path}: no BP3010 frame in its {len(raw)} bytes")
        return to_counts(dtheta, dv, fmt)
    from nav_core.recording import read_imu

    rec = read_imu(path, topic=topic)
    if abs(rec.rate_hz - BASE_RATE_HZ) > 1.0:
        raise ValueError(f"{path}: recording is at {rec.rate_hz:.1f} Hz; the BP3010 emulator plays 64 Hz")
    return recording_counts(rec, str(path), fmt)


def recording_counts(rec, where: str, fmt: FrameFormat = DEFAULT_FORMAT) -> np.ndarray:
    """Counts (n, 6) of a 64-Hz recording, one frame per sample; ValueError naming the sample, its time and the
    channel when a sample is not finite, the stamps are not one period apart in order, or an increment does not
    fit the frame's int16 (a gyro in deg/s, a gap of seconds integrated as one sample)."""
    from nav_core.recording import check_timestamps

    bad = ~(np.all(np.isfinite(rec.gyro), axis=1) & np.all(np.isfinite(rec.accel), axis=1))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{where}: {int(bad.sum())} sample(s) not finite (first: sample {k}, t = {rec.t[k]:.6f} s); "
                         "a frame carries numbers")
    check = check_timestamps(rec.t, where, max_gap_s=1.5 / BASE_RATE_HZ)
    if not check.ok:
        raise ValueError(f"{check.summary()}: the emulator plays one frame per 64-Hz sample, in order")
    counts = to_counts(*increments_from_rates(rec.t, rec.gyro, rec.accel), fmt)
    over = np.abs(counts) > 32767
    if over.any():
        k, c = (int(i) for i in np.argwhere(over)[0])
        value = (rec.gyro if c < 3 else rec.accel)[k, c % 3]
        full = 32767 * fmt.lsb()[c] * BASE_RATE_HZ
        unit, hint = ("rad/s", " (in deg/s?)") if c < 3 else ("m/s^2", "")
        raise ValueError(f"{where}: sample {k} (t = {rec.t[k]:.6f} s): {'gx gy gz ax ay az'.split()[c]} = "
                         f"{value:.4g} {unit} is beyond the frame's +-{full:.3g} {unit} at 64 Hz{hint}")
    return counts
