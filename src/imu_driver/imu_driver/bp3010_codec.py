"""MICRO-ISU BP3010 frame codec: encode and decode 16-byte increment frames, and find them in a byte stream.

The real interface control document is not public. The layout here is an
ASSUMPTION (``../shared/DESIGN.md``), with every constant a field of
:class:`FrameFormat` so the real one can be dropped in:

====  ==========================================================
byte  content
====  ==========================================================
0     sync ``0xA5``
1     frame counter, uint8, wraps
2-13  six int16 increments, little-endian: dθx dθy dθz dvx dvy dvz
14    status bits
15    checksum: the sum of all 16 bytes is 0 modulo 256
====  ==========================================================

Scale: dθ 2.5e-6 rad/LSB, dv 5e-5 (m/s)/LSB. No ROS in this module.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

FIELDS = ("dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z")
RATE_SELECT = {64: b"\x7b\x88", 32: b"\x7b\x89", 16: b"\x7b\x8a", 8: b"\x7b\x8b"}
"""Rate (Hz) -> the two bytes that select it."""
CHECKSUMS = ("sum_zero", "sum", "xor")


class FrameError(ValueError):
    """A single frame is malformed; the message names the byte."""


GYRO_WHITE_NOISE = 1.75e-3
"""The BP3010's gyro white noise (angle random walk), rad/s/sqrt(Hz): the one value the driver's default stddev,
the simulator's BP3010-grade model and config/sensor_models/bp3010.yaml share (a test holds them together)."""
ACCEL_WHITE_NOISE = 1.96e-3
"""The BP3010's accelerometer white noise (velocity random walk), m/s^2/sqrt(Hz)."""


@dataclass(frozen=True)
class FrameFormat:
    """Every constant of the frame layout (defaults: the assumed BP3010 layout)."""

    sync: int = 0xA5
    length: int = 16
    counter_byte: int = 1
    data_byte: int = 2
    field_order: tuple = FIELDS
    byteorder: str = "little"
    status_byte: int = 14
    checksum_byte: int = 15
    checksum: str = "sum_zero"
    """``sum_zero``: all bytes sum to 0 mod 256; ``sum``: byte = sum of the others mod 256; ``xor``: XOR."""
    dtheta_lsb_rad: float = 2.5e-6
    dv_lsb_mps: float = 5e-5
    counter_modulo: int = 256

    def __post_init__(self):
        if sorted(self.field_order) != sorted(FIELDS):
            raise ValueError(f"field_order must be a permutation of {FIELDS}, got {self.field_order}")
        if self.checksum not in CHECKSUMS:
            raise ValueError(f"checksum must be one of {CHECKSUMS}, got {self.checksum!r}")
        if self.byteorder not in ("little", "big"):
            raise ValueError(f"byteorder must be 'little' or 'big', got {self.byteorder!r}")
        if self.data_byte + 12 > self.length or max(self.counter_byte, self.status_byte, self.checksum_byte) >= self.length:
            raise ValueError("frame fields do not fit in the frame length")

    @property
    def int16(self) -> np.dtype:
        """The dtype of the increments."""
        return np.dtype("<i2" if self.byteorder == "little" else ">i2")

    def lsb(self) -> np.ndarray:
        """Per-field scale in the order dθx dθy dθz (rad) dvx dvy dvz (m/s)."""
        return np.array([self.dtheta_lsb_rad] * 3 + [self.dv_lsb_mps] * 3)

    def order_index(self) -> np.ndarray:
        """Position in the frame of each canonical field (FIELDS order)."""
        return np.array([self.field_order.index(f) for f in FIELDS])


DEFAULT_FORMAT = FrameFormat()


@dataclass
class FrameBatch:
    """Decoded frames: ``counter`` (n,), ``dtheta`` (n, 3) rad, ``dv`` (n, 3) m/s, ``status`` (n,)."""

    counter: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    status: np.ndarray

    def __len__(self):
        return len(self.counter)

    @staticmethod
    def empty() -> FrameBatch:
        """A batch with no frames."""
        return FrameBatch(np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int))


