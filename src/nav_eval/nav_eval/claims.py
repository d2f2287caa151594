"""The paper's claims measured: WMRA on/off x noise model (imu_calib's Allan fit, as is and completed; the
simulated model; the hand-tuned default), on the simulated paper drive and on Katwijk.

``ins-gps-kf evaluate --dataset paper-sim|katwijk --claims --out DIR``. WMRA is
:mod:`wmra_filter`'s batch core, the Allan fit :mod:`imu_calib`'s ``characterise``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from tqdm import tqdm

from imu_calib.characterise import characterise
from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_eval.rovers import load_katwijk
from nav_core.recording import ImuRecording
from ins_gps_kf import error_model as em
from ins_gps_kf.filter import NAVIGATING
from wmra_filter.wmra import WmraConfig, denoise_imu
from nav_eval.datasets import KATWIJK_PARAMS
from nav_eval.metrics import consistency, drop_fixes, error_figures, outage_drift, outage_windows, run_case, \
    write_report
from nav_core.workspace import PAPER_DRIVE, workspace_file


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
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario = scenario or workspace_file(PAPER_DRIVE)
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
