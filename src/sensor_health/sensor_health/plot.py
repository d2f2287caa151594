"""The plot of the monitored statistics over time with the events marked (PNG)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sensor_health.events import CHANNELS  # noqa: E402


def plot_health(monitor, events, path) -> None:
    """Noise level, line statistic and bias CUSUM per channel against their thresholds; events as lines."""
    tr, th = monitor.trace, monitor.thr
    fig, axes = plt.subplots(3, 1, figsize=(11, 8), sharex=True)
    t = np.asarray(tr.t)
    panels = [(np.asarray(tr.noise_cusum), th.noise_h, "noise CUSUM (sd)"),
              (np.asarray(tr.line), th.line_h, "largest line (chi2(2))"),
              (np.asarray(tr.bias_cusum), None, "bias CUSUM (sd)")]
    for ax, (y, h, label) in zip(axes, panels):
        if len(t):
            for c in range(6):
                ax.plot(t, y[:, c], lw=0.7, label=CHANNELS[c])
        if h is not None:
            ax.axhline(h, color="k", ls="--", lw=0.8, label="threshold")
        ax.set_ylabel(label)
        ax.set_yscale("symlog", linthresh=1.0)
    for c in range(6):
        if np.isfinite(th.bias_h[c]):
            axes[2].axhline(th.bias_h[c], color=f"C{c}", ls="--", lw=0.8)
    for e in events:
        for ax in axes:
            ax.axvline(e.t_s, color="r" if e.level == "ERROR" else "orange", lw=0.8)
        axes[0].annotate(f"{e.effect} {','.join(e.channels)}", (e.t_s, 1.0), xycoords=("data", "axes fraction"),
                         rotation=90, va="top", fontsize=7)
    axes[0].legend(ncol=7, fontsize=7, loc="upper left")
    axes[-1].set_xlabel("recording time (s)")
    fig.suptitle(f"sensor health: {len(events)} events")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
