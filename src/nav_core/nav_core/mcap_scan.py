"""An MCAP record scanner that reads past damage: every intact message of a file, and where the damage is.

The ``mcap`` and ``rosbags`` readers trust the file's structure: a few overwritten KB
in the middle either end the read there or make whole chunks vanish without a word.
This scanner walks the records itself, steps into uncompressed chunks (compressed
ones are decompressed and scanned the same way), and when a record does not make
sense (unknown opcode, a length past the end, a message on an unknown channel, or
outside its chunk's time range and not followed by a plausible record) it notes a
damaged region and resynchronises on the next record that does, checked by the record after it. The message that ends where
the damage begins is dropped too, since the damage may have started inside it. The
file's Statistics record, when it is intact, gives how many messages were expected
per channel, so the loss is counted exactly.

Record layout (MCAP spec): opcode u8, length u64, body; all integers little-endian.
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_STATISTICS = 0x0B
MAX_OPCODE = 0x10
_REC = struct.Struct("<BQ")
_MSG = struct.Struct("<HIQQ")
_CHUNK = struct.Struct("<QQQI")
MIN_MESSAGE_LEN = _MSG.size
_CANDIDATE = re.compile(rb"(?=[\x01-\x10][\x00-\xff]{4}\x00\x00\x00\x00)", re.DOTALL)
"""Where a record may start: a known opcode and a length below 4 GiB (searched in C, not byte by byte)."""


@dataclass
class ScanResult:
    """What a scan found: damaged byte regions, messages dropped next to them, expected counts per channel."""

    regions: list = field(default_factory=list)
    """Damaged regions that were skipped: dicts with ``start``, ``end`` (byte offsets; inside a compressed
    chunk, offsets of its data) and ``before_ns``/``after_ns``, the log times of the messages around it."""
    dropped: int = 0
    """Structurally intact messages dropped because they end where damage begins."""
    expected: dict | None = None
    """Channel id -> message count from the Statistics record (None when it is missing or damaged)."""
    truncated: bool = False
    """The file ends inside a record or without its footer."""
    problems: list = field(default_factory=list)
    """Other findings, as text (a chunk that could not be decompressed...)."""


def _str(buf, pos):
    (n,) = struct.unpack_from("<I", buf, pos)
    return bytes(buf[pos + 4:pos + 4 + n]).decode("utf-8"), pos + 4 + n


class Scanner:
    """Scan one MCAP file held in memory; :meth:`messages` yields ``(channel_id, log_time_ns, data)``."""

    def __init__(self, data: bytes):
        self.buf = memoryview(data)
        self.end = len(data)
        self.schemas: dict = {}
        self.channels: dict = {}
        """Channel id -> (topic, schema name)."""
        self.result = ScanResult()
        self._last_ns = None
        self._open: list = []

    # -- validation ---------------------------------------------------------------------------

    def _header(self, pos, end):
        if pos + 9 > end:
            return None
        op, length = _REC.unpack_from(self.buf, pos)
        if not 0 < op <= MAX_OPCODE or length > end - pos - 9:
            return None
        return op, length

    def _next_ok(self, nxt, end) -> bool:
        """Whether a plausible record (or the end of the region, or the closing magic) starts at ``nxt``."""
        if nxt == end or (end == self.end and nxt == end - len(MAGIC)
                          and bytes(self.buf[nxt:end]) == MAGIC):
            return True
        return self._header(nxt, end) is not None

    def _message_ok(self, pos, length, end, span) -> bool:
        if length < MIN_MESSAGE_LEN:
            return False
        channel, _, log_ns, _ = _MSG.unpack_from(self.buf, pos + 9)
        if channel not in self.channels:
            return False
        if span is not None and not span[0] <= log_ns <= span[1]:
            return False
        return True

    def _in_chain(self, pos, length, end, span) -> bool:
        """Whether a message met in order is intact: inside its chunk's time range, or, outside it, followed by a
        plausible record (a byte flipped in the chunk's header moves its range, not its messages: one such flip in
        a start time lost 4.3 s of intact messages)."""
        if self._message_ok(pos, length, end, span):
            return True
        return self._message_ok(pos, length, end, None) and self._next_ok(pos + 9 + length, end)

    def _chunk_fields(self, pos, length):
        try:
            start_ns, end_ns, usize, _crc = _CHUNK.unpack_from(self.buf, pos + 9)
            comp, p = _str(self.buf, pos + 9 + _CHUNK.size)
            (rec_len,) = struct.unpack_from("<Q", self.buf, p)
        except (struct.error, UnicodeDecodeError):
            return None
        body_end = pos + 9 + length
        if start_ns > end_ns or len(comp) > 16 or p + 8 + rec_len != body_end:
            return None
        return start_ns, end_ns, usize, comp, p + 8, body_end

    def _cut_chunk(self, pos, end):
        """(time span, records end, records start) of an uncompressed chunk whose header is intact but whose
        length runs past the end of the file (a file cut inside it), else None: not damage up to the cut."""
        if pos + 9 > end or self.buf[pos] != OP_CHUNK:
            return None
        (length,) = struct.unpack_from("<Q", self.buf, pos + 1)
        fields = self._chunk_fields(pos, length)
        if fields is None or fields[3] != "" or fields[4] > end:
            return None
        start_ns, end_ns, _, _, records_start, body_end = fields
        return (start_ns, end_ns), body_end, records_start

    def _valid_at(self, pos, end, span) -> bool:
        """Whether an intact record starts at ``pos`` (used to resynchronise after damage)."""
        head = self._header(pos, end)
        if head is None:
            return False
        op, length = head
        if op == OP_MESSAGE:
            return self._message_ok(pos, length, end, span) and self._next_ok(pos + 9 + length, end)
        if op == OP_CHUNK:
            return self._chunk_fields(pos, length) is not None
        if op in (OP_SCHEMA, OP_CHANNEL):
            return length >= 4 and self._next_ok(pos + 9 + length, end)
        return op > OP_CHUNK and self._next_ok(pos + 9 + length, end) and length < (1 << 26)

    def _resync(self, pos, end, span):
        """Offset of the next intact record after ``pos`` in [pos, end), or ``end``."""
        p = pos + 1
        while p < end:
            found = _CANDIDATE.search(self.buf, p, end)
            if found is None:
                return end
            p = found.start()
            if self._valid_at(p, end, span):
                return p
            p += 1
        return end

    # -- scanning -------------------------------------------------------------------------------

    def read_summary(self) -> None:
        """Learn schemas, channels and statistics from the summary section, when the footer points to one.

        So messages can be recognised even where the channel records at the start are damaged.
        """
        footer = self.end - len(MAGIC) - 9 - 20
        if footer < len(MAGIC) or bytes(self.buf[footer:footer + 9]) != _REC.pack(OP_FOOTER, 20):
            return
        (start,) = struct.unpack_from("<Q", self.buf, footer + 9)
        pos = start
        while len(MAGIC) <= pos < footer:
            head = self._header(pos, footer)
            if head is None:
                return
            self._metadata(head[0], self.buf, pos + 9, head[1])
            pos += 9 + head[1]

    def messages(self):
        """Yield ``(channel_id, log_time_ns, data bytes)`` of every intact message, in storage order."""
        self.read_summary()
        if bytes(self.buf[:len(MAGIC)]) != MAGIC:
            start = self._resync(0, self.end, None)
            self._damaged(0, start)
        else:
            start = len(MAGIC)
        yield from self._records(start, self.end, None, self.buf, 0)

    def _records(self, pos, end, span, buf, base):
        """Records in [pos, end) of ``buf`` (``base``: file offset of buf[0], for messages in decompressed chunks)."""
        pending = None  # the last message, held back until the next record shows it was not damaged
        chunk_end = None
        while pos < end:
            if chunk_end is not None and pos >= chunk_end:
                span, chunk_end = None, None
            head = self._header(pos, end)
            cut = self._cut_chunk(pos, end) if head is None and base == 0 else None
            if cut is not None:  # the file ends inside this chunk: read its records up to the cut
                self.result.truncated = True
                span, chunk_end, pos = cut
                continue
            op, length = head if head else (0, 0)
            ok = head is not None and (op != OP_MESSAGE or self._in_chain(pos, length, end, span))
            fields = self._chunk_fields(pos, length) if ok and op == OP_CHUNK else None
            if not ok or (op == OP_CHUNK and fields is None):
                if pending is not None:
                    self.result.dropped += 1
                    pending = None
                nxt = self._resync(pos, end, span)
                if nxt >= end and base == 0:
                    self.result.truncated = True  # nothing intact up to the end of the file
                self._damaged(base + pos, base + nxt)
                pos = nxt
                continue
            if pending is not None:
                yield pending
                pending = None
            if op == OP_CHUNK:
                start_ns, end_ns, _, comp, rec_start, body_end = fields
                if comp == "":
                    span, chunk_end, pos = (start_ns, end_ns), body_end, rec_start
                    continue
                yield from self._compressed(comp, buf[rec_start:body_end], (start_ns, end_ns), base + rec_start)
            elif op == OP_MESSAGE:
                channel, _, log_ns, _ = _MSG.unpack_from(buf, pos + 9)
                pending = (channel, log_ns, bytes(buf[pos + 9 + _MSG.size:pos + 9 + length]))
                self._seen(log_ns)
            elif op == OP_FOOTER and base == 0:
                return  # the closing magic follows; nothing after the footer is read
            else:
                self._metadata(op, buf, pos + 9, length)
            pos += 9 + length
        if pending is not None:
            yield pending

    def _compressed(self, comp, data, span, offset):
        try:
            if comp == "zstd":
                import zstandard
                raw = zstandard.ZstdDecompressor().decompressobj().decompress(bytes(data))
            elif comp == "lz4":
                import lz4.frame
                raw = lz4.frame.decompress(bytes(data))
            else:
                raise ValueError(f"unknown compression {comp!r}")
        except Exception as err:  # any decoder error means this chunk is lost
            self.result.regions.append((offset, offset + len(data)))
            self.result.problems.append(f"chunk at byte {offset} ({comp}) cannot be decompressed: {err}")
            return
        inner = Scanner(raw)
        inner.schemas, inner.channels, inner.result = self.schemas, self.channels, self.result
        inner._last_ns, inner._open = self._last_ns, self._open
        before = len(self.result.regions)
        yield from inner._records(0, len(raw), span, inner.buf, offset)
        self._last_ns = inner._last_ns
        if len(self.result.regions) > before:  # offsets there are inside the decompressed data
            self.result.problems.append(f"damage inside the {comp} chunk whose data starts at byte {offset}")

    def _damaged(self, start, end):
        region = {"start": start, "end": end, "before_ns": self._last_ns, "after_ns": None}
        self.result.regions.append(region)
        self._open.append(region)

    def _seen(self, log_ns):
        self._last_ns = log_ns
        while self._open:
            self._open.pop()["after_ns"] = log_ns

    def _metadata(self, op, buf, pos, length):
        try:
            if op == OP_SCHEMA:
                (sid,) = struct.unpack_from("<H", buf, pos)
                name, _ = _str(buf, pos + 2)
                self.schemas[sid] = name
            elif op == OP_CHANNEL:
                cid, sid = struct.unpack_from("<HH", buf, pos)
                topic, _ = _str(buf, pos + 4)
                self.channels[cid] = (topic, self.schemas.get(sid, ""))
            elif op == OP_STATISTICS:
                self.result.expected = _statistics(buf, pos, length)
        except (struct.error, UnicodeDecodeError):
            pass  # a damaged schema/channel/statistics body: the messages that need it show as unknown


def _statistics(buf, pos, length) -> dict:
    p = pos + 8 + 2 + 4 * 4 + 8 + 8  # message_count, schema_count, 4 counts, start and end time
    (map_len,) = struct.unpack_from("<I", buf, p)
    p += 4
    out = {}
    for q in range(p, min(p + map_len, pos + length), 10):
        cid, count = struct.unpack_from("<HQ", buf, q)
        out[cid] = count
    return out
