"""Accuracy figures of the filter against a truth: error RMS, GPS-outage drift, NEES/NIS consistency, plots.

``ins-gps-kf evaluate --dataset paper-sim --out DIR`` runs the project simulator's
paper drive (:mod:`imu_sim`) through the filter with and without periodic GPS
outages and writes ``DIR/<dataset>.json`` and PNG plots (Fig. 6 style).
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
from ins_gps_kf import error_model as em
from ins_gps_kf.filter import NAVIGATING, Estimate


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


def _rms(x):
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
    out = {"epochs": len(nav), "pos_h_rms_m": _rms(np.hypot(d[:, 0], d[:, 1])), "pos_u_rms_m": _rms(d[:, 2]),
           "pos_h_max_m": float(np.max(np.hypot(d[:, 0], d[:, 1]))) if len(d) else float("nan")}
    if ref.velocity_n is not None:
        dv = np.array([e.velocity_n for e in nav]) - ref.velocity_n
        out["vel_rms_mps"] = _rms(np.linalg.norm(dv, axis=1))
    if ref.euler is not None:
        eul = np.column_stack(frames.euler_from_quat_xyzw(np.array([e.quat_xyzw for e in nav])))
        da = frames.wrap_angle(eul - ref.euler) / DEG
        out.update({"roll_rms_deg": _rms(da[:, 0]), "pitch_rms_deg": _rms(da[:, 1]), "yaw_rms_deg": _rms(da[:, 2])})
    if gnss is not None:
        ok = (gnss.status >= 0) & np.isfinite(gnss.lat) & (gnss.t >= t_from) & (gnss.t <= truth.t[-1])
        g = frame.to_enu(gnss.lat[ok] / DEG, gnss.lon[ok] / DEG, gnss.h[ok])
        dg = g - truth_at(truth, frame, gnss.t[ok]).enu
        out["gps_h_rms_m"] = _rms(np.hypot(dg[:, 0], dg[:, 1]))
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
    return GnssRecording(gnss.t[keep], gnss.lat[keep], gnss.lon[keep], gnss.h[keep], gnss.std_enu[keep],
                         gnss.status[keep], gnss.source, gnss.damage)


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


# ----------------------------------------------------------------------------- experiments


def run_case(imu, gnss, model, params: dict):
    """One filter run: (estimates, filter)."""
    from ins_gps_kf import config
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.replay import run

    filt = InsGpsFilter(config.from_params(params), model)
    return run(filt, imu, gnss), filt


def paper_sim(out_dir, seed: int = 0, scenario=None) -> dict:
    """The simulated paper drive: nominal, 30/60 s outages every 180 s, re-used fixes, hand-tuned noise model."""
    from imu_sim.models import bp3010_grade_model
    from imu_sim.simulate import simulate
    from ins_gps_kf.replay import plot_north_east, to_trajectory

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario = scenario or Path(__file__).resolve().parents[3] / "config" / "scenarios" / "paper_drive.yaml"
    model = bp3010_grade_model()
    sim = simulate(str(scenario), model=model, seed=seed, with_bytes=False)
    params = {"imu_rate_hz": sim.rate_hz}
    t_from = 60.0  # after alignment (45 s) and the heading fix
    figures = {"source": f"imu_sim paper_drive, seed {seed}, model bp3010_grade_model", "cases": {}}
    cases = {"nominal": (sim.gnss, model, params),
             "reuse_last_fix": (sim.gnss, model, {**params, "reuse_last_fix": True}),
             "hand_tuned_noise_model": (sim.gnss, None, params)}
    windows = {}
    for length in (30.0, 60.0):
        windows[length] = outage_windows(t_from, sim.truth.t[-1], 180.0, length, 120.0)
        cases[f"outage_{int(length)}s_every_180s"] = (drop_fixes(sim.gnss, windows[length]), model, params)
    for name, (gnss, mdl, prm) in cases.items():
        est, filt = run_case(sim.imu, gnss, mdl, prm)
        fig = {"errors": error_figures(est, sim.truth, filt.frame, sim.gnss, t_from),
               "consistency": consistency(est, sim.truth, filt.frame, t_from),
               "rejected_fixes": filt.counters.fixes_rejected, "zupts": filt.counters.zupts}
        if name.startswith("outage"):
            length = float(name.split("_")[1][:-1])
            fig["outage_drift"] = outage_drift(est, sim.truth, filt.frame, windows[length])
        figures["cases"][name] = fig
        if name in ("nominal", "outage_60s_every_180s"):
            truth_enu = filt.frame.to_enu(sim.truth.lat / DEG, sim.truth.lon / DEG, sim.truth.h)
            plot_north_east(out_dir / f"paper_sim_{name}.png", to_trajectory(est, filt.frame), gnss, filt.frame,
                            truth_enu, title=f"simulated paper drive ({name}): filter, GPS, truth")
    write_report(out_dir / "paper_sim.json", figures)
    return figures


# ----------------------------------------------------------------------------- the paper's claims measured


def passthrough_model(model):
    """A copy of ``model`` with its deterministic terms (bias, scale factor, misalignment) zeroed: the noise only."""
    out = model.copy()
    for triad in (out.gyro, out.accel):
        triad.bias[:] = 0.0
        triad.scale_factor[:] = 0.0
        triad.misalignment[:] = 0.0
    return out


def wmra_denoised(imu, model, vehicle: str):
    """The IMU denoised by wmra_filter's batch core (db8, the node's defaults; thresholds from the model's white
    noise N; level from the vehicle class's bandwidth). Batch output equals the node's streaming output."""
    from nav_core.recording import ImuRecording
    from wmra_filter.wmra import WmraConfig, denoise_imu

    cfg = WmraConfig.for_bandwidth(imu.rate_hz, vehicle=vehicle)
    res = denoise_imu(imu.gyro, imu.accel, passthrough_model(model), cfg)
    return ImuRecording(imu.t, res.gyro, res.accel, imu.temp_c, source=f"{imu.source} + WMRA level {cfg.level}")


def allan_model(imu, t_end: float, completed: bool = False):
    """Noise model fitted by imu_calib (overlapping Allan deviation, five-term fit) on the samples before
    ``t_end`` (s): the recording's stationary head.

    ``completed``: a short head leaves terms unresolved (zero): the white noise is then taken from imu_calib's
    Welch PSD level, and bias instability and rate random walk from the hand-tuned default, since a filter
    told "no bias drift" trusts its biases for ever.
    """
    from imu_calib.characterise import characterise
    from nav_core.recording import ImuRecording

    k = imu.t < t_end
    head = ImuRecording(imu.t[k], imu.gyro[k], imu.accel[k], source=f"{imu.source} stationary head")
    res = characterise(head)
    model = res.model
    if completed:
        default = em.default_mems_model()
        for name in ("gyro", "accel"):
            tri, ref = model.triad(name), default.triad(name)
            tri.white_noise = np.where(tri.white_noise > 0, tri.white_noise, res.white_psd[name])
            unresolved = tri.bias_instability <= 0
            tri.bias_instability = np.where(unresolved, ref.bias_instability, tri.bias_instability)
            tri.bias_correlation_time = np.where(unresolved, ref.bias_correlation_time, tri.bias_correlation_time)
            tri.rate_random_walk = np.where(tri.rate_random_walk > 0, tri.rate_random_walk, ref.rate_random_walk)
    return model


def model_summary(model) -> dict:
    """White noise N, bias instability B, rate random walk K per triad (SI), for the report."""
    return {f"{name}_{term}": getattr(model.triad(name), term).tolist() for name in ("gyro", "accel")
            for term in ("white_noise", "bias_instability", "rate_random_walk", "quantization")}


def claims_table(imu, gnss, truth, params: dict, models: dict, vehicle: str, t_from: float, windows,
                 progress=None) -> dict:
    """Each noise model with WMRA off and on: errors, NEES, and drift over the outage ``windows``."""
    rows = {}
    for name, model in models.items():
        for wmra in (False, True):
            imu_in = wmra_denoised(imu, model if model is not None else em.default_mems_model(), vehicle) \
                if wmra else imu
            est, filt = run_case(imu_in, gnss, model, params)
            row = {"errors": error_figures(est, truth, filt.frame, gnss, t_from),
                   "consistency": consistency(est, truth, filt.frame, t_from)}
            est_o, filt_o = run_case(imu_in, drop_fixes(gnss, windows), model, params)
            row["outage_drift"] = outage_drift(est_o, truth, filt_o.frame, windows)
            rows[f"{name} / WMRA {'on' if wmra else 'off'}"] = row
            if progress:
                progress(1)
    return rows


def plot_claims(path, rows: dict, title: str):
    """Bars: horizontal position error RMS and mean outage drift per case (m)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(rows)
    fig, axes = plt.subplots(1, 2, figsize=(11, 0.5 * len(names) + 2.0))
    for ax, key, label in ((axes[0], lambda r: r["errors"].get("pos_h_rms_m", np.nan), "horizontal RMS (m)"),
                           (axes[1], lambda r: r["outage_drift"]["drift_mean_m"], "mean drift at outage end (m)")):
        ax.barh(names, [key(rows[n]) for n in names], color=["tab:blue" if "off" in n else "tab:green"
                                                            for n in names])
        ax.set_xlabel(label)
        ax.grid(True, axis="x", alpha=0.3)
        ax.invert_yaxis()
    axes[1].set_yticklabels([])
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def claims_paper_sim(out_dir, seed: int = 0, scenario=None) -> dict:
    """WMRA on/off x noise model (the simulated one = config/sensor_models/bp3010.yaml, imu_calib's fit on the
    45-s stationary head as is and completed (see :func:`allan_model`), the hand-tuned default) on the simulated paper drive, with 30-s outages every 180 s."""
    from tqdm import tqdm
    from imu_sim.models import bp3010_grade_model
    from imu_sim.simulate import simulate

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario = scenario or Path(__file__).resolve().parents[3] / "config" / "scenarios" / "paper_drive.yaml"
    model = bp3010_grade_model()
    sim = simulate(str(scenario), model=model, seed=seed, with_bytes=False)
    t_from = 60.0
    models = {"simulated model": model, "Allan fit on the 45-s head": allan_model(sim.imu, 44.0),
              "Allan fit, completed": allan_model(sim.imu, 44.0, completed=True), "hand-tuned default": None}
    windows = outage_windows(t_from, sim.truth.t[-1], 180.0, 30.0, 120.0)
    with tqdm(total=2 * len(models), desc="paper-sim claims", unit="case") as bar:
        rows = claims_table(sim.imu, sim.gnss, sim.truth, {"imu_rate_hz": sim.rate_hz}, models, "road_vehicle",
                            t_from, windows, bar.update)
    figures = {"source": f"imu_sim paper_drive, seed {seed}, bp3010_grade_model; outages 30 s every 180 s",
               "models": {k: model_summary(m) for k, m in models.items() if m is not None},
               "cases": rows}
    write_report(out_dir / f"paper_sim_claims_seed{seed}.json", figures)
    plot_claims(out_dir / f"paper_sim_claims_seed{seed}.png", rows, f"simulated paper drive, seed {seed}")
    return figures


