"""Benchmark of nav_core's recording reader: MCAP read speed, and what 4 KB of damage costs.

Usage: python benchmarks/bench_nav_core_recordings.py [--quick] [--minutes M]

Writes a 64 Hz IMU + 1 Hz GPS MCAP bag with ``nav_core.recording.write_bag`` (rosbags'
writer, ~1 MB chunks), then prints:

* speed: raw messages per second through ``bagio.iter_raw`` (the project's record scanner,
  ``nav_core.mcap_scan``) and through ``rosbags``' reader (the peer it replaced), and the whole
  ``read_imu`` (deserialisation included);
* damage: for 4 KB overwritten (zeros, then random bytes) at evenly spaced offsets, the IMU and
  GPS messages read by each reader and whether it reported the damage at all.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader

from nav_core import bagio
from nav_core.recording import GnssRecording, ImuRecording, read_imu, write_bag

T0 = 1_700_000_000.0


def make_bag(folder: Path, minutes: float) -> Path:
    """A 64 Hz IMU and 1 Hz GPS bag of ``minutes`` (MCAP)."""
    n = int(minutes * 60 * 64)
    rng = np.random.default_rng(0)
    imu = ImuRecording(T0 + np.arange(n) / 64, rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-2, (n, 3)) + [0, 0, 9.8])
    m = int(minutes * 60)
    gnss = GnssRecording(T0 + np.arange(m, dtype=float), np.full(m, 0.8), np.full(m, 0.1), np.zeros(m),
                         np.ones((m, 3)))
    return write_bag(folder / "bag", imu, gnss, storage="mcap")


def scanner_counts(bag: Path):
    """(IMU, GPS, damage reported) through the project's reader."""
    counts, damaged = {"imu/data_raw": 0, "gps/fix": 0}, False
    try:
        for topic, _, _, _ in bagio.iter_raw(bag):
            counts[topic] = counts.get(topic, 0) + 1
    except bagio.BagDamage:
        damaged = True
    return counts["imu/data_raw"], counts["gps/fix"], damaged


def rosbags_counts(bag: Path):
    """(IMU, GPS, damage reported) through rosbags' reader (what the project used before)."""
    counts, damaged = {"imu/data_raw": 0, "gps/fix": 0}, False
    try:
        with Reader(bag) as reader:
            for conn, _, _ in reader.messages():
                topic = conn.topic.lstrip("/")
                counts[topic] = counts.get(topic, 0) + 1
    except Exception:  # any error is a report of damage
        damaged = True
    return counts["imu/data_raw"], counts["gps/fix"], damaged


def speed(bag: Path) -> None:
    """Messages per second of both readers on the healthy bag, and read_imu's time."""
    for name, fn in (("nav_core scanner", scanner_counts), ("rosbags reader", rosbags_counts)):
        t = time.perf_counter()
        imu, gps, _ = fn(bag)
        dt = time.perf_counter() - t
        print(f"  {name:17s} {imu + gps:8d} messages in {dt:6.3f} s = {(imu + gps) / dt:10,.0f} messages/s")
    t = time.perf_counter()
    n = len(read_imu(bag))
    print(f"  read_imu (deserialised)  {n} samples in {time.perf_counter() - t:.2f} s")


def damage(bag: Path, work: Path, offsets: int) -> None:
    """4 KB overwritten at evenly spaced offsets: messages read and damage reported by each reader."""
    storage = next(bag.glob("*.mcap"))
    data = storage.read_bytes()
    total_imu, total_gps, _ = scanner_counts(bag)
    print(f"  clean bag: {total_imu} IMU, {total_gps} GPS messages, {len(data) / 1e6:.1f} MB")
    print("  offset MB | bytes  | nav_core IMU lost, GPS lost, reported | rosbags IMU lost, GPS lost, reported")
    rng = np.random.default_rng(1)
    for k in range(1, offsets + 1):
        offset = int(len(data) * k / (offsets + 1))
        for kind in ("zeros", "random"):
            blob = bytes(4096) if kind == "zeros" else rng.integers(0, 256, 4096, dtype=np.uint8).tobytes()
            copy = work / f"damaged_{k}_{kind}"
            shutil.copytree(bag, copy)
            raw = bytearray(data)
            raw[offset:offset + 4096] = blob
            (copy / storage.name).write_bytes(bytes(raw))
            ours, theirs = scanner_counts(copy), rosbags_counts(copy)
            print(f"  {offset / 1e6:9.3f} | {kind:6s} | {total_imu - ours[0]:12d} {total_gps - ours[1]:9d} "
                  f"{str(ours[2]):>9s} | {total_imu - theirs[0]:11d} {total_gps - theirs[1]:9d} {str(theirs[2]):>9s}")
            shutil.rmtree(copy)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 minutes of data, 3 offsets")
    parser.add_argument("--minutes", type=float, default=60.0, help="length of the bag (default 60)")
    args = parser.parse_args()
    minutes, offsets = (10.0, 3) if args.quick else (args.minutes, 7)
    with tempfile.TemporaryDirectory() as tmp:
        bag = make_bag(Path(tmp), minutes)
        print(f"MCAP read speed, {minutes:g} min at 64 Hz:")
        speed(bag)
        print("4 KB overwritten:")
        damage(bag, Path(tmp), offsets)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
