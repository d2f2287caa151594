"""Accuracy figures of the filter against a truth: error RMS, GPS-outage drift, NEES/NIS consistency; one run.

Used by every evaluation in :mod:`nav_eval` (simulated paper drive, real recordings, the
paper's claims); nothing here simulates or loads a dataset.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from nav_core import frames
from nav_core.recording import GnssRecording, Trajectory
from nav_core.units import DEG
from ins_gps_kf import config
from ins_gps_kf import error_model as em
from ins_gps_kf.filter import NAVIGATING, Estimate, InsGpsFilter
from ins_gps_kf.offline import run


@dataclass
class TruthAt:
    """Truth interpolated to estimate times: ENU position (m, filter frame), velocity (m/s), roll/pitch/yaw (rad)."""

    enu: np.ndarray
    velocity_n: np.ndarray | None
    euler: np.ndarray | None


def truth_at(truth: Trajectory, frame, t) -> TruthAt:
    """Interpolate ``truth`` (geodetic) to times ``t`` (s) in ``frame``; attitude unwrapped before interpolation."""
    enu = frame.to_enu(truth.lat / DEG, truth.lon / DEG, truth.h)
    pos = np.column_stack([np.interp(t, truth.t, enu[:, i]) for i in range(3)])
    vel = None if truth.velocity_n is None else np.column_stack(
        [np.interp(t, truth.t, truth.velocity_n[:, i]) for i in range(3)])
    euler = None
    if truth.roll is not None and np.any(np.isfinite(truth.yaw)):
        euler = np.column_stack([np.interp(t, truth.t, np.unwrap(a)) for a in (truth.roll, truth.pitch, truth.yaw)])
    return TruthAt(pos, vel, euler)


def rms(x) -> float:
    """Root mean square of the finite entries of ``x`` (an epoch without a truth value is NaN and left out);
    NaN when none is finite. The one RMS of the evaluations and nav-demo's report."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def error_figures(est: list[Estimate], truth: Trajectory, frame, gnss: GnssRecording | None = None,
                  t_from: float = 0.0) -> dict:
    """Position (horizontal, vertical), velocity and attitude error RMS after ``t_from`` s; raw GPS error RMS."""
    nav = [e for e in est if e.status == NAVIGATING and e.t >= t_from]
    if not nav:
        return {"epochs": 0, "note": "never navigating (no heading) after t_from"}
    t = np.array([e.t for e in nav])
    ref = truth_at(truth, frame, t)
    pos = np.array([e.position_n for e in nav])
    d = pos - ref.enu
    out = {"epochs": len(nav), "pos_h_rms_m": rms(np.hypot(d[:, 0], d[:, 1])), "pos_u_rms_m": rms(d[:, 2]),
           "pos_h_max_m": float(np.max(np.hypot(d[:, 0], d[:, 1]))) if len(d) else float("nan")}
    if ref.velocity_n is not None:
        dv = np.array([e.velocity_n for e in nav]) - ref.velocity_n
        out["vel_rms_mps"] = rms(np.linalg.norm(dv, axis=1))
    if ref.euler is not None:
        eul = np.column_stack(frames.euler_from_quat_xyzw(np.array([e.quat_xyzw for e in nav])))
        da = frames.wrap_angle(eul - ref.euler) / DEG
        out.update({"roll_rms_deg": rms(da[:, 0]), "pitch_rms_deg": rms(da[:, 1]), "yaw_rms_deg": rms(da[:, 2])})
    if gnss is not None:
        ok = (gnss.status >= 0) & np.isfinite(gnss.lat) & (gnss.t >= t_from) & (gnss.t <= truth.t[-1])
        g = frame.to_enu(gnss.lat[ok] / DEG, gnss.lon[ok] / DEG, gnss.h[ok])
        dg = g - truth_at(truth, frame, gnss.t[ok]).enu
        out["gps_h_rms_m"] = rms(np.hypot(dg[:, 0], dg[:, 1]))
    return out


