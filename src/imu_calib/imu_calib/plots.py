"""Allan deviation figure per axis: data with intervals, each fitted term and the total (like the paper's Fig. 3)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from imu_calib.noise_fit import _FACTORS, _POWERS, TERMS  # noqa: E402

UNITS = {"gyro": "rad/s", "accel": "m/s$^2$"}
TERM_LABELS = {"Q": "quantization", "N": "white noise", "B": "bias instability", "K": "rate random walk",
               "R": "rate ramp"}


def plot_allan(result, path) -> Path:
    """Two rows (gyro, accel) by three axes of log-log Allan deviation; saved as PNG at ``path``."""
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5), sharex=True)
    for row, triad in enumerate(("gyro", "accel")):
        adev = result.adev[triad]
        for i in range(3):
            _axis_panel(axes[row, i], adev.axis(i), result.fits[triad][i], f"{triad} {'xyz'[i]}", UNITS[triad])
    for ax in axes[-1]:
        ax.set_xlabel("cluster time $\\tau$ (s)")
    fig.suptitle(f"Allan deviation ({int(adev.confidence * 100)} % intervals) and fitted noise terms")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _axis_panel(ax, adev, fit, title, unit) -> None:
    taus = adev.taus
    ax.errorbar(taus, adev.adev, yerr=[adev.adev - adev.lo, adev.hi - adev.adev], fmt="o", ms=3,
                color="k", ecolor="0.6", label="data")
    fine = np.geomspace(taus[0], taus[-1], 200)
    for term in TERMS:
        if fit.values[term] > 0:
            label = TERM_LABELS[term] + (" (Gauss-Markov)" if term == "B" and fit.bias_correlation_time else "")
            ax.plot(fine, np.sqrt(fit.term_avar(term, fine)), "--", lw=1, label=f"{term}: {label}")
    for term, bound in getattr(fit, "upper_bounds", {}).items():
        if bound > 0 and term in ("B", "K"):  # the long-tau terms a short record cannot pin down
            i = TERMS.index(term)
            curve = _FACTORS[i] * bound ** 2 * fine ** _POWERS[i]
            ax.plot(fine, np.sqrt(curve), ":", color="0.5", lw=1, label=f"{term} <= {bound:.2g} (not identifiable)")
    ax.plot(fine, np.sqrt(fit.avar(fine)), "r-", lw=1.5, label="fit total")
    ax.set_xscale("log")
    ax.set_yscale("log")
    quality = getattr(fit, "fit_quality", {}).get("verdict")
    ax.set_title(title + (" - poor fit" if quality == "poor" else ""))
    ax.set_ylabel(f"$\\sigma(\\tau)$ ({unit})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
