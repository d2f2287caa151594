"""Damaged recordings: everything intact is read, the damage is named (file, byte or line, what was lost)."""
from __future__ import annotations

import shutil
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nav_core import bagio
from nav_core import recording as rec_io
from nav_core.recording import RecordingError, check_timestamps

T0 = 1_700_000_000.0
N_IMU = 6000  # two MCAP chunks of about 1 MB


def _imu(n=N_IMU, rate=64.0, seed=0):
    rng = np.random.default_rng(seed)
    return rec_io.ImuRecording(T0 + np.arange(n) / rate, rng.normal(0, 0.01, (n, 3)),
                               rng.normal(0, 0.1, (n, 3)) + [0, 0, 9.8])


def _gnss(n=90):
    t = T0 + np.arange(n, dtype=float)
    return rec_io.GnssRecording(t, np.full(n, 0.8), np.full(n, 0.1), np.zeros(n), np.ones((n, 3)))


class _Bag(tuple):
    def __repr__(self):  # hypothesis prints fixtures of failing examples: not 2 MB of bytes
        return f"<MCAP bag {self[0]}>"


@pytest.fixture(scope="module")
def mcap_bag(tmp_path_factory):
    """A clean MCAP bag, its storage bytes and the byte span of every IMU message record."""
    path = rec_io.write_bag(tmp_path_factory.mktemp("clean") / "bag", _imu(), _gnss(), storage="mcap")
    storage = next(path.glob("*.mcap"))
    data = storage.read_bytes()
    return _Bag((path, storage.name, data, _imu_record_spans(data)))


def _imu_record_spans(data: bytes) -> dict:
    """Stamp (s) -> (start, end) byte span of each IMU message record of a clean, uncompressed MCAP file."""
    spans, pos, channel = {}, 8, None
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == 0x06:  # step into the chunk's records
            (clen,) = struct.unpack_from("<I", data, pos + 9 + 28)
            pos = pos + 9 + 32 + clen + 8
            continue
        if op == 0x04:
            cid, _, tlen = struct.unpack_from("<HHI", data, pos + 9)
            if data[pos + 17:pos + 17 + tlen].decode() == "/imu/data_raw":
                channel = cid
        if op == 0x05 and struct.unpack_from("<H", data, pos + 9)[0] == channel:
            log_ns = struct.unpack_from("<Q", data, pos + 9 + 6)[0]
            spans[log_ns] = (pos, pos + 9 + length, bytes(data[pos + 9 + 22:pos + 9 + length]))
        pos += 9 + length
    return spans


def _damaged_copy(tmp_path, bag, name, data, offset, blob):
    out = tmp_path / "damaged"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(bag, out)
    damaged = bytearray(data)
    damaged[offset:offset + len(blob)] = blob
    (out / name).write_bytes(bytes(damaged))
    return out


def test_4_kb_overwritten_in_the_middle_of_an_mcap_loses_only_what_was_there(tmp_path, mcap_bag):
    bag, name, data, spans = mcap_bag
    offset = len(data) // 2
    damaged = _damaged_copy(tmp_path, bag, name, data, offset, bytes(4096))
    imu = rec_io.read_imu(damaged)
    gnss = rec_io.read_gnss(damaged)
    overlapping = sum(1 for a, b, _ in spans.values() if a < offset + 4096 and b > offset)
    assert N_IMU - len(imu) <= overlapping + 2  # was: everything after the damage, or 15.7 s silently
    assert len(gnss) >= 89
    first = int(imu.damage.split("bytes ")[1].split("-")[0])  # the damaged region named, by byte offset
    assert name in imu.damage and offset - 400 <= first <= offset + 4096
    assert "read" in imu.damage and f"of {N_IMU} messages on imu/data_raw" in imu.damage
    with pytest.raises(RecordingError, match=name):
        rec_io.read_imu(damaged, strict=True)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.0, 1.0), size=st.integers(1, 6000), zeros=st.booleans(), seed=st.integers(0, 2**16))