def claims_katwijk(out_dir, axes: str = "-x_fwd") -> dict:
    """WMRA on/off x noise model (imu_calib's fit on the ~20-s stationary head as is and completed, hand-tuned
    default) on Katwijk,
    with 30-s outages every 90 s. ``axes``: the forward axis the rover evaluation chose (smallest GPS NIS)."""
    from tqdm import tqdm
    from nav_core.datasets import load_katwijk
    from ins_gps_kf.datasets import KATWIJK_PARAMS
    from ins_gps_kf.filter import NAVIGATING

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    imu, gnss, ref, info = load_katwijk(axes)
    head_end = info["reference_onset_s"] - 1.0
    models = {"Allan fit on the stationary head": allan_model(imu, head_end),
              "Allan fit, completed": allan_model(imu, head_end, completed=True), "hand-tuned default": None}
    est, _ = run_case(imu, gnss, None, KATWIJK_PARAMS)
    t_from = next((e.t for e in est if e.status == NAVIGATING), 0.0) + 10.0
    windows = outage_windows(t_from, min(gnss.t[-1], ref.t[-1]), 90.0, 30.0, t_from + 20.0)
    with tqdm(total=2 * len(models), desc="katwijk claims", unit="case") as bar:
        rows = claims_table(imu, gnss, ref, KATWIJK_PARAMS, models, "rover", t_from, windows, bar.update)
    figures = {"source": "Katwijk beach (NaveGo); reference = interpolation of the same RTK fixes; outages 30 s "
                         f"every 90 s; axes {axes}; Allan head 0-{head_end:.1f} s",
               "models": {k: model_summary(m) for k, m in models.items() if m is not None},
               "cases": rows}
    write_report(out_dir / "katwijk_claims.json", figures)
    plot_claims(out_dir / "katwijk_claims.png", rows, "Katwijk rover")
    return figures