def checksum_ok(rows: np.ndarray, fmt: FrameFormat = DEFAULT_FORMAT) -> np.ndarray:
    """Whether each frame row (n, length) uint8 passes the checksum."""
    rows = rows.astype(np.int64)
    if fmt.checksum == "sum_zero":
        return rows.sum(axis=1) % 256 == 0
    others = np.delete(rows, fmt.checksum_byte, axis=1)
    if fmt.checksum == "sum":
        return others.sum(axis=1) % 256 == rows[:, fmt.checksum_byte]
    return np.bitwise_xor.reduce(others, axis=1) == rows[:, fmt.checksum_byte]


def frame_ok(buf, pos: int, fmt: FrameFormat = DEFAULT_FORMAT) -> bool:
    """Sync and checksum of the frame at ``buf[pos:pos + length]`` (pure Python: fast for one frame)."""
    frame = buf[pos:pos + fmt.length]
    if len(frame) < fmt.length or frame[0] != fmt.sync:
        return False
    if fmt.checksum == "sum_zero":
        return sum(frame) & 0xFF == 0
    check = frame[fmt.checksum_byte]
    others = frame[:fmt.checksum_byte] + frame[fmt.checksum_byte + 1:]
    if fmt.checksum == "sum":
        return sum(others) & 0xFF == check
    acc = 0
    for b in others:
        acc ^= b
    return acc == check


def _checksum_value(rows: np.ndarray, fmt: FrameFormat) -> np.ndarray:
    rows = rows.astype(np.int64)
    others = np.delete(rows, fmt.checksum_byte, axis=1)
    if fmt.checksum == "sum_zero":
        return (-others.sum(axis=1)) % 256
    if fmt.checksum == "sum":
        return others.sum(axis=1) % 256
    return np.bitwise_xor.reduce(others, axis=1)


def encode_counts(counter, counts, status=0, fmt: FrameFormat = DEFAULT_FORMAT) -> bytes:
    """Frames from integer counts (n, 6) in FIELDS order, counters (n,) and status (n,) -> bytes."""
    counts = np.atleast_2d(np.asarray(counts))
    n = counts.shape[0]
    if np.any(counts > 32767) or np.any(counts < -32768):
        raise FrameError("increment out of int16 range: the motion exceeds the sensor's range at this rate")
    rows = np.zeros((n, fmt.length), dtype=np.uint8)
    rows[:, 0] = fmt.sync
    rows[:, fmt.counter_byte] = np.asarray(counter, dtype=np.int64) % fmt.counter_modulo
    ordered = np.empty_like(counts)
    ordered[:, fmt.order_index()] = counts
    rows[:, fmt.data_byte:fmt.data_byte + 12] = ordered.astype(fmt.int16).view(np.uint8).reshape(n, 12)
    rows[:, fmt.status_byte] = np.broadcast_to(np.asarray(status, dtype=np.int64), (n,)) % 256
    rows[:, fmt.checksum_byte] = _checksum_value(rows, fmt)
    return rows.tobytes()


def to_counts(dtheta_rad, dv_mps, fmt: FrameFormat = DEFAULT_FORMAT) -> np.ndarray:
    """Round increments (n, 3) rad and (n, 3) m/s to integer counts (n, 6) in FIELDS order."""
    inc = np.hstack([np.atleast_2d(dtheta_rad), np.atleast_2d(dv_mps)])
    return np.rint(inc / fmt.lsb()).astype(np.int64)


def encode_stream(dtheta_rad, dv_mps, fmt: FrameFormat = DEFAULT_FORMAT, counter0: int = 0, status=0) -> bytes:
    """Pack increments dθ (n, 3) rad and dv (n, 3) m/s, each rounded to its LSB, into n frames."""
    counts = to_counts(dtheta_rad, dv_mps, fmt)
    counter = counter0 + np.arange(counts.shape[0])
    return encode_counts(counter, counts, status, fmt)


