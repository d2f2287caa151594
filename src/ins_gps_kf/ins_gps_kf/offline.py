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
STATUS_NAMES = {code: name for name, code in STATUS_CODES.items()}


class EstimateTable:
    """Estimates as one float64 row per epoch (what the trajectory CSV and the smoother use: stamp s, ENU position m,
    velocity m/s, quaternion xyzw, biases, scale factors, the covariance's diagonal, NIS, flags): 49 floats an
    epoch where an :class:`Estimate` object takes ~3 kB (a 2-hour 64-Hz replay held ~45 MB of them per list)."""

    FIELDS = (("t", 1), ("position_n", 3), ("velocity_n", 3), ("quat_xyzw", 4), ("gyro_bias", 3),
              ("accel_bias", 3), ("scale_factors", 6), ("has_scale_factors", 1), ("cov_diag", 15), ("nis", 1),
              ("gps_used", 1), ("zupt_used", 1), ("stationary", 1), ("status", 1))
    SLICES, WIDTH = {}, 0
    for _name, _size in FIELDS:
        SLICES[_name], WIDTH = slice(WIDTH, WIDTH + _size), WIDTH + _size

    def __init__(self, n_rows: int = 0):
        self._blocks = [np.zeros((n_rows, self.WIDTH))] if n_rows else []

    def __len__(self) -> int:
        return sum(len(b) for b in self._blocks)

    @classmethod
    def rows_of(cls, estimates: list[Estimate]) -> np.ndarray:
        """``estimates`` as rows (m, WIDTH)."""
        rows = np.zeros((len(estimates), cls.WIDTH))
        s = cls.SLICES
        for row, e in zip(rows, estimates):
            row[s["t"]], row[s["position_n"]], row[s["velocity_n"]] = e.t, e.position_n, e.velocity_n
            row[s["quat_xyzw"]], row[s["gyro_bias"]], row[s["accel_bias"]] = e.quat_xyzw, e.gyro_bias, e.accel_bias
            if e.scale_factors is not None:
                row[s["scale_factors"]], row[s["has_scale_factors"]] = e.scale_factors, 1.0
            n = min(len(e.cov), 15)
            row[s["cov_diag"].start:s["cov_diag"].start + n] = np.diag(e.cov)[:n]
            row[s["nis"]], row[s["gps_used"]], row[s["zupt_used"]] = e.nis, e.gps_used, e.zupt_used
            row[s["stationary"]], row[s["status"]] = e.stationary, STATUS_CODES[e.status]
        return rows

    def extend(self, estimates: list[Estimate]) -> None:
        """Append ``estimates`` (the sink :func:`run` feeds)."""
        if estimates:
            self._blocks.append(self.rows_of(estimates))

    def put(self, lo: int, estimates: list[Estimate]) -> None:
        """Write ``estimates`` at rows ``lo`` on (a table made with ``n_rows``)."""
        self.rows()[lo:lo + len(estimates)] = self.rows_of(estimates)

    def rows(self) -> np.ndarray:
        """All rows (n, WIDTH), one array."""
        if len(self._blocks) != 1:
            self._blocks = [np.concatenate(self._blocks) if self._blocks else np.zeros((0, self.WIDTH))]
        return self._blocks[0]

    def column(self, name: str) -> np.ndarray:
        """One field of every row, contiguous ((n,) or (n, size))."""
        col = self.rows()[:, self.SLICES[name]]
        return np.ascontiguousarray(col[:, 0] if col.shape[1] == 1 else col)

    def estimates(self, lo: int, hi: int) -> list[Estimate]:
        """Rows ``lo`` to ``hi`` (exclusive) as Estimates (covariance None: the table keeps its diagonal)."""
        s, out = self.SLICES, []
        for row in self.rows()[lo:hi]:
            out.append(Estimate(float(row[0]), row[s["position_n"]].copy(), row[s["velocity_n"]].copy(),
                                row[s["quat_xyzw"]].copy(), None, row[s["gyro_bias"]].copy(),
                                row[s["accel_bias"]].copy(), STATUS_NAMES[int(row[s["status"]][0])],
                                bool(row[s["gps_used"]][0]), bool(row[s["zupt_used"]][0]), float(row[s["nis"]][0]),
                                bool(row[s["stationary"]][0]),
                                row[s["scale_factors"]].copy() if row[s["has_scale_factors"]][0] else None))
        return out


def fix_places(t_fix: np.ndarray, stale_s: float) -> np.ndarray:
    """Where each fix of a recording goes among the IMU samples (s, IMU clock), by the node's rule
    (:class:`ins_gps_kf.input_checks.FixArrivals`, the fixes taken in recorded order); ``stale_s`` s is the
    filter's ``time_jump``. Equal to the stamps for a time-ordered recording."""
    arrivals = FixArrivals(stale_s)
    return np.array([arrivals.place_of(float(t))[0] for t in t_fix], dtype=float)


def run(filt: InsGpsFilter, imu: ImuRecording, gnss: GnssRecording | None, progress: bool = False,
        odometry: tuple | None = None, sink=None) -> list[Estimate]:
    """Feed ``imu`` and ``gnss`` to ``filt`` as the node's intake would: each fix at its place (:func:`fix_places`),
    fixes of one place in recorded order and before an IMU sample of that stamp; the filter gets each fix's own
    stamp and judges it (a stamp gone back is counted and dropped, or re-stamped after a GNSS clock step). The IMU
    stamps go through the intake's :class:`~ins_gps_kf.input_checks.ImuClock` (an IMU clock step back re-stamped).
    ``odometry``: (t (n,) s, forward speed (n,) m/s) wheel speeds, each fed at its stamp after the fixes there.
    ``sink``: called with each call's estimates (a list) instead of keeping them; the result is then empty."""
    out: list[Estimate] = []
    keep = sink or out.extend
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
            keep(filt.process_imu(t_imu[s:e], imu.gyro[s:e], imu.accel[s:e]))
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
    table = EstimateTable()
    table.extend(estimates)
    return table_trajectory(table, frame)


def table_trajectory(table: EstimateTable, frame) -> Trajectory:
    """An :class:`EstimateTable` as a :class:`Trajectory` (geodetic via ``frame``) with ENU, std, NIS and status
    columns."""
    if not len(table):
        return Trajectory(*(np.zeros(0) for _ in range(7)), velocity_n=np.zeros((0, 3)))
    t, pos, vel = table.column("t"), table.column("position_n"), table.column("velocity_n")
    std = np.sqrt(table.column("cov_diag"))
    roll, pitch, yaw = frames.euler_from_quat_xyzw(table.column("quat_xyzw"))
    lat, lon, h = frame.to_geodetic(pos)
    extra = {"e_m": pos[:, 0], "n_m": pos[:, 1], "u_m": pos[:, 2],
             "std_e": std[:, 0], "std_n": std[:, 1], "std_u": std[:, 2],
             "std_ve": std[:, 3], "std_vn": std[:, 4], "std_vu": std[:, 5],
             # phi is an ENU rotation error: east/north ~ roll/pitch at small yaw, up = yaw
             "std_att_e_deg": std[:, 6] / DEG, "std_att_n_deg": std[:, 7] / DEG, "std_yaw_deg": std[:, 8] / DEG,
             **{k: table.column(k) for k in ("nis", "gps_used", "zupt_used", "status")}}
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
