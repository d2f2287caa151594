"""Outputs of a diagnosis: diagnosis.json, model_updated.yaml, report.html with PNG plots."""
from __future__ import annotations

import html
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from imu_calib.allan import AllanError, overlapping_adev  # noqa: E402
from nav_core.sensor_model import save, stamp_provenance  # noqa: E402

from imu_sim.diagnose.case import CHANNELS, deterministic  # noqa: E402
from imu_sim.diagnose.noise_tests import block_means  # noqa: E402


def write_all(diag, out_dir, sources: dict) -> dict:
    """Write the three outputs (and the PNGs) into ``out_dir``; returns name -> path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "diagnosis.json", "model": out / "model_updated.yaml", "html": out / "report.html"}
    paths["json"].write_text(json.dumps(diag.result, indent=2, default=_plain))
    model = diag.model_updated.copy()
    stamp_provenance(model, "imu-sim diagnose", sources.get("recording", ""),
                     added_effects=[f["effect"] for f in diag.result["findings"]])
    save(model, paths["model"])
    noise = model_noise(diag)
    pngs = {"residual": residual_png(diag, out / "residual.png"), "allan": allan_png(diag, noise, out / "allan.png"),
            "psd": psd_png(diag, noise, out / "psd.png")}
    if diag.case.gnss is not None:
        gpng = gnss_png(diag, out / "gnss_residual.png")
        if gpng is not None:
            pngs["gnss_residual"] = gpng
    paths["html"].write_text(_html(diag, sources, pngs))
    paths.update(pngs)
    return paths


def _plain(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def residual_png(diag, path) -> Path:
    """1-s means of the residual before and after the fitted effects, per channel."""
    case = diag.case
    m = max(1, int(round(1.0 / case.dt)))
    tb = block_means(case.t, m)
    fig, axes = plt.subplots(6, 1, figsize=(10, 11), sharex=True)
    for c, ax in enumerate(axes):
        for r, lab in ((diag.resid_before, "before"), (diag.resid_after, "after")):
            y = block_means(r[:, c] - r[:, c].mean(), m)
            ax.plot(tb, y, lw=0.8, label=lab)
        ax.set_ylabel(CHANNELS[c] + ("\nrad/s" if c < 3 else "\nm/s²"), fontsize=8)
    axes[0].legend(fontsize=8)
    axes[0].set_title("residual (recorded − simulated), 1-s means, turn-on bias removed")
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return Path(path)


def model_noise(diag) -> np.ndarray:
    """The updated model's simulated noise on this case (n, 6): what a matching residual should look like."""
    case, model = diag.case, diag.model_updated
    return deterministic(case, model, stochastic=True, seed=7) - deterministic(case, model)


def allan_png(diag, sim_noise, path) -> Path:
    """Allan deviation with 95 % intervals: residual before / after, and simulated model noise."""
    rate = 1.0 / diag.case.dt
    fig, axes = plt.subplots(2, 3, figsize=(12, 7))
    try:
        curves = [(overlapping_adev(x, rate), lab) for x, lab in ((diag.resid_before, "real residual, before"),
                                                                   (diag.resid_after, "real residual, after"),
                                                                   (sim_noise, "simulated noise (updated model)"))]
    except AllanError:
        curves = []
    for c, ax in enumerate(axes.ravel()):
        for adev, lab in curves:
            ax.loglog(adev.taus, adev.adev[:, c], label=lab)
            ax.fill_between(adev.taus, adev.lo[:, c], adev.hi[:, c], alpha=0.2)
        ax.set_title(CHANNELS[c], fontsize=9)
        ax.set_xlabel("cluster time (s)", fontsize=8)
    if curves:
        axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return Path(path)


