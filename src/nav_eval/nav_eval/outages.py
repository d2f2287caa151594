"""Forward against smoothed through GNSS outages: horizontal errors with their 3-sigma bands, the largest error per
outage (KF-GINS's score), a plot; from the trajectory CSVs ``ins-gps-kf replay --smooth`` writes and a truth.

``ins-gps-kf evaluate --trajectory OUT.csv --truth TRUTH.csv --out DIR`` reads ``OUT.csv`` (smoothed) and
``OUT.forward.csv`` beside it, finds the outages (gaps between the forward filter's GNSS updates, or given), and
writes ``DIR/outages.png`` and ``DIR/outages.json``; nav-demo's report calls :func:`outage_study` on its run's bag.
The horizontal 3-sigma band is ``3 sqrt(std_e^2 + std_n^2)`` (the filter's own horizontal std, m).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nav_core.earth import LocalFrame
from nav_core.recording import RecordingError, Trajectory, read_trajectory_csv
from nav_core.units import DEG
from nav_eval.metrics import rms, truth_at

MIN_OUTAGE_S = 10.0
"""s: a gap this long between the forward filter's GNSS updates is an outage (1-Hz fixes at a 2-Hz filter leave 1 s)."""


@dataclass
class HorizontalErrors:
    """One trajectory against the truth: ``t`` (n,) s, horizontal error ``err_m`` (n,) m, horizontal std
    ``std_m`` (n,) m (the filter's: sqrt(std_e^2 + std_n^2))."""

    t: np.ndarray
    err_m: np.ndarray
    std_m: np.ndarray


def horizontal_errors(traj: Trajectory, truth: Trajectory, frame: LocalFrame) -> HorizontalErrors:
    """Horizontal error of ``traj`` (geodetic, with ``std_e``/``std_n`` columns) against ``truth`` in ``frame``;
    epochs outside the truth's time are left out."""
    inside = (traj.t >= truth.t[0]) & (traj.t <= truth.t[-1])
    t = traj.t[inside]
    enu = frame.to_enu(traj.lat[inside] / DEG, traj.lon[inside] / DEG, traj.h[inside])
    d = enu - truth_at(truth, frame, t).enu
    std = np.hypot(traj.extra["std_e"][inside], traj.extra["std_n"][inside]) if "std_e" in traj.extra \
        else np.full(len(t), np.nan)
    return HorizontalErrors(t, np.hypot(d[:, 0], d[:, 1]), std)


def outages_from_updates(t, gps_used, min_gap_s: float = MIN_OUTAGE_S) -> list[tuple[float, float]]:
    """Outages (t0, t1) s: the gaps longer than ``min_gap_s`` between epochs that used a fix (``gps_used`` 1)."""
    used = np.asarray(t, float)[np.asarray(gps_used, float) > 0.5]
    gaps = np.flatnonzero(np.diff(used) > min_gap_s)
    return [(float(used[k]), float(used[k + 1])) for k in gaps]


def largest_per_outage(err: HorizontalErrors, windows) -> list[float]:
    """The largest horizontal error (m) inside each outage window (t0, t1) s (NaN for a window without epochs)."""
    out = []
    for t0, t1 in windows:
        inside = (err.t >= t0) & (err.t <= t1)
        out.append(float(np.max(err.err_m[inside])) if inside.any() else float("nan"))
    return out


def figures(forward: HorizontalErrors, smoothed: HorizontalErrors, windows) -> dict:
    """Forward and smoothed: largest error per outage and its RMS (KF-GINS's score), horizontal RMS overall,
    the share of epochs where the smoothed error is no larger, and whether each stays inside its 3-sigma band."""
    fwd, smo = largest_per_outage(forward, windows), largest_per_outage(smoothed, windows)
    common, i_f, i_s = np.intersect1d(np.round(forward.t, 6), np.round(smoothed.t, 6), return_indices=True)
    no_worse = smoothed.err_m[i_s] <= forward.err_m[i_f] + 1e-9
    out = {"outages": [[round(a, 3), round(b, 3)] for a, b in windows],
           "forward_largest_per_outage_m": fwd, "smoothed_largest_per_outage_m": smo,
           "forward_largest_rms_m": rms(fwd), "smoothed_largest_rms_m": rms(smo),
           "forward_horizontal_rms_m": rms(forward.err_m), "smoothed_horizontal_rms_m": rms(smoothed.err_m),
           "smoothed_no_worse_fraction": float(np.mean(no_worse)) if len(common) else float("nan")}
    for name, e in (("forward", forward), ("smoothed", smoothed)):
        ok = np.isfinite(e.std_m)
        out[f"{name}_inside_3sigma_fraction"] = float(np.mean(e.err_m[ok] <= 3.0 * e.std_m[ok])) if ok.any() \
            else float("nan")
    return {k: _none_for_nan(v) for k, v in out.items()}


def _none_for_nan(value):
    """``value`` with NaN as None (JSON null: no outage, or none with an epoch, has no largest error)."""
    if isinstance(value, list):
        return [_none_for_nan(v) for v in value]
    return None if isinstance(value, float) and np.isnan(value) else value


