"""Sensor health on the real recordings of ../shared/data: events per recording (the target is none, unless a
real fault is found and shown).

    .venv/bin/python benchmarks/bench_sensor_health_real.py [--only adis|balzer|navego] [--quick]

Each recording's model is fitted by ``imu-calib allan`` as a user would: on the recording itself for the static
ADIS16405 runs (SMAC-Group/imudata, CC BY-NC-SA 4.0); on the stationary start for the drives when there are at
least 120 s of it, otherwise on the whole drive (its road vibration is then part of "the model's noise"):
balzer82/Kalman car (CC-BY-SA 2.0), NaveGo rover runs (rodralez/NaveGo, UTIAS Canada and ESA Katwijk).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from nav_core import datasets, sensor_model
from nav_eval import rovers
from nav_core.recording import write_imu_csv
from sensor_health.monitor import HealthMonitor

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
VENV_BIN = Path(sys.executable).parent


def recordings(only):
    """(name, loader, imu-calib args or None (fit on a CSV of a stretch)) of every real recording present."""
    out = []
    if only in (None, "adis"):
        for k in range(1, 7):
            p = DATA / "adis16405_static" / f"imu{k}.npz"
            out.append((f"adis16405 imu{k} (static)", lambda p=p: datasets.load_adis_npz(p),
                        [str(p), "--format", "adis"]))
    if only in (None, "balzer"):
        for p in sorted((DATA / "balzer_car").glob("*.csv")):
            out.append((f"balzer car {p.stem}", lambda p=p: datasets.read_balzer_csv(p), None))
    if only in (None, "navego"):
        nav = DATA / "navego_rover"
        for name in ("canada", "katwijk"):
            p = nav / f"{name}_imu_planetary.mat"
            out.append((f"navego {name} rover", lambda p=p: rovers.read_navego_imu(p), None))
    return out


def fit(tmp: Path, name, rec, calib_args):
    """imu-calib allan -> (model, what it was fitted on)."""
    out = tmp / name.replace(" ", "_").replace("(", "").replace(")", "")
    if calib_args is None:
        onset = rovers.motion_onset(rec.t, np.linalg.norm(rec.gyro, axis=1), rec.rate_hz)
        if onset - rec.t[0] >= 120.0:
            part, what = rec.between(rec.t[0], onset - 5.0), f"the stationary start ({onset - rec.t[0]:.0f} s)"
        else:
            part, what = rec, f"the whole drive (stationary start {onset - rec.t[0]:.0f} s < 120 s)"
        write_imu_csv(tmp / "fit.csv", part)
        calib_args = [str(tmp / "fit.csv")]
    else:
        what = "the recording itself"
    subprocess.run([str(VENV_BIN / "imu-calib"), "allan", *calib_args, "--out", str(out), "--no-progress"],
                   check=True, capture_output=True)
    return sensor_model.load(out / "sensor_model.yaml"), what


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", choices=("adis", "balzer", "navego"))
    p.add_argument("--quick", action="store_true", help="the first recording present only (the suite's smoke run)")
    args = p.parse_args(argv)
    total_h, total_events = 0.0, 0
    todo = recordings(args.only)
    with tempfile.TemporaryDirectory() as tmpdir:
        for name, load, calib_args in todo[:1] if args.quick else todo:
            start = time.time()
            try:
                rec = load()
            except (OSError, ValueError) as err:
                print(f"{name}: skipped ({err})")
                continue
            model, what = fit(Path(tmpdir), name, rec, calib_args)
            mon = HealthMonitor(model, sample_rate_hz=rec.rate_hz, keep_trace=False)
            events = []
            step = int(60 * rec.rate_hz)
            for a in range(0, len(rec.t), step):
                events += mon.push(rec.t[a:a + step], rec.gyro[a:a + step], rec.accel[a:a + step])
            hours = (rec.t[-1] - rec.t[0]) / 3600
            total_h += hours
            total_events += len(events)
            print(f"{name}: {hours:.2f} h at {rec.rate_hz:.4g} Hz, model from {what}: {len(events)} events "
                  f"({time.time() - start:.0f} s)")
            for e in events[:8]:
                print(f"    t {e.t_s:9.2f} s  {e.effect} {','.join(e.channels)}: {e.message}")
    print(f"real recordings: {total_h:.2f} h, {total_events} events")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
