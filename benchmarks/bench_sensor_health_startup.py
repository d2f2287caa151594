"""Sensor health on faults present from the first sample (no healthy stretch to compare with): delay, naming and
false events at the start, against the sensor model.

    .venv/bin/python benchmarks/bench_sensor_health_startup.py [--seeds 20] [--quick]

The drives and the unit come from ``health_drives`` (not imu_sim), the model from ``imu-calib allan`` on a 1-h
static run as a user would (``bench_sensor_health.fitted_model``), with the unit's turn-on repeatability stated in
it as a datasheet gives it (``info: turn_on_bias_repeatability``: the generator's 5 x bias sd). Faults from t = 0 on
60-s drives (seeds 9800..): noise x3 and a 3-sigma line at 5-25 Hz on channel seed % 6, a turn-on bias of
10 x the stated repeatability on gx gy gz (seed % 3) and on az. Healthy starts: the first 120 s of the benchmark's
1-h healthy drives (seeds 9000..) and of 60-s level standing runs (seeds 9900..).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import health_drives as hd  # noqa: E402
from bench_sensor_health import fitted_model  # noqa: E402

from sensor_health.events import CHANNELS  # noqa: E402
from sensor_health.monitor import HealthMonitor  # noqa: E402
from sensor_health.startup import REPEATABILITY_KEY, STARTUP_S  # noqa: E402

REPEATABILITY = {"gyro": 5 * hd.SENSOR["gyro"]["gm_sd"], "accel": 5 * hd.SENSOR["accel"]["gm_sd"]}
FAULTS = {"white_noise_increase": range(6), "vibration": range(6), "turn_on_bias gyro": (0, 1, 2),
          "turn_on_bias accel": (5,)}
TARGET_S = {"white_noise_increase": "5", "vibration": "10", "turn_on_bias gyro": "-", "turn_on_bias accel": "-"}
"""Issue 26's delay targets (none is stated for a turn-on bias: it is tested once the first STARTUP_S are in)."""


def stated(model):
    """The fitted model with the datasheet's turn-on repeatability (1 sd, SI)."""
    model = model.copy()
    model.gyro.info[REPEATABILITY_KEY] = REPEATABILITY["gyro"]
    model.accel.info[REPEATABILITY_KEY] = REPEATABILITY["accel"]
    return model


def monitor(model, base, t, x):
    """(events, turn-on observability) of the whole record."""
    mon = HealthMonitor(model, keep_trace=False, thresholds=base.thr)
    events = mon.push(t, x[:, :3], x[:, 3:])
    return events, mon.observability()["turn_on_bias"]


def fault_run(model, base, fault, seed):
    """One run with ``fault`` from the first sample: (channel, first sample's time, events, turn-on observability)."""
    rng = np.random.default_rng(seed)
    chans = FAULTS[fault]
    ch = int(chans[seed % len(chans)])
    t, x = hd.drive(seed, 60.0)
    if fault.startswith("turn_on_bias"):
        x[:, ch] += 10 * REPEATABILITY["gyro" if ch < 3 else "accel"] * rng.choice([-1.0, 1.0])
    else:
        t, x, _ = hd.inject(fault, t, x, t[0], ch, rng)
    return ch, float(t[0]), *monitor(model, base, t, x)


def fault_table(model, base, seeds: int) -> None:
    """Named first, delay and false names per start-up fault."""
    print(f"{'fault from t=0':22s} {'runs':>4s} {'named 1st':>9s} {'delay med/max s':>16s} {'target':>6s}")
    for fault in FAULTS:
        good, delays = 0, []
        for seed in range(9800, 9800 + seeds):
            ch, t0, events, note = fault_run(model, base, fault, seed)
            first = events[0] if events else None
            want = fault.split(" ")[0]
            if first is not None and first.effect == want and CHANNELS[ch] in first.channels:
                good += 1
                delays.append(first.t_s - t0)
            else:
                print(f"  {fault} seed {seed} {CHANNELS[ch]}: first "
                      f"{(first.effect, first.channels, round(first.t_s, 2)) if first else None}; turn-on: {note}")
        d = np.array(delays)
        dm = f"{np.median(d):.2f}/{np.max(d):.2f}" if len(d) else "-"
        print(f"{fault:22s} {seeds:4d} {100 * good / seeds:8.0f}% {dm:>16s} {TARGET_S[fault]:>6s}", flush=True)


def healthy_starts(model, seeds: int) -> None:
    """Events in the first 120 s of the benchmark's healthy drives and of standing runs (none expected)."""
    base = HealthMonitor(model)
    for name, first_seed, make in (("healthy drives' starts (120 s of the 1-h drives)", 9000,
                                    lambda s: hd.drive(s, 3600.0)),
                                   ("level standing starts (60 s)", 9900, lambda s: hd.static_run(s, 60.0))):
        false, tested = 0, 0
        for seed in range(first_seed, first_seed + seeds):
            t, x = make(seed)
            keep = t < t[0] + 120.0
            events, note = monitor(model, base, t[keep], x[keep])
            tested += note.startswith("tested")
            false += len(events)
            for e in events:
                print(f"  false event, {name} seed {seed}: {e.effect} {e.channels} at {e.t_s:.2f} s: {e.message}")
        print(f"{name}: {seeds} starts, {false} events; turn-on bias tested on {tested} (unaccelerated start)",
              flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--quick", action="store_true", help="3 seeds")
    args = p.parse_args(argv)
    seeds = 3 if args.quick else args.seeds
    start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        model = stated(fitted_model(Path(tmp)))
    base = HealthMonitor(model)
    sth = base.startup.sth
    print(f"model: imu-calib allan on a 1-h static run, turn-on repeatability stated {REPEATABILITY}; thresholds "
          f"{time.time() - start:.1f} s; start-up: {sth.looks} windows, {sth.p_look:.2g} per look and test")
    fault_table(model, base, seeds)
    healthy_starts(model, seeds)
    print(f"total {time.time() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