def test_any_overwritten_span_keeps_every_intact_imu_message(tmp_path, mcap_bag, where, size, zeros, seed):
    _, name, data, spans = mcap_bag
    offset = int(where * (len(data) - 1))
    blob = bytes(size) if zeros else np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8).tobytes()
    damaged = bytearray(data)
    damaged[offset:offset + size] = blob
    path = tmp_path / name
    path.write_bytes(bytes(damaged))
    got, damage = {}, None
    try:
        for _, _, log_ns, raw in bagio.iter_raw(path, ["imu/data_raw"]):
            got.setdefault(log_ns, []).append(raw)
    except bagio.BagDamage as err:
        damage = str(err)
    hit = {k for k, (a, b, _) in spans.items() if a < offset + size and b > offset}
    untouched = set(spans) - hit
    missing = [k for k in untouched if k not in got]
    # Nothing intact is lost but the one record ending where the damage begins. (Bytes changed inside
    # one message's payload cannot be seen in an MCAP file without CRCs; such records are not checked.)
    assert len(missing) <= 1
    for k in untouched - set(missing):
        assert spans[k][2] in got[k]  # read exactly as written
    assert sum(map(len, got.values())) <= N_IMU
    if missing:
        assert damage and str(path) in damage and "bytes" in damage


def test_a_byte_flipped_in_a_chunks_time_range_loses_no_message(tmp_path, mcap_bag):
    """A chunk's stated start time is only a resynchronisation aid: its intact messages outside it still chain (CI,
    28 Nov: one byte of the first chunk's start time, +4.3 s, lost 275 intact IMU messages)."""
    _, name, data, spans = mcap_bag
    chunk = data.index(b"\x06", 8 + 9 + struct.unpack_from("<Q", data, 9)[0])  # the record after the header
    for field in (0, 8):  # message start time, then end time
        damaged = bytearray(data)
        damaged[chunk + 9 + field + 4] ^= 0x01 if field == 0 else 0xFF  # start 4.3 s later; end far earlier
        path = tmp_path / name
        path.write_bytes(bytes(damaged))
        got = {log_ns for _, _, log_ns, _ in bagio.iter_raw(path, ["imu/data_raw"])}
        assert set(spans) <= got


def test_a_20_byte_mcap_is_a_recording_error_naming_the_file(tmp_path, mcap_bag):
    path = tmp_path / "tiny.mcap"
    path.write_bytes(mcap_bag[2][:20])
    for strict in (False, True):
        with pytest.raises(RecordingError, match="tiny.mcap"):
            rec_io.read_imu(path, strict=strict)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError, match="too short"):
        rec_io.read_gnss(empty)