def decode_rows(rows: np.ndarray, fmt: FrameFormat = DEFAULT_FORMAT) -> FrameBatch:
    """Decode aligned, already-validated frame rows (n, length) uint8 into a :class:`FrameBatch`."""
    n = rows.shape[0]
    raw = np.ascontiguousarray(rows[:, fmt.data_byte:fmt.data_byte + 12]).view(fmt.int16).reshape(n, 6)
    counts = raw[:, fmt.order_index()].astype(float) * fmt.lsb()
    return FrameBatch(rows[:, fmt.counter_byte].astype(int), counts[:, :3], counts[:, 3:],
                      rows[:, fmt.status_byte].astype(int))


def decode_bytes(frames: bytes, fmt: FrameFormat = DEFAULT_FORMAT) -> FrameBatch:
    """Decode validated, concatenated frames (numpy for many, struct for a few: no array overhead)."""
    n = len(frames) // fmt.length
    if n > 8:
        return decode_rows(np.frombuffer(frames, dtype=np.uint8).reshape(n, fmt.length), fmt)
    fields = struct.Struct(("<" if fmt.byteorder == "little" else ">") + "6h")
    order = fmt.order_index()
    raw = [fields.unpack_from(frames, i * fmt.length + fmt.data_byte) for i in range(n)]
    counts = np.array([[r[j] for j in order] for r in raw], dtype=float).reshape(n, 6) * fmt.lsb()
    return FrameBatch(np.array([frames[i * fmt.length + fmt.counter_byte] for i in range(n)], dtype=int),
                      counts[:, :3], counts[:, 3:],
                      np.array([frames[i * fmt.length + fmt.status_byte] for i in range(n)], dtype=int))


def decode_frame(frame: bytes, fmt: FrameFormat = DEFAULT_FORMAT) -> FrameBatch:
    """Decode one frame; raises :class:`FrameError` naming the bad byte."""
    if len(frame) != fmt.length:
        raise FrameError(f"frame has {len(frame)} bytes, expected {fmt.length}")
    row = np.frombuffer(bytes(frame), dtype=np.uint8).reshape(1, -1)
    if row[0, 0] != fmt.sync:
        raise FrameError(f"byte 0: sync is 0x{row[0, 0]:02X}, expected 0x{fmt.sync:02X}")
    if not checksum_ok(row, fmt)[0]:
        raise FrameError(f"byte {fmt.checksum_byte}: checksum 0x{row[0, fmt.checksum_byte]:02X} does not match "
                         f"({fmt.checksum}: expected 0x{_checksum_value(row, fmt)[0]:02X})")
    return decode_rows(row, fmt)


@dataclass
class DecoderStats:
    """Counters of a :class:`StreamDecoder`."""

    bytes_in: int = 0
    frames: int = 0
    checksum_errors: int = 0
    resyncs: int = 0
    lost_frames: int = 0
    counter_jumps: int = 0
    duplicates: int = 0
    bytes_discarded: int = 0

    def as_dict(self) -> dict:
        """The counters by name."""
        return dict(self.__dict__)