def plot(path, forward: HorizontalErrors, smoothed: HorizontalErrors, windows, title: str = "") -> Path:
    """Horizontal error of the forward and the smoothed trajectory over time with their 3-sigma bands, the outages
    shaded; a log scale when the errors span more than two decades."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = min(forward.t[0], smoothed.t[0]) if len(forward.t) and len(smoothed.t) else 0.0
    fig, ax = plt.subplots(figsize=(11, 4.5))
    for k, (a, b) in enumerate(windows):
        ax.axvspan(a - t0, b - t0, color="tab:red", alpha=0.08, label="GNSS outage" if k == 0 else None)
    for e, color, name in ((forward, "tab:blue", "forward"), (smoothed, "tab:green", "smoothed")):
        ax.fill_between(e.t - t0, 0.0, 3.0 * e.std_m, color=color, alpha=0.15, lw=0, label=f"{name} 3σ")
        ax.plot(e.t - t0, e.err_m, color=color, lw=1.0, label=f"{name} error")
    for k, ((a, b), f, s) in enumerate(zip(windows, largest_per_outage(forward, windows),
                                           largest_per_outage(smoothed, windows))):
        ax.annotate(f"{f:.1f} / {s:.1f} m", (0.5 * (a + b) - t0, f if np.isfinite(f) else 0.0), fontsize=7,
                    ha="center", va="bottom")
    top = np.nanmax(np.concatenate([forward.err_m, smoothed.err_m, [1e-3]]))
    low = np.nanmin(np.concatenate([smoothed.err_m[smoothed.err_m > 0], [top]]))
    if top / max(low, 1e-6) > 100.0:
        ax.set_yscale("log")
    else:  # a band far above every error (an outage's forward 3 sigma) would flatten the errors: clip it
        ax.set_ylim(0.0, 1.6 * top)
    ax.set_xlabel("time since the first epoch (s)")
    ax.set_ylabel("horizontal error (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=3)
    ax.set_title(title or "Forward and smoothed horizontal error through GNSS outages (labels: largest forward / "
                 "smoothed per outage)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def evaluate_files(smoothed_csv, truth_csv, out_dir, forward_csv=None, windows=None) -> dict:
    """``ins-gps-kf evaluate --trajectory``: the smoothed trajectory CSV, its forward one (default
    ``OUT.forward.csv`` beside it), the truth CSV; outages from the forward filter's GNSS updates unless
    ``windows`` ((t0, t1) s) are given. Writes ``outages.png`` and ``outages.json`` into ``out_dir``; the figures."""
    from ins_gps_kf.replay import forward_path
    from nav_eval.metrics import write_report

    forward_csv = Path(forward_csv) if forward_csv else forward_path(smoothed_csv)
    if not forward_csv.exists():
        raise RecordingError(f"{forward_csv}: not found: the forward trajectory beside {smoothed_csv} "
                             "(ins-gps-kf replay --smooth writes it), or give --forward")
    smo, fwd, truth = (read_trajectory_csv(p) for p in (smoothed_csv, forward_csv, truth_csv))
    for traj, path in ((smo, smoothed_csv), (fwd, forward_csv)):
        if "std_e" not in traj.extra or "std_n" not in traj.extra:
            raise RecordingError(f"{path}: no std_e, std_n columns: not a trajectory ins-gps-kf replay wrote")
    frame = LocalFrame(float(truth.lat[0] / DEG), float(truth.lon[0] / DEG), float(truth.h[0]))
    e_fwd, e_smo = horizontal_errors(fwd, truth, frame), horizontal_errors(smo, truth, frame)
    if not len(e_fwd.t):
        raise RecordingError(f"{forward_csv}: no epoch within the truth's time ({truth_csv}: t {truth.t[0]:.10g} to "
                             f"{truth.t[-1]:.10g} s): not one clock?")
    if windows is None:
        windows = outages_from_updates(fwd.t, fwd.extra.get("gps_used", np.ones(len(fwd.t))))
    out = figures(e_fwd, e_smo, windows)
    out_dir = Path(out_dir)
    plot(out_dir / "outages.png", e_fwd, e_smo, windows, "" if windows else
         f"Forward and smoothed horizontal error (no GNSS outage: no gap over {MIN_OUTAGE_S:g} s between updates)")
    write_report(out_dir / "outages.json", out)
    return out


def outage_study(imu, gnss, truth: Trajectory, params: dict, model, period_s: float = 180.0, length_s: float = 60.0,
                 odometry=None):
    """The forward filter and its smoothed pass over ``imu`` with ``length_s``-s outages cut into ``gnss`` every
    ``period_s`` s (from ``period_s`` after the first fix; the last one ends before the last fix):
    (figures, forward errors, smoothed errors, windows); the filter runs with ``params`` (name -> value)."""
    from ins_gps_kf import config
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.offline import run, to_trajectory
    from ins_gps_kf.smoother import run_smoothed
    from nav_eval.metrics import drop_fixes

    t_first, t_last = float(np.nanmin(gnss.t)), float(np.nanmax(gnss.t))
    windows = [(a, b) for a, b in ((s, s + length_s) for s in np.arange(t_first + period_s, t_last, period_s))
               if b < t_last - 1.0]
    filt = InsGpsFilter(config.from_params(params), model)
    forward, smoothed = run_smoothed(filt, run, imu, drop_fixes(gnss, windows), odometry=odometry)
    if filt.frame is None or not forward:
        raise RecordingError(f"{imu.source}: no filter epoch for the outage study")
    frame = LocalFrame(float(truth.lat[0] / DEG), float(truth.lon[0] / DEG), float(truth.h[0]))
    e_fwd, e_smo = (horizontal_errors(to_trajectory(est, filt.frame), truth, frame) for est in (forward, smoothed))
    return figures(e_fwd, e_smo, windows), e_fwd, e_smo, windows
