"""Benchmark of nav-batch: ``allan`` on 2 Dask workers against the serial loop of ``imu-calib allan``, and the
CPU-seconds per recording-hour of each batch tool (the figures of docs/fleet_sizing.md).

Usage: python benchmarks/bench_nav_batch.py [--quick] [--recordings N] [--hours H] [--only speed|sizing]

Speed: N static recordings of H hours at 100 Hz (CSV, synthetic BP3010-like noise); the peer is the loop a user
writes without nav-batch, ``for r in recs: imu-calib allan r --out ...``, one process per recording; nav-batch runs
``nav-batch allan recs --workers 2``. Both are timed as whole commands (wall clock, start-up of the processes and
of the Dask cluster included), one after the other in the same run, and the outputs are compared byte for byte
(``SOURCE_DATE_EPOCH`` fixes the models' ``created_utc``). Sizing: each single-recording command once on one
recording, its CPU time (user + system of the child process) divided by the recording's hours.
"""
from __future__ import annotations

import argparse
import csv
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from imu_calib import synthetic
from nav_core import sensor_model
from nav_core.processes import executable
from nav_core.recording import ImuRecording, write_bag, write_imu_csv

RATE_HZ = 100.0
MODEL = sensor_model.SensorModel(
    gyro=sensor_model.TriadModel(white_noise=np.full(3, 8.7e-4), bias_instability=np.full(3, 3e-4)),
    accel=sensor_model.TriadModel(white_noise=np.full(3, 1.2e-3)), sample_rate_hz=RATE_HZ)
ENV = dict(os.environ, SOURCE_DATE_EPOCH="1700000000", OPENBLAS_NUM_THREADS="1")


def _static(folder: Path, k: int, hours: float) -> str:
    rec = synthetic.static_recording(MODEL, hours * 3600.0, np.random.default_rng(k))
    return str(write_imu_csv(folder / f"static{k}.csv", rec))