@dataclass
class StreamDecoder:
    """Find frames in an arbitrary byte stream; resynchronise after garbage, partial and dropped bytes.

    Locked onto the stream, a frame is accepted when its sync and checksum are
    good and its counter follows the last one; a repeat of the last frame is
    skipped and counted in ``duplicates``. Otherwise the decoder searches for a
    sync byte. A candidate whose checksum is good and whose counter follows the
    last accepted one (a step of 1 to ``max_plausible_gap``) is accepted as soon
    as its bytes are in. Any other candidate must be confirmed: followed by a
    good frame whose counter follows its own, or better confirmed than the
    candidates overlapping it; so the decoder waits for the next frame's bytes
    (:meth:`flush` decides with what is there). A lone window that nothing
    confirms is taken for line noise, unless it opens a clean stream (nothing
    discarded before it, no counter to check). Lost frames are counted from
    counter gaps shorter than ``max_plausible_gap``; a longer jump, which the
    8-bit counter cannot measure, is counted in ``counter_jumps``; duplicates
    and noise are not lost frames.

    With ``lookahead`` a locked frame is also held until the next frame's sync
    byte arrives. That catches the one damage an 8-bit checksum cannot: a
    dropped byte equal to the sync value (1 drop in 256), which otherwise
    passes as a frame and costs the next intact one. It adds up to one frame
    period of latency (and confirms every candidate after damage), so the live
    driver leaves it off; offline decoding turns it on.
    """

    fmt: FrameFormat = DEFAULT_FORMAT
    max_plausible_gap: int = 8
    lookahead: bool = False
    stats: DecoderStats = field(default_factory=DecoderStats)

    def __post_init__(self):
        self._buf = bytearray()
        self._locked = False
        self._last_counter = None
        self._discarding = False
        self._final = False
        self._waiting = False

    def feed(self, data: bytes) -> FrameBatch:
        """Add bytes; return the frames that could be decided."""
        self._buf += data
        self.stats.bytes_in += len(data)
        return self._decode(final=False)

    def flush(self) -> FrameBatch:
        """Decide on everything buffered (end of stream); an incomplete tail is counted as discarded."""
        out = self._decode(final=True)
        self._discard(len(self._buf))
        self._buf.clear()
        return out

    def reset(self) -> None:
        """Forget buffered bytes and the lock (after a reconnect); counters are kept."""
        self._buf.clear()
        self._locked = False
        self._last_counter = None
        self._discarding = False

    # -- internals -------------------------------------------------------

    def _rows(self, pos: int, n: int) -> np.ndarray:
        return np.frombuffer(self._buf, dtype=np.uint8, count=n * self.fmt.length, offset=pos).reshape(n, -1)

    def _valid_at(self, pos: int) -> bool:
        return frame_ok(self._buf, pos, self.fmt)

    def _counter_at(self, pos: int) -> int:
        return self._buf[pos + self.fmt.counter_byte]

    def _gap(self, counter: int) -> int:
        """Frames missing between the last accepted counter and ``counter``."""
        if self._last_counter is None:
            return 0
        return (counter - self._last_counter - 1) % self.fmt.counter_modulo

    def _follows(self, counter: int, last) -> bool:
        """Whether ``counter`` can follow ``last`` (a step of 1 to ``max_plausible_gap``)."""
        return last is not None and 1 <= (counter - last) % self.fmt.counter_modulo <= self.max_plausible_gap

    def _decode(self, final: bool) -> FrameBatch:
        self._final = final
        accepted = []
        pos = 0
        while pos < len(self._buf):
            self._waiting = False
            step = self._take_locked(pos, accepted) if self._locked else self._search(pos, final, accepted)
            if step is None:
                break
            pos = step
            if self._waiting:
                break
        del self._buf[:pos]
        if not accepted:
            return FrameBatch.empty()
        return decode_bytes(b"".join(accepted), self.fmt)

    def _accept(self, pos: int, n: int, accepted: list) -> None:
        """Take the n good frames at ``pos``."""
        L, cb = self.fmt.length, self.fmt.counter_byte
        gap = self._gap(self._buf[pos + cb])
        if gap < self.max_plausible_gap:
            self.stats.lost_frames += gap
        elif gap < self.fmt.counter_modulo - 1 - self.max_plausible_gap:
            # a jump the 8-bit counter cannot measure (a long dropout, a reset of the unit, or the last
            # frame was noise): counted as a jump, not as a number of lost frames
            self.stats.counter_jumps += 1
        # (a counter a few steps behind the last: the last frame was noise; nothing was lost)
        self._last_counter = self._buf[pos + (n - 1) * L + cb]
        self.stats.frames += n
        accepted.append(bytes(self._buf[pos:pos + n * L]))

    def _take_locked(self, pos: int, accepted: list):
        """Accept the longest run of good, consecutive frames at ``pos``; None when waiting for data."""
        L, fmt = self.fmt.length, self.fmt
        n = (len(self._buf) - pos) // L
        if self.lookahead and not self._final:
            n = (len(self._buf) - pos - 1) // L  # frames whose successor's first byte is here
        if n <= 0:
            return None
        k = self._good_run(pos, n)
        if k:
            self._accept(pos, k, accepted)
        if k == n:
            return pos + k * L
        # The frame at pos + k*L broke the lock: damaged, repeated, or a counter jump that needs confirmation.
        bad = pos + k * L
        if self._buf[bad] == fmt.sync and not self._valid_at(bad):
            self.stats.checksum_errors += 1
        elif self._valid_at(bad) and self._counter_at(bad) == self._last_counter:
            self.stats.duplicates += 1  # the same frame sent twice: not data, not a loss
            return bad + L
        self._locked = False
        return bad

    def _good_run(self, pos: int, n: int) -> int:
        """How many of the n frames at ``pos`` are good and consecutive (a Python loop for a few, numpy else)."""
        fmt, L, last = self.fmt, self.fmt.length, self._last_counter
        if n <= 8:
            for i in range(n):
                at = pos + i * L
                if not frame_ok(self._buf, at, fmt) or self._buf[at + fmt.counter_byte] != (last + 1) % fmt.counter_modulo:
                    return i
                if self.lookahead and at + L < len(self._buf) and self._buf[at + L] != fmt.sync:
                    return i
                last = self._buf[at + fmt.counter_byte]
            return n
        rows = self._rows(pos, n)
        good = (rows[:, 0] == fmt.sync) & checksum_ok(rows, fmt)
        counters = rows[:, fmt.counter_byte].astype(int)
        expected = (np.concatenate([[last], counters[:-1]]) + 1) % fmt.counter_modulo
        good &= counters == expected
        if self.lookahead:
            nxt = np.frombuffer(self._buf, np.uint8, count=len(self._buf) - pos - L, offset=pos + L)[::L][:n]
            good[:len(nxt)] &= nxt == fmt.sync
        return n if good.all() else int(np.argmin(good))

    def _search(self, pos: int, final: bool, accepted: list):
        """Find and confirm the next frame start at or after ``pos``; sets ``_waiting`` when data is short.

        Returns the new position: bytes before it are consumed (and were counted as discarded once).
        """
        L, sync = self.fmt.length, self.fmt.sync
        start = self._buf.find(sync, pos)
        if start < 0:
            self._discard(len(self._buf) - pos)
            return len(self._buf)
        self._discard(start - pos)
        if start + L > len(self._buf):
            self._waiting = True
            return start
        if not self._valid_at(start):
            self._discard(1)
            return start + 1
        choice = self._choose(start, final)
        if choice is None:
            self._waiting = True
            return start
        if choice != start:
            self._discard(max(choice - start, 1))
            return max(choice, start + 1)
        if self._counter_at(start) == self._last_counter:  # a confirmed repeat of the last frame
            self.stats.duplicates += 1
            return start + L
        self._accept(start, 1, accepted)
        self._locked = True
        if self._discarding:
            self.stats.resyncs += 1
            self._discarding = False
        return start + L

    def _choose(self, start: int, final: bool):
        """Pick among ``start`` and overlapping good candidates; -1: reject ``start``; None: more data needed."""
        L, last = self.fmt.length, self._last_counter
        if not self.lookahead and self._follows(self._counter_at(start), last):
            return start  # its counter follows the last frame's: publish it now
        if not final and start + 2 * L > len(self._buf):
            return None
        candidates = [start] + [q for q in range(start + 1, start + L) if self._valid_at(q)]
        # Judge competitors only once each can show whether a good frame follows it.
        if not final and len(candidates) > 1 and candidates[-1] + 2 * L > len(self._buf):
            return None

        def score(q):
            chained = self._valid_at(q + L) and self._follows(self._counter_at(q + L), self._counter_at(q))
            return 2 * chained + self._follows(self._counter_at(q), last)

        best = max(candidates, key=lambda q: (score(q), -q))
        if score(best) == 0 and (last is not None or self._discarding):
            return -1  # a lone window in noise: nothing confirms it, its counter cannot follow the last
        return best

    def _discard(self, n: int) -> None:
        if n > 0:
            self.stats.bytes_discarded += n
            self._discarding = True