def test_truncated_sqlite_bag_without_the_topic_names_the_topic_and_the_topics_present(tmp_path):
    bag = rec_io.write_bag(tmp_path / "bag", _imu(n=3000), _gnss(), storage="sqlite3")
    db = next(bag.glob("*.db3"))
    with open(db, "r+b") as fh:
        fh.truncate(db.stat().st_size // 3)
    with pytest.raises(RecordingError, match=r"no messages on topic 'odometry/filtered'.*imu/data_raw"):
        rec_io.read_odometry(bag)
    with pytest.raises(RecordingError, match=r"no messages on topic 'imu/other'.*gps/fix"):
        rec_io.read_imu(bag, topic="imu/other")


def test_topics_of_a_damaged_mcap_are_listed(tmp_path, mcap_bag):
    bag, name, data, _ = mcap_bag
    cut = _damaged_copy(tmp_path, bag, name, data[: len(data) // 2], 0, b"")
    assert set(bagio.topics(cut)) >= {"imu/data_raw"}


# -- CSV -----------------------------------------------------------------------------------------------


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bad=st.lists(st.integers(2, 1001), min_size=0, max_size=10, unique=True),
       junk=st.sampled_from(["1.0,2.0,oops,4,5,6,7", "1,2,3", "", "nan,0,0,0,0,0,0", "\x00\xff,1,2,3,4,5,6",
                             "1,2,3,4,5,6,7,8,9", "inf,0,0,0,0,0,0"]))
def test_bad_csv_rows_are_skipped_counted_and_named(tmp_path, bad, junk):
    imu = _imu(n=1000)
    path = rec_io.write_imu_csv(tmp_path / "imu.csv", imu)
    lines = path.read_text().splitlines()
    for line in sorted(bad):  # line numbers of the final file (1 = header)
        lines.insert(line - 1, junk)
    path.write_text("\n".join(lines) + "\n")
    back = rec_io.read_imu(path)
    np.testing.assert_allclose(back.gyro, imu.gyro, rtol=1e-12)  # every good row, in order
    if junk and bad:
        assert back.skipped_rows == tuple(sorted(bad))
        assert "skipped" in back.damage and f"line {min(bad)}" in back.damage and str(path) in back.damage
        with pytest.raises(RecordingError, match=f"line {min(bad)}"):
            rec_io.read_imu(path, strict=True)
    else:
        assert back.damage is None and back.skipped_rows == ()


def test_a_gnss_csv_with_many_bad_rows_is_refused_not_silently_cut(tmp_path):
    gnss = _gnss(n=766)
    path = rec_io.write_gnss_csv(tmp_path / "gnss.csv", gnss)
    lines = path.read_text().splitlines()
    lines[200] = "garbage"
    path.write_text("\n".join(lines) + "\n")
    assert len(rec_io.read_gnss(path)) == 765  # one bad row: skipped, not the 566 after it
    for k in range(300, 320):
        lines[k] = "garbage"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=r"skipped 21 bad row\(s\) of 766.*not used"):
        rec_io.read_gnss(path)


def test_a_csv_cut_mid_row_keeps_every_whole_row(tmp_path):
    path = rec_io.write_imu_csv(tmp_path / "imu.csv", _imu(n=500))
    text = path.read_text()
    path.write_text(text[: len(text) - 25])
    back = rec_io.read_imu(path)
    assert len(back) == 499 and back.skipped_rows == (501,)


# -- timestamps ------------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(n=st.integers(3, 400), events=st.lists(st.tuples(st.sampled_from(["back", "dup", "gap"]),
                                                         st.integers(1, 399)), max_size=5, unique_by=lambda e: e[1]))
def test_check_timestamps_finds_each_planted_problem(n, events):
    dt = 1 / 64
    steps = np.full(n - 1, dt)
    planted = {"back": set(), "dup": set(), "gap": set()}
    for kind, i in events:
        if i < n:
            steps[i - 1] = {"back": -0.5, "dup": 0.0, "gap": 3600.0}[kind]
            planted[kind].add(i)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    check = check_timestamps(t, "rec.csv", max_gap_s=1.0)
    assert set(check.backwards.tolist()) == planted["back"]
    assert set(check.duplicates.tolist()) == planted["dup"]
    assert set(check.gaps.tolist()) == planted["gap"]
    assert check.ok == (not any(planted.values()))
    runs = check.runs()
    assert sum(r.stop - r.start for r in runs) == n
    for r in runs:
        assert np.all(np.diff(t[r]) > 0) and np.all(np.diff(t[r]) <= 1.0)
    if not check.ok:
        with pytest.raises(RecordingError, match="rec.csv"):
            check.raise_if()


def test_check_timestamps_names_non_finite_times_and_default_gap():
    check = check_timestamps([0.0, 0.01, 0.02, np.nan, 0.04, 0.05, 5.0], "x")  # default gap: 10 x 0.01 s
    assert check.non_finite.tolist() == [3] and check.gaps.tolist() == [6]
    assert "non-finite" in check.summary() and "sample 6" in check.summary()
    assert [(r.start, r.stop) for r in check.runs()] == [(0, 3), (4, 6), (6, 7)]


def test_imu_messages_that_do_not_decode_are_counted_not_a_traceback(tmp_path, mcap_bag):
    bag = mcap_bag[0]
    with pytest.raises(RecordingError, match=r"90 of 90 message\(s\) on gps/fix could not be decoded"):
        rec_io.read_imu(bag, topic="gps/fix")  # NavSatFix is not an Imu
    imu = rec_io.read_imu(bag)
    np.testing.assert_array_equal(imu.gyro, _imu().gyro)  # the batch decoder reads what was written
    assert imu.frame_id == "imu_link" and imu.damage is None
