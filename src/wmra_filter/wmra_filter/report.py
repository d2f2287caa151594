"""``wmra-report --out DIR``: the evidence as PNG plots (like the paper's Figs. 4 and 5) and report.md.

Simulated rate-table and road runs (seeded, BP3010-grade white noise) and the real
car recording of balzer82/Kalman (CC-BY-SA 2.0; no truth: plots and residual spectrum).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from nav_core.cli import about, add_common, number, parse_args, run_cli  # noqa: E402
from nav_core.outputs import check_out_dir, staged_dir  # noqa: E402
from nav_core.units import rad2deg  # noqa: E402
from nav_core.datasets import read_balzer_csv  # noqa: E402
from nav_core.workspace import shared_data  # noqa: E402
from wmra_filter import evaluation as ev  # noqa: E402
from wmra_filter.wmra import WmraConfig  # noqa: E402

BALZER = shared_data("balzer_car")
UNIT = {"g": ("deg/s", rad2deg), "a": ("m/s^2", lambda v: v)}


def _channel_unit(channel: str):
    return UNIT[channel[0]]


def plot_simulated(out: dict, sc: ev.Scenario, channels, path: Path, zoom_s: float) -> Path:
    """Raw against denoised (and clean, and the low-pass peer) per channel, full run and one step zoomed."""
    fig, axes = plt.subplots(len(channels), 2, figsize=(13, 3.2 * len(channels)), squeeze=False,
                             gridspec_kw={"width_ratios": [3, 1]})
    for row, name in enumerate(channels):
        c = ev.CHANNELS.index(name)
        unit, conv = _channel_unit(name)
        t_step = next((t for ch, t in sc.steps if ch == c), sc.t[len(sc.t) // 2])
        for ax, box in ((axes[row, 0], slice(None)), (axes[row, 1], (sc.t > t_step - zoom_s) & (sc.t < t_step + zoom_s))):
            ax.plot(sc.t[box], conv(out["outputs"]["raw"][box, c]), color="0.7", lw=0.6, label="raw (noisy)")
            ax.plot(sc.t[box], conv(out["outputs"]["lowpass"][box, c]), color="tab:orange", lw=0.9,
                    label="Butterworth 5 Hz (peer)")
            ax.plot(sc.t[box], conv(out["outputs"]["wmra"][box, c]), color="tab:blue", lw=1.0, label="WMRA db8")
            ax.plot(sc.t[box], conv(sc.clean[box, c]), color="k", lw=0.8, ls="--", label="clean")
            ax.set_ylabel(f"{name} [{unit}]")
            ax.grid(alpha=0.3)
        axes[row, 1].set_title(f"step at {t_step:.1f} s")
    axes[0, 0].set_title(f"{sc.name}: raw against WMRA-denoised")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_real(out: dict, rec, path: Path, spectrum_path: Path, bandwidth_hz: float, span_s=(60.0, 90.0)):
    """Real car: raw against denoised (yaw rate, ax, az) over ``span_s``; PSD of raw and of the residual."""
    box = (rec.t >= span_s[0]) & (rec.t < span_s[1])
    fig, axes = plt.subplots(3, 1, figsize=(12, 8), sharex=True)
    for ax, name in zip(axes, ("gz", "ax", "az")):
        c = ev.CHANNELS.index(name)
        unit, conv = _channel_unit(name)
        ax.plot(rec.t[box], conv(out["raw"][box, c]), color="0.6", lw=0.6, label="raw")
        ax.plot(rec.t[box], conv(out["denoised"][box, c]), color="tab:blue", lw=1.0, label="WMRA db8")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
    axes[0].set_title(f"real car ({Path(rec.source).name}): raw against WMRA-denoised")
    axes[0].legend(loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    for ax, names, title in ((axes[0], ("gx", "gy", "gz"), "gyro [(rad/s)^2/Hz]"),
                             (axes[1], ("ax", "ay", "az"), "accel [(m/s^2)^2/Hz]")):
        for name in names:
            c = ev.CHANNELS.index(name)
            line, = ax.semilogy(out["freqs"], out["psd_raw"][:, c], lw=0.8, alpha=0.5)
            ax.semilogy(out["freqs"], out["psd_residual"][:, c], lw=1.2, color=line.get_color(),
                        label=f"{name} residual")
        ax.axvline(bandwidth_hz, color="k", ls=":", label=f"motion band {bandwidth_hz:g} Hz")
        ax.set_title(f"PSD: raw (faint) and removed residual, {title}")
        ax.set_xlabel("f [Hz]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(spectrum_path, dpi=110)
    plt.close(fig)


def _simulated_tables(name: str, results: dict) -> list[str]:
    lines = [f"### {name}", "", "| mode | channel | SNR raw dB | SNR WMRA dB | SNR low-pass dB | RMS raw | RMS WMRA | RMS low-pass |",
             "|---|---|---|---|---|---|---|---|"]
    for mode, out in results.items():
        for c, ch in enumerate(ev.CHANNELS):
            snr = [out["snr_db"][k][c] for k in ("raw", "wmra", "lowpass")]
            if np.isnan(snr[0]):
                continue
            rms = [out["rms"][k][c] for k in ("raw", "wmra", "lowpass")]
            lines.append(f"| {mode} | {ch} | " + " | ".join(f"{v:.1f}" for v in snr) + " | "
                         + " | ".join(f"{v:.2e}" for v in rms) + " |")
    lines += ["", "Step transitions (hard_soft): 10-90 % rise time and overshoot over the clean signal.", "",
              "| channel | t s | step | rise raw s | rise WMRA s | rise low-pass s | overshoot raw % | "
              "overshoot WMRA % | overshoot low-pass % |", "|---|---|---|---|---|---|---|---|---|"]
    for s in results["hard_soft"]["steps"]:
        lines.append(f"| {s['channel']} | {s['t']:.1f} | {s['size']:+.3f} | {s['rise_raw_s']:.3f} | "
                     f"{s['rise_wmra_s']:.3f} | {s['rise_lowpass_s']:.3f} | {s['overshoot_raw_pct']:.1f} | "
                     f"{s['overshoot_wmra_pct']:.1f} | {s['overshoot_lowpass_pct']:.1f} |")
    return lines + [""]


def main(argv=None) -> int:
    """``wmra-report``: exit 2 with one line for a bad --out or input (``--debug``: the traceback)."""
    parser = argparse.ArgumentParser(prog="wmra-report", **about(
        "Show what WMRA denoising does: plots and numbers on simulated runs and a real car drive.",
        "wmra-report --out out/wmra"))
    parser.add_argument("--out", required=True, type=Path, help="output folder (new or empty; --force replaces it)")
    add_common(parser, force=True)
    parser.add_argument("--seed", type=number(0, 2**63 - 1, integer=True), default=2024,
                        help="RNG seed of the simulated runs (an integer >= 0)")
    parser.add_argument("--balzer", type=Path, default=None,
                        help="balzer82/Kalman car CSV (default: the shared data's, skipped with a note if absent)")
    return run_cli("wmra-report", _report, parse_args(parser, argv))


def _report(args) -> int:
    """Check --out first, then write every file into a temporary folder renamed into place at the end."""
    given = args.balzer is not None
    args.balzer = args.balzer or BALZER / "2014-03-26-000-Data.csv"
    check_out_dir(args.out, args.force, inputs=(args.balzer,))
    # the car CSV is read first: a bad one fails before minutes of simulated runs; a path given is never skipped
    args.car = read_balzer_csv(args.balzer) if given or args.balzer.exists() else None
    final = args.out
    with staged_dir(final, args.force, inputs=(args.balzer,)) as tmp:
        args.out = tmp
        _write_report(args, final)
    print(f"wrote {final / 'report.md'} and {len(list(final.glob('*.png')))} PNG plots in {final}")
    return 0


def _write_report(args, final: Path) -> None:
    rng = np.random.default_rng(args.seed)
    runs = {"rate_table": (ev.rate_table_run(rng), ("gz",), 0.6), "road": (ev.road_run(rng), ("gz", "ax", "az"), 1.0)}
    lines = ["# WMRA denoising: evidence", "",
             f"Generated by `wmra-report --out {final} --seed {args.seed}`. db8, level from 64 Hz and a 5 Hz "
             "motion band (level 2), thresholds universal from the white noise N (BP3010 grade: N_gyro "
             f"{ev.N_GYRO} rad/sqrt(s), N_accel {ev.N_ACCEL} m/s/sqrt(s)). Peer: zero-phase 4th-order "
             "Butterworth low-pass at 5 Hz. Scores exclude the edge region (support) at both ends.", ""]
    tasks = [(name, mode) for name in runs for mode in ("hard", "soft", "hard_soft")]
    results = {name: {} for name in runs}
    for name, mode in tqdm(tasks, desc="simulated runs", unit="run"):
        sc = runs[name][0]
        results[name][mode] = ev.evaluate(sc, WmraConfig.for_bandwidth(64.0, mode=mode))
    for name, (sc, channels, zoom) in runs.items():
        png = plot_simulated(results[name]["hard_soft"], sc, channels, args.out / f"{name}.png", zoom)
        lines += _simulated_tables(f"{name} (Fig. {4 if name == 'rate_table' else 5} situation)", results[name])
        lines += [f"![{name}]({png.name})", ""]
    lines += _real_section(args)
    (args.out / "report.md").write_text("\n".join(lines) + "\n")


def _real_section(args) -> list[str]:
    rec = args.car
    if rec is None:
        return [f"## Real car\n\nNot run: {args.balzer} not found."]
    if rec.damage:  # read past it: say what was lost
        print(f"wmra-report: warning: {rec.damage}", file=sys.stderr)
    cfg = WmraConfig.for_bandwidth(50.0, noise="mad")
    with tqdm(total=1, desc="real car", unit="run") as bar:
        out = ev.evaluate_real(rec, cfg)
        bar.update()
    plot_real(out, rec, args.out / "real_car.png", args.out / "real_car_residual_psd.png", 5.0)
    lines = ["## Real car (balzer82/Kalman, Dresden drive, CC-BY-SA 2.0)", "",
             f"`{args.balzer.name}`: {len(rec)} samples resampled to 50 Hz ({rec.t[-1]:.0f} s). No truth and no "
             f"sensor model: thresholds universal, noise from the median absolute deviation of each level "
             f"(level {cfg.level}, untouched band 0-{50 / 2 ** (cfg.level + 1):.2f} Hz).", "",
             "| channel | residual std | share of raw variance removed | residual power at <= 5 Hz |",
             "|---|---|---|---|"]
    for c, ch in enumerate(ev.CHANNELS):
        lines.append(f"| {ch} | {out['residual_std'][c]:.3g} | {out['raw_power_removed'][c]:.3f} | "
                     f"{out['residual_power_in_band'][c]:.4f} |")
    return lines + ["", "![real car](real_car.png)", "", "![residual spectrum](real_car_residual_psd.png)", ""]


if __name__ == "__main__":
    sys.exit(main())
