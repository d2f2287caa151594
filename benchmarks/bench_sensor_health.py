"""Sensor health on drives it did not make: detection delay, naming, onset error and false events per 10 h.

    .venv/bin/python benchmarks/bench_sensor_health.py [--healthy-hours 20] [--healthy-first-seed 9000] [--seeds 20]
        [--quick] [--faults saturation bias_shift_gyro ...] [--no-scale] [--only-scale] [--no-gnss]

The drives come from ``health_drives`` (motion and true IMU output by ``independent_gen``, no imu_sim code); the
sensor model is fitted by ``imu-calib allan`` from a 1-h static run of the same unit, as a user would. Faults
start 300 s into 420-s drives; healthy drives are 1 h each, seeds 9000.. (healthy) and 9500.. (faults). Fault and
healthy runs get 1-Hz GNSS fixes along the motion (``--no-gnss``: the IMU alone); runs that miss a target and
every false event are printed with what came first. The GNSS fixes have 5-cm horizontal and 10-cm vertical white
noise. The gz scale-factor section: a +2 % step at 1500 s of 2400-s drives (seeds 9700..), and the scale test alone
on the healthy drives. ``--floor``: what the gyro's own white noise allows a gyro bias test at best.
``--bias-tail HOURS``: the bias CUSUMs' false alarms counted per channel on HOURS of the model's simulated noise.
``--track-tail HOURS``: the gz and ax track tests' false alarms counted (one per excursion over the gate) on HOURS
of their own Monte Carlo noise; ``--track-gate-offset AX GZ``: what-if rows with those gates lowered.
Targets (issue 26): deterministic faults <= 1 s, noise x3 <= 5 s, a 3-sigma line <= 10 s, a 10 x bias-sd step
<= 30 s; the right effect and channel first in >= 95 %; onset within 2 s for steps; <= 1 false event per 10 h.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import health_drives as hd  # noqa: E402

from nav_core import sensor_model  # noqa: E402
from nav_core.recording import ImuRecording, write_imu_csv  # noqa: E402
from sensor_health.events import CHANNELS  # noqa: E402
from nav_core.earth import radii  # noqa: E402
from sensor_health import threshold_cache, thresholds as thr  # noqa: E402
from sensor_health.config import HealthConfig  # noqa: E402
from sensor_health.monitor import HealthMonitor  # noqa: E402
from sensor_health.yaw_scale import YawScaleMonitor  # noqa: E402

VENV_BIN = Path(sys.executable).parent
FAULT_CHANNELS = {"stuck_output": range(6), "non_finite": range(6), "white_noise_increase": range(6),
                  "vibration": range(6), "bias_shift_gyro": (0, 1), "bias_shift_accel": (5,), "saturation": (2,),
                  "dropout": (0,), "sample_rate_change": (0,), "bias_shift_gyro_z": (2,), "bias_shift_accel_x": (3,),
                  "bias_shift_accel_y": (4,), "az_scale_1pct": (5,)}
TARGET_S = {"stuck_output": 1, "non_finite": 1, "saturation": 1, "dropout": 1, "sample_rate_change": 1,
            "white_noise_increase": 5, "vibration": 10, "bias_shift_gyro": 30, "bias_shift_accel": 30,
            "bias_shift_gyro_z": 30, "bias_shift_accel_x": 30, "bias_shift_accel_y": 30,
            "az_scale_1pct": 30}
ALL_CHANNELS = ("dropout", "sample_rate_change")


def fitted_model(folder: Path):
    """imu-calib allan on a 1-h static run of the unit (the user's way to the model)."""
    t, x = hd.static_run(5000, 3600.0)
    write_imu_csv(folder / "static.csv", ImuRecording(t, x[:, :3], x[:, 3:]))
    subprocess.run([str(VENV_BIN / "imu-calib"), "allan", str(folder / "static.csv"), "--out", str(folder / "calib"),
                    "--no-progress"], check=True, capture_output=True)
    return sensor_model.load(folder / "calib" / "sensor_model.yaml")


def healthy(model, base, hours: int, gnss=True, first_seed=9000):
    """False events over ``hours`` 1-h drives (seeds from ``first_seed``) with 1-Hz GNSS (``gnss``): Counter of
    effect; each event printed."""
    count = Counter()
    for seed in range(first_seed, first_seed + hours):
        t, x = hd.drive(seed, 3600.0)
        mon = HealthMonitor(model, keep_trace=False, thresholds=base.thr)
        events = mon.push_gnss(*gnss_fixes(seed, 3600.0, np.random.default_rng(seed + 100000))) if gnss else []
        for e in events + mon.push(t, x[:, :3], x[:, 3:]):
            count[e.effect] += 1
            print(f"  false event, seed {seed}: {e.effect} {e.channels} at {e.t_s:.1f} s: {e.message}", flush=True)
    return count


def fault_run(model, base, fault, seed, gnss=True):
    """One fault run with 1-Hz GNSS fixes along the drive (``gnss``): (truth, all events)."""
    rng = np.random.default_rng(seed)
    chans = FAULT_CHANNELS[fault]
    ch = int(chans[seed % len(chans)])
    t, x = hd.drive(seed, 420.0)
    if fault == "saturation":  # the unit clips below its configured range (the monitor is not told the level)
        after = t >= 300.0
        level = 0.8 * np.max(np.abs(x[after, ch]))
        x[after, ch] = np.clip(x[after, ch], -level, level)
        onset = float(t[after][np.argmax(np.abs(x[after, ch]) >= level)])
        truth = {"effect": "saturation", "channel": ch, "onset_s": onset}
    elif fault == "az_scale_1pct":
        # az's scale up 1 % on a level drive: its mean moves by 0.01 g, exactly as a bias does, and the only right
        # name there is bias_shift az (health.json says the az scale is not observable on such a record)
        after = t >= 300.0
        x[after, ch] *= 1.01
        truth = {"effect": "bias_shift", "channel": ch, "onset_s": float(t[after][0])}
    else:
        t, x, truth = hd.inject(fault, t, x, 300.0, ch, rng)
    mon = HealthMonitor(model, keep_trace=False, thresholds=base.thr)
    events = mon.push_gnss(*gnss_fixes(seed, 420.0, rng)) if gnss else []
    events += mon.push(t, x[:, :3], x[:, 3:])
    return truth, sorted(events, key=lambda e: e.t_s)


GNSS_SD_M, GNSS_H_SD_M = 0.05, 0.10
"""White horizontal and vertical position noise of the benchmark's GNSS fixes (1 Hz), m."""
SCALE_STEP, SCALE_ONSET_S, SCALE_DRIVE_S = 0.02, 1500.0, 2400.0


def gnss_fixes(seed: int, duration_s: float, rng):
    """1-Hz fixes (t, lat, lon rad, height m) along the drive ``hd.drive(seed, duration_s)`` makes (its RoadDrive,
    ENU, level)."""
    motion = hd.RoadDrive(duration_s, np.random.default_rng(seed))  # hd.drive's first draws: the same motion
    t = np.arange(0.0, duration_s, 1.0)
    p = motion.position(t)[0][:, :2] + rng.normal(0.0, GNSS_SD_M, (len(t), 2))
    h = hd.SITE[2] + rng.normal(0.0, GNSS_H_SD_M, len(t))
    lat0, lon0 = np.radians(hd.SITE[0]), np.radians(hd.SITE[1])
    rn, re = radii(lat0)
    return t, lat0 + p[:, 1] / rn, lon0 + p[:, 0] / (re * np.cos(lat0)), h


def scale_section(model, base, seeds: int, hours: int) -> None:
    """A +2 % gz scale step at 1500 s of 2400-s drives with GNSS (the whole monitor: delay, named first, estimate),
    and false scale events on ``hours`` 1-h healthy drives with GNSS (the scale test alone)."""
    rows = []
    for seed in range(9700, 9700 + seeds):
        rng = np.random.default_rng(seed)
        t, x = hd.drive(seed, SCALE_DRIVE_S)
        x[t >= SCALE_ONSET_S, 2] *= 1.0 + SCALE_STEP
        mon = HealthMonitor(model, keep_trace=False, thresholds=base.thr)
        events = mon.push_gnss(*gnss_fixes(seed, SCALE_DRIVE_S, rng)) + mon.push(t, x[:, :3], x[:, 3:])
        after = [e for e in events if e.t_s >= SCALE_ONSET_S - 1.0]
        first = after[0] if after else None
        good = first is not None and (first.effect, first.channels) == ("scale_factor_change", ["gz"])
        rows.append((good, first.t_s - SCALE_ONSET_S if good else np.inf,
                     first.onset_s - SCALE_ONSET_S if good else np.nan, first.estimate if good else np.nan,
                     sum(e.t_s < SCALE_ONSET_S - 1.0 for e in events),
                     f"seed {seed}: first after the onset "
                     f"{(first.effect, first.channels, round(first.t_s, 1)) if first else None}; "
                     f"{mon.yaw_scale.observability()}"))
    r = np.array([row[:5] for row in rows], float)
    d = r[r[:, 0] == 1, 1]
    print(f"gz scale +{100 * SCALE_STEP:g} % at {SCALE_ONSET_S:g} s ({seeds} drives of {SCALE_DRIVE_S:g} s, GNSS "
          f"{GNSS_SD_M} m): named first {100 * r[:, 0].mean():.0f} %, delay median/max "
          f"{np.median(d) if len(d) else np.inf:.0f}/{np.max(d) if len(d) else np.inf:.0f} s, onset error median "
          f"{np.nanmedian(np.abs(r[:, 2])) if len(d) else np.nan:.0f} s, estimate median "
          f"{100 * np.nanmedian(r[:, 3]) if len(d) else np.nan:.2f} %, events before the onset {int(r[:, 4].sum())}")
    for row in rows:
        if not row[0]:
            print(f"  missed: {row[5]}")
    false, observable = 0, 0
    for seed in range(9000, 9000 + hours):
        rng = np.random.default_rng(seed + 100000)
        t, x = hd.drive(seed, 3600.0)
        mon = YawScaleMonitor(model, base.thr.budget_per_10h / thr.N_TESTS)
        false += len(mon.push_gnss(*gnss_fixes(seed, 3600.0, rng)[:3]) + mon.push_imu(t, x[:, 2]))
        observable += mon.observability().startswith("observable")
    print(f"gz scale, healthy drives with GNSS: {hours} h ({observable} observable), {false} false scale events = "
          f"{10 * false / max(hours, 1):.2f} per 10 h (this test's share of the budget: "
          f"{base.thr.budget_per_10h / thr.N_TESTS:.3f})")


def floor_section(share_per_10h: float, runs: int = 4000) -> None:
    """The information floor of a gyro bias step (10 x the unit's bias sd): a test that knew the true rate exactly
    (a perfect attitude reference) still sees the bias through the gyro's own white noise, so the ideal test is a
    CUSUM on 1-s means of white noise (the step in sd of a 1-s mean, k 0.5, h at the run length of the test's share
    of the false-event budget, ``share_per_10h``) and the best change point is maximum likelihood over the samples.
    Prints the delays and onset errors that allows."""
    rng = np.random.default_rng(0)
    white = hd.SENSOR["gyro"]["white"]
    delta = 10 * hd.SENSOR["gyro"]["gm_sd"] / white  # the step in sd of a 1-s mean
    k = 0.5
    target = thr.SECONDS_PER_10H / share_per_10h
    z = rng.normal(size=400000)
    h = thr.cusum_threshold(np.column_stack([z, -z]), k, 2 * target)  # per side: half the share
    s, d = np.zeros(runs), np.full(runs, np.nan)
    for _ in range(300):  # the CUSUM's state on healthy data when the step comes
        s = np.maximum(0.0, s + rng.normal(size=runs) - k)
    for w in range(1, 200):
        s = np.maximum(0.0, s + rng.normal(size=runs) + delta - k)
        d[np.isnan(d) & (s > h)] = w
    max20 = np.mean([np.max(rng.choice(d, 20)) for _ in range(500)])
    print(f"floor, gyro bias step {delta:.2f} sd of a 1-s mean (k {k}, h {h:.2f} for {share_per_10h:.3g} false events "
          f"per 10 h): delay median {np.median(d):.0f} s, "
          f"95 % {np.percentile(d, 95):.0f} s, P(> 30 s) {np.mean(d > 30):.3f}, expected max of 20 runs {max20:.1f} s")
    sig, fs, err = white * np.sqrt(hd.RATE_HZ), int(hd.RATE_HZ), []
    for _ in range(1000):
        x = rng.normal(0.0, sig, 76 * fs)
        x[60 * fs:] += 10 * hd.SENSOR["gyro"]["gm_sd"]
        cs = np.cumsum(x - x.mean())
        j = np.arange(2, len(x) - 1)
        err.append((j[np.argmax(cs[j - 1] ** 2 / (j * (len(x) - j)))] - 60 * fs) / fs)
    err = np.abs(err)
    print(f"floor, its change point (ML over 60 s before and 16 s after): |error| median {np.median(err):.2f} s, "
          f"within 2 s in {100 * np.mean(err <= 2):.0f} %, 90 % {np.percentile(err, 90):.1f} s")


def filter_floor_section(model, base, runs: int = 4000, before: int = 600, after: int = 120) -> None:
    """The gx bias step (10 x the unit's bias sd) through the monitor's own bias filter (a scalar random walk of the
    model's K: the motion regressors are nil on a straight) and its CUSUM at the monitor's k and h, on white noise and
    on the model's wander (``bias_tail.slow_terms``), and with the bias before the step known (no walk): what the
    filter that follows the unit's wander costs against the ideal test of ``floor_section``."""
    from sensor_health.bias_tail import slow_terms
    th, c = base.thr, 0
    rng = np.random.default_rng(2)
    sd, k, h, n = th.bias_sd[c], th.bias_k[c], th.bias_h[c], before + after
    step = 10 * hd.SENSOR["gyro"]["gm_sd"]
    phi, gsd, rw = slow_terms(model, c, th.window_s)
    for label, wander, q in (("white noise", False, th.bias_q[c]), ("the model's wander", True, th.bias_q[c]),
                             ("white noise, the bias before the step known", False, 0.0)):
        y = sd * rng.normal(size=(runs, n))
        if wander:
            for p_, s_ in zip(phi, gsd):
                g = rng.normal(size=runs) * s_ / np.sqrt(1 - p_ * p_)
                for w in range(n):
                    g = p_ * g + s_ * rng.normal(size=runs)
                    y[:, w] += g
            y += np.cumsum(rw * rng.normal(size=(runs, n)), axis=1)
        y[:, before:] += step
        b, var, r = y[:, 0].copy(), sd**2, sd**2
        pos, neg, d = np.zeros(runs), np.zeros(runs), np.full(runs, np.inf)
        for w in range(1, n):
            var += q
            z = (y[:, w] - b) / np.sqrt(var + r)
            b, var = b + var / (var + r) * (y[:, w] - b), var * r / (var + r)
            if w < thr.bias_warmup_windows(th.window_s):
                continue
            pos, neg = np.maximum(0.0, pos + z - k), np.maximum(0.0, neg - z - k)
            if w < before:
                hit = (pos > h) | (neg > h)
                pos[hit], neg[hit] = 0.0, 0.0
            else:
                d[np.isinf(d) & (pos > h)] = w - before + 1
        max20 = np.median([np.max(rng.choice(d, 20)) for _ in range(2000)])
        print(f"floor with the monitor's gx filter (h {h:.2f}, k {k:.2f}), {label}: delay median {np.median(d):.0f} s, "
              f"95 % {np.percentile(d, 95):.0f} s, P(> 30 s) {np.mean(d > 30):.3f}, median max of 20 runs "
              f"{max20:.0f} s", flush=True)


def track_floor_section(share_per_10h: float, runs: int = 2000, speed_m_s: float = 15.0,
                        ref_sd_rad_s: float = 2.2e-4) -> None:
    """What the gz test against the GNSS track (cross_track's window-limited GLR at its gate) allows for a 10 x
    bias-sd step (2e-3 rad/s) at ``speed_m_s`` on 1-Hz fixes with the benchmark's noise, on the straight its gate is
    drawn on (no learning, no turns: a bound on the monitor's figures): with the learned bias' error
    ``ref_sd_rad_s`` (the monitor's on these drives: the fitted bias instability 1.7e-4 and the learned bias' sd
    1.4e-4, together) and with the bias before the step known exactly."""
    from sensor_health import cross_track as ct
    n = ct.SPAN_EPOCHS
    tau, length = np.arange(n, dtype=float), np.ones(n)
    rel = speed_m_s / GNSS_SD_M  # rad/s -> fix-noise sd per s of a 1-s chord
    arw, step = hd.SENSOR["gyro"]["white"] * rel, 10 * hd.SENSOR["gyro"]["gm_sd"] * rel
    base = np.column_stack([np.ones(n), np.cumsum(length)])
    steps = ct.step_columns(tau, length)
    rng = np.random.default_rng(1)
    for ref_sd in (ref_sd_rad_s * rel, 0.0):
        gate = ct.glr_gate(share_per_10h, float(f"{arw:.2g}"), float(f"{ref_sd:.2g}"))
        ci = ct.drift_inverse_covariance(length, tau, arw, 1.0, ref_sd)
        delays = np.full(runs, np.inf)
        for r in range(runs):
            after = 2 * n
            course_err = np.diff(rng.normal(size=n + after + 1))
            k = np.arange(n + after)
            heading = np.cumsum(arw * rng.normal(size=n + after)) + step * np.maximum(k - n + 1, 0)
            d = np.lib.stride_tricks.sliding_window_view(course_err - heading, n)[1:after + 1]
            y = np.cumsum(d - d[:, :1] - ref_sd * rng.normal() * np.arange(n), axis=1)
            b, sd = ct.glr(ci, base, steps, y)
            over = np.flatnonzero(np.abs(b / sd).max(axis=1) > gate)
            if len(over):
                delays[r] = over[0] + 1.0  # spans ending 1.. s after the step
        max20 = np.median([np.max(rng.choice(delays, 20)) for _ in range(2000)])
        print(f"floor, gz bias step against the track, glr ({speed_m_s:g} m/s, learned-bias error "
              f"{ref_sd / rel:.2g} rad/s, gate {gate:.2f} for {share_per_10h:.3g} per 10 h): delay median "
              f"{np.median(delays):.0f} s, 95 % {np.percentile(delays, 95):.0f} s, "
              f"P(> 30 s) {np.mean(delays > 30):.3f}, "
              f"median max of 20 runs {max20:.1f} s, all 20 within 30 s in {100 * np.mean(delays <= 30) ** 20:.0f} % "
              f"of 20-run benchmarks, never within {after} s {np.mean(np.isinf(delays)):.3f}")


def track_tail_section(along, hours: float, speed_m_s: float = 15.0, ref_sd_rad_s: float = 2.2e-4) -> None:
    """The gz and ax track tests' false alarms counted (one per excursion of the statistic over the gate) on
    ``hours`` of their own Monte Carlo noise in independent 20000-fix drives (seeds other than the gates'; ax: the
    gate and ax noise of ``along``, the fitted model's monitor's AlongTrackMonitor): the measured rate at the gate
    against the share, and the gate the counts give for it."""
    from sensor_health import along_track as at, cross_track as ct
    from sensor_health.bias_tail import threshold_for
    share, chunk = HealthConfig().track_bias_per_10h, 20000
    rel = speed_m_s / GNSS_SD_M
    arw, ref_sd = float(f"{hd.SENSOR['gyro']['white'] * rel:.2g}"), float(f"{ref_sd_rad_s * rel:.2g}")
    tests = {"ax": (along.gate, lambda rng: at.simulated_z(chunk, rng, along.ax_noise)),
             "gz": (ct.glr_gate(share, arw, ref_sd), lambda rng: np.abs(ct.straight_glr_z(
                 ct.simulated_drifts(chunk, arw, ref_sd, rng), arw, ref_sd)).max(axis=1))}
    for name, (gate, sim) in tests.items():
        start, maxima, fixes = time.process_time(), [], 0
        for i in range(int(np.ceil(hours * 3600.0 / chunk))):
            z = sim(np.random.default_rng(7000 + i))
            fixes += len(z)
            maxima.append(thr.excursion_maxima(z, 3.0))
        maxima, h_run = np.concatenate(maxima), fixes / 3600.0
        n = int(np.count_nonzero(maxima > gate))
        h, how = threshold_for(maxima, h_run, share)
        print(f"track tail {name}: gate {gate:.2f} (the package's); counted on "
              f"{h_run:.0f} h: {n} alarms = {10 * n / h_run:.4f} per 10 h (share {share}); the counts' gate for the "
              f"share {h:.2f} ({how}); {time.process_time() - start:.0f} s CPU", flush=True)


def lower_track_gates(ax_sd: float, gz_sd: float) -> None:
    """What-if: the monitors' ax and gz track gates lowered by ``ax_sd`` and ``gz_sd`` (not the package's gates)."""
    from sensor_health import along_track as at, cross_track as ct
    os.environ[threshold_cache.ENV] = threshold_cache.OFF  # a lowered gate must neither come from nor go to the cache
    ax_gate, gz_gate = at.z_gate, ct.glr_gate
    at.z_gate = lambda *a, **k: ax_gate(*a, **k) - ax_sd
    ct.glr_gate = lambda *a, **k: gz_gate(*a, **k) - gz_sd
    print(f"what-if: track gates lowered by ax {ax_sd} sd, gz {gz_sd} sd", flush=True)


def bias_tail_section(model, base, hours: float) -> None:
    """The bias CUSUMs' false alarms counted on ``hours`` of simulated window means of the model's noise per channel
    (``bias_tail``, seeds other than the monitor's) at the thresholds the monitor set: the measured false rate per
    channel against its share."""
    from scipy import stats as st
    from sensor_health import noise_sim
    from sensor_health.bias_tail import bias_tail
    from sensor_health.window_stats import window_stats
    th = base.thr
    x = noise_sim.model_noise(model, 4000 * base.grid.n, base.grid.dt, np.random.default_rng(99))
    levels = window_stats(base.grid, x.reshape(4000, base.grid.n, 6)).level
    cfg = base.config
    for c in thr.BIAS_CHANNELS:
        share = cfg.gyro_bias_per_10h if c < 2 and cfg.gyro_bias_per_10h > 0 else th.budget_per_10h / thr.N_TESTS
        start = time.process_time()
        tail = bias_tail(model, c, th.window_s, th.bias_sd[c], levels[:, c], th.bias_q[c], th.bias_k[c], share,
                         hours, thr.bias_warmup_windows(th.window_s), seed=1000 + c, split=False)
        n = int(np.count_nonzero(tail.maxima > th.bias_h[c]))
        lo, hi = (st.chi2.ppf(0.025, 2 * n) / 2 if n else 0.0), st.chi2.ppf(0.975, 2 * n + 2) / 2
        print(f"bias tail {CHANNELS[c]}: h {th.bias_h[c]:.2f} (k {th.bias_k[c]:.2f}, {th.bias_h_how[c]} from "
              f"{th.bias_tail_hours:g} h at start); counted on {hours:g} h of the model's noise: {n} alarms = "
              f"{10 * n / hours:.4f} per 10 h [{10 * lo / hours:.4f}, {10 * hi / hours:.4f}] (share {share:.4f}); "
              f"h for the share on this run {tail.h:.2f} ({tail.how}); {time.process_time() - start:.0f} s CPU",
              flush=True)


def named(truth, e) -> bool:
    """The right effect, and the right channel where the effect has one."""
    if e.effect != truth["effect"]:
        return False
    return truth["effect"] in ALL_CHANNELS or CHANNELS[truth["channel"]] in e.channels


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--healthy-hours", type=int, default=20)
    p.add_argument("--healthy-first-seed", type=int, default=9000,
                   help="seed of the first healthy drive (to split the hours over processes)")
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--quick", action="store_true", help="1 h healthy, 2 seeds per fault, 1 scale drive")
    p.add_argument("--scale-seeds", type=int, default=10, help="gz scale-step drives (2400 s each)")
    p.add_argument("--scale-hours", type=int, default=20, help="healthy 1-h drives with GNSS for the scale test")
    p.add_argument("--only-scale", action="store_true", help="the scale-factor section alone")
    p.add_argument("--no-scale", action="store_true", help="skip the gz scale-factor section")
    p.add_argument("--faults", nargs="*", default=list(FAULT_CHANNELS), choices=list(FAULT_CHANNELS),
                   help="the fault sections to run (all by default; none: the healthy drives only)")
    p.add_argument("--floor", action="store_true", help="the information floor of a gyro bias step alone")
    p.add_argument("--bias-tail", type=float, default=0.0, metavar="HOURS",
                   help="the bias CUSUMs' false rate per channel counted on HOURS of simulated model noise, alone")
    p.add_argument("--track-tail", type=float, default=0.0, metavar="HOURS",
                   help="the gz and ax track tests' false rate counted on HOURS of their Monte Carlo noise, alone")
    p.add_argument("--track-gate-offset", type=float, nargs=2, default=None, metavar=("AX", "GZ"),
                   help="what-if: the ax and gz track gates lowered by these (sd), e.g. to the counted ones")
    p.add_argument("--no-gnss", action="store_true",
                   help="IMU alone (no 1-Hz GNSS fixes) in the fault and healthy runs")
    args = p.parse_args(argv)
    if args.quick:
        args.healthy_hours, args.seeds, args.scale_seeds, args.scale_hours = 1, 2, 1, 1
    start = time.time()
    if args.track_gate_offset:
        lower_track_gates(*args.track_gate_offset)
    if args.floor:
        cfg = HealthConfig()
        for share in sorted({cfg.false_alarms_per_10h / thr.N_TESTS, cfg.gyro_bias_per_10h or 0.1}):
            floor_section(share)
    with tempfile.TemporaryDirectory() as tmp:
        model = fitted_model(Path(tmp))
    base = HealthMonitor(model)
    if args.track_tail > 0:
        track_tail_section(base.along_track, args.track_tail)
        return 0
    if args.floor:
        filter_floor_section(model, base)
        track_floor_section(cfg.track_bias_per_10h)
        return 0
    print(f"model: imu-calib allan on a 1-h static run; thresholds {time.time() - start:.1f} s; "
          f"stuck run {base.thr.stuck_run.tolist()} samples, line gate {base.thr.line_h:.1f}, "
          f"noise h {base.thr.noise_h:.2f}, bias h {np.round(base.thr.bias_h, 2).tolist()}")
    if args.bias_tail > 0:
        bias_tail_section(model, base, args.bias_tail)
        return 0
    if not args.no_scale:
        scale_section(model, base, args.scale_seeds, args.scale_hours)
    if args.only_scale:
        return 0
    print(f"{'fault':22s} {'runs':>4s} {'named 1st':>9s} {'delay med/max s':>16s} {'target':>6s} "
          f"{'onset err med/max s':>20s}")
    ok_all = True
    for fault in args.faults:
        rows = []
        for seed in range(9500, 9500 + args.seeds):
            truth, events = fault_run(model, base, fault, seed, gnss=not args.no_gnss)
            first = next((e for e in events if e.t_s >= truth["onset_s"] - 1.0), None)
            good = first is not None and named(truth, first)
            delay = first.t_s - truth["onset_s"] if good else np.inf
            onset_err = abs(first.onset_s - truth["onset_s"]) if good else np.inf
            false_before = sum(e.t_s < truth["onset_s"] - 1.0 for e in events)
            rows.append((good, delay, onset_err, false_before))
            if not good or delay > TARGET_S[fault] or onset_err > 2.0:
                seen = (first.effect, first.channels, round(first.t_s - truth["onset_s"], 2),
                        round(first.onset_s - truth["onset_s"], 2)) if first else None
                print(f"  {fault} seed {seed} {CHANNELS[truth['channel']]}: first (effect, channels, delay, onset "
                      f"error) {seen}", flush=True)
        r = np.array(rows, float)
        rate = r[:, 0].mean()
        d = r[r[:, 0] == 1, 1]
        o = r[r[:, 0] == 1, 2]
        dm = f"{np.median(d):.2f}/{np.max(d):.2f}" if len(d) else "-"
        om = f"{np.median(o):.2f}/{np.max(o):.2f}" if len(o) else "-"
        met = rate >= 0.95 and len(d) and np.max(d) <= TARGET_S[fault]
        ok_all &= bool(met)
        print(f"{fault:22s} {len(r):4d} {100 * rate:8.0f}% {dm:>16s} {TARGET_S[fault]:6d} {om:>20s}"
              f"  {'met' if met else 'NOT met'}  (events before the onset: {int(r[:, 3].sum())})", flush=True)
    count = healthy(model, base, args.healthy_hours, gnss=not args.no_gnss, first_seed=args.healthy_first_seed)
    total = sum(count.values())
    rate = 10 * total / max(args.healthy_hours, 1)
    print(f"healthy drives: {args.healthy_hours} h from seed {args.healthy_first_seed}, {total} false events = "
          f"{rate:.2f} per 10 h (target <= 1) "
          f"{dict(count)}")
    print(f"wall time {time.time() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
