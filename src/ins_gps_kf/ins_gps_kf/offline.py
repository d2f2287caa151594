"""The filter over whole recordings, without ROS: feed (``run``), tabulate (``to_trajectory``), load a model, plot.

What the node, the ``ins-gps-kf`` CLI (:mod:`ins_gps_kf.replay`) and the evaluations
(:mod:`nav_eval`) share. Imports nothing heavier than the filter: the progress bar (tqdm)
and matplotlib are imported only when asked for.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nav_core import frames
from nav_core import sensor_model as sm
from nav_core.recording import GnssRecording, ImuRecording, Trajectory
from nav_core.units import DEG
from ins_gps_kf.error_model import default_mems_model
from ins_gps_kf.filter import STATUS_CODES, Estimate, InsGpsFilter


def _arrivals(t_fix: np.ndarray) -> np.ndarray:
    """When each fix of a recording reaches the filter (s, IMU clock): IMU samples up to then go first.

    A file keeps only the order, so: a fix arrives at its stamp, never before the fix ahead of it;
    a stamp going back arrives one fix spacing after the previous one (the receiver kept its rate,
    its clock stepped: the filter then sees the lag, as the node would); a stamp beyond the next
    one while the next follows the previous (an outlier), or NaN, arrives with the previous fix.
    Equal to the stamps for a time-ordered recording.
    """
    out = np.full(len(t_fix), -np.inf)
    prev_arrival, prev_t, spacing = -np.inf, np.nan, 0.0
    for k, t in enumerate(t_fix):
        before = t_fix[k - 1] if k else -np.inf
        after = t_fix[k + 1] if k + 1 < len(t_fix) else np.inf
        if not np.isfinite(t) or (t > after >= before):
            out[k] = prev_arrival
            continue
        spacing = t - prev_t if t > prev_t else spacing  # the receiver's rate: the last forward step
        prev_arrival = t if t >= prev_arrival else prev_arrival + spacing
        out[k], prev_t = prev_arrival, t
    return out


def run(filt: InsGpsFilter, imu: ImuRecording, gnss: GnssRecording | None, progress: bool = False) -> list[Estimate]:
    """Feed ``imu`` and ``gnss`` to ``filt`` by stamp, fixes in recorded order (a fix before an IMU sample of
    equal stamp); a fix stamped back in time is the filter's to judge (counted, dropped), as in the node."""
    out: list[Estimate] = []
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(imu), unit="epoch", mininterval=0.5, desc="replay")
    start = 0
    limits = _arrivals(gnss.t) if gnss is not None else []
    for k, limit in enumerate(limits):
        stop = int(np.searchsorted(imu.t, limit, side="left"))
        if stop > start:
            out += filt.process_imu(imu.t[start:stop], imu.gyro[start:stop], imu.accel[start:stop])
            bar is not None and bar.update(stop - start)
            start = stop
        filt.process_gps(gnss.t[k], gnss.lat[k], gnss.lon[k], gnss.h[k], gnss.std_enu[k], gnss.status[k])
    chunk = 65536
    for s in range(start, len(imu), chunk):
        e = min(s + chunk, len(imu))
        out += filt.process_imu(imu.t[s:e], imu.gyro[s:e], imu.accel[s:e])
        bar is not None and bar.update(e - s)
    if bar is not None:
        bar.close()
    return out


def to_trajectory(estimates: list[Estimate], frame) -> Trajectory:
    """Estimates as a :class:`Trajectory` (geodetic via ``frame``) with ENU, std, NIS and status columns."""
    if not estimates:
        return Trajectory(*(np.zeros(0) for _ in range(7)), velocity_n=np.zeros((0, 3)))
    t = np.array([e.t for e in estimates])
    pos = np.array([e.position_n for e in estimates])
    vel = np.array([e.velocity_n for e in estimates])
    roll, pitch, yaw = frames.euler_from_quat_xyzw(np.array([e.quat_xyzw for e in estimates]))
    std = np.sqrt(np.array([np.diag(e.cov) for e in estimates]))
    lat, lon, h = frame.to_geodetic(pos)
    extra = {"e_m": pos[:, 0], "n_m": pos[:, 1], "u_m": pos[:, 2],
             "std_e": std[:, 0], "std_n": std[:, 1], "std_u": std[:, 2],
             "std_ve": std[:, 3], "std_vn": std[:, 4], "std_vu": std[:, 5],
             # phi is an ENU rotation error: east/north ~ roll/pitch at small yaw, up = yaw
             "std_att_e_deg": std[:, 6] / DEG, "std_att_n_deg": std[:, 7] / DEG, "std_yaw_deg": std[:, 8] / DEG,
             "nis": np.array([e.nis for e in estimates]),
             "gps_used": np.array([e.gps_used for e in estimates], float),
             "zupt_used": np.array([e.zupt_used for e in estimates], float),
             "status": np.array([STATUS_CODES[e.status] for e in estimates], float)}
    return Trajectory(t, lat * DEG, lon * DEG, h, roll, pitch, yaw, vel, extra)


def load_model(path) -> sm.SensorModel:
    """The sensor model at ``path``; the hand-tuned default for ``default``."""
    if str(path) == "default":
        return default_mems_model()
    return sm.load(path)


def plot_north_east(path, traj: Trajectory, gnss: GnssRecording | None, frame, truth_enu=None, title=""):
    """Fig. 6 of the paper: filter, GPS (and truth) on east/north axes, m."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 6))
    if gnss is not None and len(gnss):
        ok = (np.isfinite(gnss.lat) & np.isfinite(gnss.lon) & np.isfinite(gnss.h) & (gnss.status >= 0)
              & (np.abs(gnss.lat) <= 0.5 * np.pi) & (np.abs(gnss.lon) <= np.pi))
        g = frame.to_enu(gnss.lat[ok] / DEG, gnss.lon[ok] / DEG, gnss.h[ok])
        ax.plot(g[:, 0], g[:, 1], ".", ms=3, color="tab:orange", label="GPS")
    if truth_enu is not None:
        ax.plot(truth_enu[:, 0], truth_enu[:, 1], "-", lw=1.0, color="k", label="truth")
    ax.plot(traj.extra["e_m"], traj.extra["n_m"], "-", lw=1.2, color="tab:blue", label="INS/GPS filter")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title or f"ins_gps_kf: {Path(path).stem}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
