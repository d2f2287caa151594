"""An MCAP bag cut short inside a chunk (a copy interrupted, a disk full): every message before the cut is read and
the damage names only the cut (was also "bytes X-Y unreadable, messages ... lost" at the chunk's header, where
nothing was lost)."""
import struct

import numpy as np

from nav_core import bagio
from nav_core import recording as rec_io

T0 = 1_700_000_000.0


def _chunk_starts(data: bytes) -> list:
    pos, out = 8, []
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == 0x06:
            out.append(pos)
        pos += 9 + length
    return out


def test_a_bag_cut_inside_its_second_chunk_reads_to_the_cut_and_names_only_the_cut(tmp_path):
    n = 6000  # two chunks of about 1 MB
    rng = np.random.default_rng(0)
    imu = rec_io.ImuRecording(T0 + np.arange(n) / 64, rng.normal(0, 0.01, (n, 3)), rng.normal(0, 0.1, (n, 3)))
    bag = rec_io.write_bag(tmp_path / "bag", imu, storage="mcap")
    storage = next(bag.glob("*.mcap"))
    data = storage.read_bytes()
    second = _chunk_starts(data)[1]
    cut = second + 200_000
    storage.write_bytes(data[:cut])
    back = rec_io.read_imu(bag)
    assert back.damage and f"cut short at byte {cut}" in back.damage
    assert f"bytes {second}-" not in back.damage  # the chunk header is intact: no region there
    assert back.damage.count("unreadable") == 1 and "and the end lost" in back.damage
    k = len(back)
    np.testing.assert_allclose(back.t, imu.t[:k], rtol=0, atol=1e-6)  # every message before the cut, in order
    assert k > 3000