def consistency(est: list[Estimate], truth: Trajectory, frame, t_from: float = 0.0, every: int = 10) -> dict:
    """Mean position/velocity NEES (3 dof) on every ``every``-th epoch, mean GPS NIS, with 95 % chi-square bounds."""
    nav = [e for e in est if e.status == NAVIGATING and e.t >= t_from][::every]
    if not nav:
        return {}
    ref = truth_at(truth, frame, np.array([e.t for e in nav]))
    nees_p = [float(d @ np.linalg.solve(e.cov[em.DP, em.DP], d))
              for e, d in zip(nav, np.array([e.position_n for e in nav]) - ref.enu)]
    out = {"nees_pos_mean": float(np.mean(nees_p))}
    if ref.velocity_n is not None:
        out["nees_vel_mean"] = float(np.mean([float(d @ np.linalg.solve(e.cov[em.DV, em.DV], d)) for e, d in zip(
            nav, np.array([e.velocity_n for e in nav]) - ref.velocity_n)]))
    n = len(nav)
    out["nees_bounds_95"] = [float(chi2.ppf(0.025, 3 * n) / n), float(chi2.ppf(0.975, 3 * n) / n)]
    nis = np.array([e.nis for e in est if e.gps_used and np.isfinite(e.nis) and e.t >= t_from])
    if len(nis):
        m = len(nis)
        out.update({"nis_mean": float(nis.mean()), "nis_count": m,
                    "nis_bounds_95": [float(chi2.ppf(0.025, 3 * m) / m), float(chi2.ppf(0.975, 3 * m) / m)]})
    return out


def outage_windows(t_start: float, t_end: float, period_s: float, length_s: float, first_s: float):
    """GPS outage windows [t0, t0 + length) every ``period_s`` from ``first_s``, inside (t_start, t_end)."""
    starts = np.arange(first_s, t_end - length_s, period_s)
    return [(float(s), float(s + length_s)) for s in starts if s > t_start]


def drop_fixes(gnss: GnssRecording, windows) -> GnssRecording:
    """A copy of ``gnss`` without the fixes inside ``windows`` (outages: prediction only)."""
    keep = np.ones(len(gnss), bool)
    for t0, t1 in windows:
        keep &= ~((gnss.t >= t0) & (gnss.t < t1))
    return gnss.select(keep)


def outage_drift(est: list[Estimate], truth: Trajectory, frame, windows) -> dict:
    """Horizontal position error at the end of each outage (m): mean, max, per window."""
    t = np.array([e.t for e in est])
    ends = []
    for t0, t1 in windows:
        k = int(np.searchsorted(t, t1)) - 1
        if k < 0 or t[k] < t0:
            continue
        ref = truth_at(truth, frame, np.array([t[k]]))
        d = est[k].position_n - ref.enu[0]
        ends.append(float(np.hypot(d[0], d[1])))
    return {"windows": len(ends), "drift_mean_m": float(np.mean(ends)) if ends else float("nan"),
            "drift_max_m": float(np.max(ends)) if ends else float("nan"), "drift_each_m": ends}


def write_report(path, figures: dict) -> Path:
    """Figures as JSON (numbers only)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures, indent=2, default=float))
    return path


def run_case(imu, gnss, model, params: dict):
    """One filter run over a recording with parameters ``params`` (name -> value): (estimates, filter)."""
    filt = InsGpsFilter(config.from_params(params), model)
    return run(filt, imu, gnss), filt


def counters(filt: InsGpsFilter) -> dict:
    """The filter's event counts and its rejected-input counts, for a report."""
    c = filt.counters
    return {"fixes": c.fixes, "rejected": c.fixes_rejected, "zupts": c.zupts, "nhc_updates": c.nhc_updates,
            "nhc_rejected": c.nhc_rejected, "gps_resets": c.gps_resets,
            "input": {k: v for k, v in filt.input_counters.items() if v}}