def psd_png(diag, sim_noise, path) -> Path:
    """Welch PSD of the real residual (before, after) against the updated model's simulated noise."""
    case = diag.case
    rate = 1.0 / case.dt
    nper = int(min(case.n, max(256, 2 ** int(np.log2(case.n / 8)))))
    fig, axes = plt.subplots(2, 3, figsize=(12, 7))
    for x, lab in ((diag.resid_before, "real residual, before"), (diag.resid_after, "real residual, after"),
                   (sim_noise, "simulated noise")):
        f, p = signal.welch(x, fs=rate, nperseg=nper, axis=0)
        for c, ax in enumerate(axes.ravel()):
            ax.loglog(f[1:], p[1:, c], lw=0.8, label=lab)
            ax.set_title(CHANNELS[c], fontsize=9)
            ax.set_xlabel("Hz", fontsize=8)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return Path(path)


def gnss_png(diag, path):
    """Fix residual (m, ENU) under the input model and under the updated model; None without usable fixes."""
    from imu_sim.diagnose.gnss_tests import gnss_residual
    before, after = gnss_residual(diag.case, diag.case.model), gnss_residual(diag.case, diag.model_updated)
    if before is None:
        return None
    fig, axes = plt.subplots(3, 1, figsize=(10, 6), sharex=True)
    for a, ax in enumerate(axes):
        ax.plot(before.t_rel, before.r[:, a], ".", ms=2, label="input model")
        ax.plot(after.t_rel, after.r[:, a], ".", ms=2, label="updated model")
        ax.set_ylabel(f"{'ENU'[a]} residual (m)", fontsize=8)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle("GNSS fix minus the model's antenna position", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)


def _html(diag, sources, pngs) -> str:
    res = diag.result
    rows = []
    for f in res["findings"]:
        params = "<br>".join(f"{html.escape(k)} = {v:.4g} [{f['intervals'].get(k, ['', ''])[0]:.4g}, "
                             f"{f['intervals'].get(k, ['', ''])[1]:.4g}]" if k in f["intervals"]
                             else f"{html.escape(k)} = {v:.4g}" for k, v in f["parameters"].items())
        rows.append(f"<tr><td><b>{f['effect']}</b><br>{f.get('share_of_mismatch', 0):.0%} of the mismatch</td>"
                    f"<td>{', '.join(f['channels'])}</td>"
                    f"<td>{f['time_span_s'][0]:.1f} – {f['time_span_s'][1]:.1f}</td><td>{html.escape(json.dumps(f['band']))}</td>"
                    f"<td>{params}</td><td>{f['fit_before']:.4g} → {f['fit_after']:.4g}<br><small>{html.escape(f['metric'])}"
                    f"</small></td><td>{html.escape(f['explanation'])}</td></tr>")
    tested = "".join(f"<tr><td>{t['effect']}</td><td>{t['value']}</td><td>{t['threshold']}</td>"
                     f"<td>{'yes' if t['significant'] else 'no'}</td><td>{html.escape(t['statistic'])}</td>"
                     f"<td>{html.escape(t['note'])}</td></tr>" for t in res["tested"])
    src = "".join(f"<li>{k}: {html.escape(str(v))}</li>" for k, v in sources.items())
    imgs = "".join(f"<h3>{k}</h3><img src='{Path(p).name}' style='max-width:100%'>" for k, p in pngs.items())
    verdict = "mismatch found" if res["mismatch"] else "no significant mismatch"
    return (f"<html><head><meta charset='utf-8'><title>imu-sim diagnose</title></head><body>"
            f"<h1>Sim versus real: {verdict}</h1><ul>{src}</ul><p>{res['samples']} samples at {res['rate_hz']:.3g} Hz. "
            f"{html.escape('; '.join(res['notes']))}</p>"
            f"<h2>Findings (by share of the mismatch)</h2><table border=1 cellpadding=4><tr><th>effect</th><th>channels</th>"
            f"<th>time span (s)</th><th>band</th><th>parameters [95 %]</th><th>held-out fit</th><th>why</th></tr>"
            f"{''.join(rows)}</table><h2>Every effect tested</h2><table border=1 cellpadding=3><tr><th>effect</th>"
            f"<th>statistic</th><th>threshold</th><th>significant</th><th>test</th><th>note</th></tr>{tested}</table>"
            f"<h2>Plots</h2>{imgs}</body></html>")
