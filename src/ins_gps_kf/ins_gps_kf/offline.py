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
from ins_gps_kf.input_checks import FixArrivals, ImuClock

IMU_CHUNK = 65536  # IMU samples per filter call


def fix_places(t_fix: np.ndarray, stale_s: float) -> np.ndarray:
    """Where each fix of a recording goes among the IMU samples (s, IMU clock), by the node's rule
    (:class:`ins_gps_kf.input_checks.FixArrivals`, the fixes taken in recorded order); ``stale_s`` s is the
    filter's ``time_jump``. Equal to the stamps for a time-ordered recording."""
    arrivals = FixArrivals(stale_s)
    return np.array([arrivals.place_of(float(t))[0] for t in t_fix], dtype=float)


def run(filt: InsGpsFilter, imu: ImuRecording, gnss: GnssRecording | None, progress: bool = False,
        odometry: tuple | None = None) -> list[Estimate]:
    """Feed ``imu`` and ``gnss`` to ``filt`` as the node's intake would: each fix at its place (:func:`fix_places`),
    fixes of one place in recorded order and before an IMU sample of that stamp; the filter gets each fix's own
    stamp and judges it (a stamp gone back is counted and dropped, or re-stamped after a GNSS clock step). The IMU
    stamps go through the intake's :class:`~ins_gps_kf.input_checks.ImuClock` (an IMU clock step back re-stamped).
    ``odometry``: (t (n,) s, forward speed (n,) m/s) wheel speeds, each fed at its stamp after the fixes there."""
    out: list[Estimate] = []
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(imu), unit="epoch", mininterval=0.5, desc="replay")
    start = 0
    t_imu = ImuClock(filt.cfg.time_jump, filt.input).restamp(imu.t)

    def feed(stop):  # the IMU samples up to index ``stop``
        nonlocal start
        for s in range(start, stop, IMU_CHUNK):  # bounded memory; the same numbers as one call
            e = min(s + IMU_CHUNK, stop)
            out.extend(filt.process_imu(t_imu[s:e], imu.gyro[s:e], imu.accel[s:e]))
            bar is not None and bar.update(e - s)
        start = max(start, stop)

    places = fix_places(gnss.t, filt.cfg.time_jump) if gnss is not None else np.zeros(0)
    odo_t, odo_v = odometry if odometry is not None else (np.zeros(0), np.zeros(0))
    # each wheel speed arrives after the latest stamp before it (file order kept: a stamp gone back is judged)
    odo_places = np.maximum.accumulate(np.where(np.isfinite(odo_t), odo_t, -np.inf)) if len(odo_t) else odo_t
    events = np.concatenate([places, odo_places])
    for k in np.argsort(events, kind="stable"):
        feed(int(np.searchsorted(t_imu, events[k], side="left")))
        if k < len(places):
            filt.process_gps(gnss.t[k], gnss.lat[k], gnss.lon[k], gnss.h[k], gnss.std_enu[k], gnss.status[k])
        else:
            filt.process_odometry(odo_t[k - len(places)], odo_v[k - len(places)])
    feed(len(imu))
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
