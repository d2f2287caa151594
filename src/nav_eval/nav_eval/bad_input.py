"""The filter on damaged GNSS and IMU input, on the simulated paper drive: largest error and speed per case.

``python -m nav_eval.bad_input [--seed N] [--scenario YAML]`` prints one line per case (the
figures of the ins_gps_kf README's **Bad input** section): 6-fix glitches of 200 m and 500 km,
stds of 0 and -1, duplicated and conflicting fixes, fix stamps stepping back 100 s, a latitude
of 221 deg, one NaN IMU sample.
"""
from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_core.earth import LocalFrame
from nav_core.recording import GnssRecording
from nav_core.units import DEG
from ins_gps_kf.filter import NAVIGATING
from nav_eval.metrics import run_case, truth_at
from nav_core.workspace import PAPER_DRIVE, workspace_file

GLITCH_T_S = 300.0  # the damage starts at this fix stamp, s
T_FROM_S = 60.0  # after alignment and the heading fix


def _rows(gnss: GnssRecording, idx=None) -> GnssRecording:
    idx = np.arange(len(gnss)) if idx is None else idx
    return GnssRecording(gnss.t[idx].copy(), gnss.lat[idx].copy(), gnss.lon[idx].copy(), gnss.h[idx].copy(),
                         gnss.std_enu[idx].copy(), gnss.status[idx].copy())


def shift_north(gnss: GnssRecording, idx, metres: float) -> GnssRecording:
    """A copy of ``gnss`` with the fixes at ``idx`` moved ``metres`` north (in the first fix's local frame)."""
    gnss = _rows(gnss)
    frame = LocalFrame(gnss.lat[0] / DEG, gnss.lon[0] / DEG, gnss.h[0])
    enu = frame.to_enu(gnss.lat[idx] / DEG, gnss.lon[idx] / DEG, gnss.h[idx])
    enu[:, 1] += metres
    lat, lon, h = frame.to_geodetic(enu)
    gnss.lat[idx], gnss.lon[idx], gnss.h[idx] = lat * DEG, lon * DEG, h
    return gnss


def cases(gnss: GnssRecording) -> dict:
    """Case name -> damaged copy of ``gnss`` (the IMU case is handled by :func:`main`)."""
    k = int(np.searchsorted(gnss.t, GLITCH_T_S))
    i = np.arange(len(gnss))
    doubled = np.sort(np.concatenate([i, i[k:k + 10]]))
    out = {"clean": _rows(gnss),
           "6 fixes 200 m off": shift_north(gnss, np.arange(k, k + 6), 200.0),
           "6 fixes 500 km off": shift_north(gnss, np.arange(k, k + 6), 500e3),
           "every std 0": _rows(gnss), "every std -1": _rows(gnss),
           "10 duplicated fixes": _rows(gnss, doubled)}
    out["every std 0"].std_enu[:] = 0.0
    out["every std -1"].std_enu[:] = -1.0
    conflicting = _rows(gnss, doubled)
    second = np.flatnonzero(np.diff(conflicting.t) == 0) + 1
    out["10 conflicting duplicates (22 m)"] = shift_north(conflicting, second, 22.0)
    out["fix stamps step back 100 s"] = _rows(gnss)
    out["fix stamps step back 100 s"].t[k:] -= 100.0
    out["latitude 221 deg"] = _rows(gnss)
    out["latitude 221 deg"].lat[k] = 221.0 * DEG
    return out


def figures(sim, gnss, model, imu=None) -> str:
    """One line: largest/RMS horizontal error and largest speed after T_FROM_S, the filter's counts."""
    est, filt = run_case(imu or sim.imu, gnss, model, {"imu_rate_hz": sim.rate_hz})
    nav = [e for e in est if e.status == NAVIGATING and e.t > T_FROM_S]
    ref = truth_at(sim.truth, filt.frame, np.array([e.t for e in nav]))
    err = np.hypot(*(np.array([e.position_n for e in nav]) - ref.enu)[:, :2].T)
    speed = np.hypot(*np.array([e.velocity_n for e in nav])[:, :2].T)
    c = filt.counters
    flagged = ", ".join(f"{k} {v}" for k, v in filt.input_counters.items() if v and k != "last_rejection")
    return (f"largest error {err.max():.2f} m, RMS {np.sqrt(np.mean(err ** 2)):.2f} m, largest speed "
            f"{speed.max():.1f} m/s, navigating epochs {len(nav)}, rejected {c.fixes_rejected}, GPS resets "
            f"{c.gps_resets}; input: {flagged or 'none'}")


def main(argv=None) -> int:
    """Print the figures of every case."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scenario", help="scenario YAML (default: the workspace's paper drive)")
    args = parser.parse_args(argv)
    model = bp3010_grade_model()
    sim = simulate(str(args.scenario or workspace_file(PAPER_DRIVE)), model=model, seed=args.seed,
                   with_bytes=False)
    top = float(np.max(np.hypot(*sim.truth.velocity_n[:, :2].T)))
    print(f"simulated paper drive, seed {args.seed}; true top speed {top:.1f} m/s; damage from t={GLITCH_T_S:.0f} s")
    for name, gnss in cases(sim.gnss).items():
        print(f"{name}: {figures(sim, gnss, model)}")
    gyro = sim.imu.gyro.copy()
    gyro[len(gyro) // 2, 0] = np.nan
    print(f"one NaN IMU sample: {figures(sim, sim.gnss, model, replace(sim.imu, gyro=gyro))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
