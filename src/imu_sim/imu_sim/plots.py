"""Overview PNG of a simulation: truth path with GPS fixes, gyro and accelerometer outputs, temperature."""
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nav_core.earth import LocalFrame  # noqa: E402
from nav_core.units import DEG  # noqa: E402


def overview_png(res, path) -> Path:
    """Write a 2x2 overview of a :class:`SimResult` to ``path`` (PNG)."""
    truth = res.truth
    frame = LocalFrame(float(truth.lat[0] / DEG), float(truth.lon[0] / DEG), float(truth.h[0]))
    enu = frame.to_enu(truth.lat / DEG, truth.lon / DEG, truth.h)
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    ax = axes[0, 0]
    ax.plot(enu[:, 0], enu[:, 1], "k-", lw=1, label="truth")
    if res.gnss is not None and len(res.gnss):
        fix = frame.to_enu(res.gnss.lat / DEG, res.gnss.lon / DEG, res.gnss.h)
        ax.plot(fix[:, 0], fix[:, 1], ".", ms=2, label="GPS fixes")
    ax.set(xlabel="east (m)", ylabel="north (m)", title="trajectory", aspect="equal")
    ax.legend()
    for ax, data, unit, title in ((axes[0, 1], res.imu.gyro / DEG, "deg/s", "gyro"),
                                  (axes[1, 0], res.imu.accel, "m/s^2", "accelerometer")):
        for i, name in enumerate("xyz"):
            ax.plot(res.imu.t, data[:, i], lw=0.5, label=name)
        ax.set(xlabel="t (s)", ylabel=unit, title=f"{title} (imu/data_raw)")
        ax.legend()
    ax = axes[1, 1]
    speed = np.linalg.norm(truth.velocity_n, axis=1) if truth.velocity_n is not None else np.zeros(len(truth.t))
    ax.plot(truth.t, speed, "k-", lw=1, label="speed (m/s)")
    if res.imu.temp_c is not None:
        ax.plot(res.imu.t, res.imu.temp_c, "r-", lw=1, label="temperature (deg C)")
    ax.set(xlabel="t (s)", title="speed and temperature")
    ax.legend()
    fig.suptitle(f"imu_sim: {res.info.get('name', '')}, seed {res.seed}, {res.rate_hz:g} Hz")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)