def _run(cmd) -> tuple[float, float]:
    """Run ``cmd`` to the end: (wall s, CPU s of it and its children)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=ENV)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd[:3])} failed: {proc.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _identical(a: Path, b: Path) -> bool:
    names = sorted(p.name for p in a.iterdir())
    return names == sorted(p.name for p in b.iterdir()) and all(
        (a / n).read_bytes() == (b / n).read_bytes() for n in names)


def bench_speed(work: Path, n: int, hours: float) -> None:
    """nav-batch allan --workers 2 against the serial loop of imu-calib allan on n recordings of ``hours``."""
    recs = [_static(work, k, hours) for k in range(n)]
    print(f"speed: {n} static recordings of {hours:g} h at {RATE_HZ:g} Hz "
          f"({os.path.getsize(recs[0]) / 1e6:.0f} MB CSV each); {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f} at the start")
    t_serial, cpu_serial = 0.0, 0.0
    for rec in recs:
        wall, cpu = _run([executable("imu-calib"), "allan", rec, "--out", str(work / "serial" / Path(rec).stem),
                          "--no-progress"])
        t_serial += wall
        cpu_serial += cpu
    t_batch, cpu_batch = _run([executable("nav-batch"), "allan", *recs, "--out", str(work / "batch"),
                               "--workers", "2", "--no-progress"])
    same = all(_identical(work / "serial" / Path(r).stem, work / "batch" / Path(r).stem) for r in recs)
    with open(work / "batch" / "results.csv", newline="") as fh:
        tasks = [(float(r["wall_s"]), float(r["cpu_s"])) for r in csv.DictReader(fh)]
    print(f"  serial loop of imu-calib allan: {t_serial:.1f} s wall, {cpu_serial:.1f} CPU-s")
    print(f"  nav-batch allan --workers 2:    {t_batch:.1f} s wall, {cpu_batch:.1f} CPU-s (workers included)")
    print(f"  speed-up {t_serial / t_batch:.2f}x (target >= 1.6x on 2 cores); outputs byte-identical: {same}; "
          f"load average {os.getloadavg()[0]:.1f} at the end")
    print(f"  in the workers: {sum(c for _, c in tasks):.1f} CPU-s for {len(tasks)} recordings, each task "
          f"{np.mean([c / w for w, c in tasks]):.0%} of a core on average (wall {sum(w for w, _ in tasks):.1f} s in all)")
    autogroup = Path("/proc/sys/kernel/sched_autogroup_enabled")
    if autogroup.exists() and autogroup.read_text().strip() == "1":
        print("  (the kernel's autogroup scheduling is on: under load a session's processes share one session's "
              "part of the CPU, however many they are)")


def _drive_bag(folder: Path, hours: float) -> tuple[str, str]:
    """A drive bag (64 Hz IMU with errors, 1 Hz GPS) of about ``hours`` and the model to replay it with."""
    from ins_gps_kf import error_model
    from ins_gps_kf import synthetic as syn
    laps = max(1, int(round(hours * 3600.0 / 60.0)))
    motion = syn.circle(still_s=60.0, accel_s=5.0, straight_s=10.0, turn_s=60.0 * laps - 15.0)
    rng = np.random.default_rng(3)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, 64.0), rng, 1e-4, 0.01, 1e-3, 1e-3)
    bag = write_bag(folder / "drive", imu, syn.gnss(motion, 64.0, 1.0, rng), imu_topic="imu/data_corrected",
                    storage="mcap")
    return str(bag), str(sensor_model.save(error_model.default_mems_model(), folder / "kf_model.yaml"))


def _diagnose_case(folder: Path, hours: float) -> tuple[str, str, str]:
    """A static recording of ``hours`` at 100 Hz with its scenario and model (imu-sim diagnose's inputs)."""
    rec = synthetic.static_recording(MODEL, hours * 3600.0, np.random.default_rng(5), t0=1.0 / RATE_HZ)
    csv = write_imu_csv(folder / "diag.csv", ImuRecording(rec.t, rec.gyro, rec.accel))
    scen = folder / "scenario.yaml"
    scen.write_text(yaml.safe_dump({"latitude_deg": 45.0, "longitude_deg": 7.0, "height_m": 200.0,
                                    "rate_hz": RATE_HZ, "gps": False, "static_segments": [
                                        {"t0": 0.0, "t1": float(rec.t[-1]) + 1.0, "roll_deg": 0.0,
                                         "pitch_deg": 0.0, "yaw_deg": 0.0}]}))
    return str(csv), str(scen), str(sensor_model.save(MODEL, folder / "model.yaml"))


def bench_sizing(work: Path, hours: dict) -> None:
    """CPU-seconds per recording-hour of each single-recording command, and its input's bytes per hour."""
    print("sizing: CPU time (user + system) of one single-recording command, per hour of recording")
    allan_rec = _static(work, 99, hours["allan"])
    bag, kf_model = _drive_bag(work, hours["replay"])
    diag_rec, scen, model = _diagnose_case(work, hours["diagnose"])
    cases = {
        "allan": ([executable("imu-calib"), "allan", allan_rec, "--out", str(work / "s_allan"), "--no-progress"],
                  allan_rec, hours["allan"], "100 Hz CSV"),
        "replay": ([executable("ins-gps-kf"), "replay", "--recording", bag, "--model", kf_model,
                    "--out", str(work / "s_replay" / "trajectory.csv"), "--quiet"], bag, hours["replay"],
                   "64 Hz IMU + 1 Hz GPS, MCAP bag"),
        "diagnose": ([executable("imu-sim"), "diagnose", "--recording", diag_rec, "--scenario", scen, "--model",
                      model, "--out", str(work / "s_diag")], diag_rec, hours["diagnose"], "100 Hz CSV"),
    }
    for tool, (cmd, data, h, what) in cases.items():
        wall, cpu = _run(cmd)
        files = list(Path(data).rglob("*")) if Path(data).is_dir() else [Path(data)]
        size = sum(f.stat().st_size for f in files)
        print(f"  {tool:8s}: {cpu / h:7.0f} CPU-s per recording-hour ({cpu:.1f} CPU-s, {wall:.1f} s wall on "
              f"{h:g} h); input {size / h / 1e6:.0f} MB per hour ({what})")


def main() -> int:
    """Parse the options, run the parts, print the figures."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="2 recordings of 5 minutes (a smoke run)")
    p.add_argument("--recordings", type=int, default=4, help="recordings in the speed part (default 4)")
    p.add_argument("--hours", type=float, default=1.0, help="hours per recording (default 1)")
    p.add_argument("--only", choices=("speed", "sizing"), default=None)
    args = p.parse_args()
    n, hours = (2, 5 / 60) if args.quick else (args.recordings, args.hours)
    sizing_h = {"allan": hours, "replay": hours, "diagnose": min(hours, 0.25)}  # diagnose: scaled from 15 min
    work = Path(tempfile.mkdtemp(prefix="bench_nav_batch-"))
    try:
        for part in ("speed", "sizing"):
            (work / part).mkdir()
        if args.only in (None, "speed"):
            bench_speed(work / "speed", n, hours)
        if args.only in (None, "sizing"):
            bench_sizing(work / "sizing", sizing_h)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
