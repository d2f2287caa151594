"""``sensor-health --recording REC [--gnss G.csv] --model M.yaml --out DIR``: the health monitor on a recording.

Writes ``DIR/health.json`` (``{"events": [...], "checked_s": [t0, t1], ...}``) and ``DIR/health.png`` (the
monitored statistics with the events marked). The samples are pushed in pieces of ``--chunk-s`` s, like the
node's intake; the events do not depend on the split.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from nav_core import recording, sensor_model
from nav_core.cli import about, add_common, number, parse_args, run_cli
from nav_core.outputs import staged_dir
from nav_core.units import deg2rad, g2mps2
from sensor_health.events import EFFECTS, _finite
from sensor_health.monitor import HealthConfig, HealthMonitor
from sensor_health.plot import plot_health


def build_parser() -> argparse.ArgumentParser:
    """The CLI's options."""
    p = argparse.ArgumentParser(prog="sensor-health", **about(
        "Name IMU faults in a recording (effect, channel, onset): health.json and health.png.",
        "sensor-health --recording my_bag --model out/my_imu/sensor_model.yaml --out out/health"))
    p.add_argument("--recording", required=True, type=Path, help="rosbag2 bag or recording CSV (imu/data_raw)")
    p.add_argument("--gnss", type=Path, default=None, help="GNSS CSV or bag (the yaw scale factor against "
                   "the course in turns; without it the scale factor is not observable)")
    p.add_argument("--model", required=True, type=Path, help="sensor-model YAML (imu-calib allan writes one)")
    p.add_argument("--out", required=True, type=Path, help="output folder (new or empty; --force replaces it)")
    p.add_argument("--false-alarms-per-10h", type=number(0, None, low_open=True),
                   default=HealthConfig.false_alarms_per_10h,
                   help="budget of statistical false events on the model's noise shared by the tests without a "
                        f"share of their own (default {HealthConfig.false_alarms_per_10h})")
    p.add_argument("--gyro-range-dps", type=number(0, None, low_open=True), default=300.0,
                   help="gyro range, deg/s (saturation; default 300, the BP3010's)")
    p.add_argument("--accel-range-g", type=number(0, None, low_open=True), default=10.0,
                   help="accelerometer range, g (saturation; default 10)")
    p.add_argument("--chunk-s", type=number(0, None, low_open=True), default=60.0,
                   help="samples are pushed in pieces of this many seconds (default 60)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_common(p, force=True)
    return p


def run(args) -> int:
    """Read, monitor, write; returns 0."""
    model = sensor_model.load(args.model)
    imu = in_time_order(recording.read_imu(args.recording))
    gnss = recording.read_gnss(args.gnss) if args.gnss else None
    if len(imu) < 2:
        raise recording.RecordingError(f"{args.recording}: fewer than 2 IMU samples")
    cfg = HealthConfig(false_alarms_per_10h=args.false_alarms_per_10h,
                       gyro_range_rad_s=float(deg2rad(args.gyro_range_dps)),
                       accel_range_m_s2=float(g2mps2(args.accel_range_g)))
    inputs = [args.recording, args.model] + ([args.gnss] if args.gnss else [])
    with staged_dir(args.out, args.force, inputs=inputs) as tmp:
        monitor = HealthMonitor(model, cfg, sample_rate_hz=imu.rate_hz)
        events = []
        if gnss is not None and len(gnss):
            fixed = gnss.status >= 0 if gnss.status is not None else np.ones(len(gnss), bool)  # -1: no fix
            events = monitor.push_gnss(gnss.t[fixed], gnss.lat[fixed], gnss.lon[fixed], gnss.h[fixed])
        events += monitor_recording(monitor, imu, args.chunk_s, not args.no_progress)
        result = health_document(monitor, events, imu, gnss)
        (tmp / "health.json").write_text(json.dumps(result, indent=1))
        plot_health(monitor, events, tmp / "health.png")
    print(f"sensor-health: {len(events)} events over {result['checked_s'][1] - result['checked_s'][0]:.1f} s "
          f"-> {args.out / 'health.json'}")
    for name, text in result["observability"].items():
        print(f"  {name}: {text}")
    for e in events:
        print(f"  t {e.t_s:.3f} s  {e.level:5s} {e.effect} {','.join(e.channels)}: {e.message}")
    return 0


def in_time_order(imu):
    """The samples stamped after every sample before them; the others (a repeated or earlier stamp) are skipped
    and named on stderr: the monitor takes no interval from them, but their values would enter its statistics."""
    check = recording.check_timestamps(imu.t, str(imu.source or "recording"))
    said = check.messages(("duplicates", "backwards"))
    if not said:
        return imu
    keep = imu.t > np.fmax.accumulate(np.r_[-np.inf, imu.t[:-1]])
    print(f"{'; '.join(said)}: skipped {int(np.sum(~keep))} sample(s) not after the ones before them",
          file=sys.stderr)
    return imu.select(keep)


def monitor_recording(monitor: HealthMonitor, imu, chunk_s: float, progress: bool = False) -> list:
    """Push ``imu`` in pieces of ``chunk_s`` s; all events in time order."""
    edges = np.searchsorted(imu.t, np.arange(imu.t[0], imu.t[-1] + chunk_s, chunk_s))
    edges = np.unique(np.r_[edges, len(imu.t)])
    events = []
    for a, b in tqdm(list(zip(edges[:-1], edges[1:])), disable=not progress, desc="sensor-health", unit="chunk"):
        events += monitor.push(imu.t[a:b], imu.gyro[a:b], imu.accel[a:b])
    return events


def health_document(monitor: HealthMonitor, events, imu, gnss=None) -> dict:
    """The health.json content."""
    doc = {"events": [e.to_dict() for e in events], "checked_s": monitor.checked_s,
           "source": str(imu.source), "samples": len(imu), "sample_rate_hz": 1.0 / monitor.dt,
           "windows": monitor.windows, "thresholds": monitor.thr.to_dict(), "vocabulary": EFFECTS,
           "observability": monitor.observability(), "scale_threshold": monitor.yaw_scale.h,
           "cleared": monitor.cleared}
    if gnss is not None and len(gnss):
        doc["gnss_checked_s"] = [float(gnss.t[0]), float(gnss.t[-1])]
    return _finite(json.loads(json.dumps(doc, default=_plain)))


def _plain(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON: {type(x).__name__}")


def main(argv=None) -> int:
    """Console script ``sensor-health``."""
    return run_cli("sensor-health", run, parse_args(build_parser(), argv))
