"""Offline replay: the node's filter over a recording (rosbag2 bag, or IMU and GNSS CSVs) as fast as it can.

``ins-gps-kf replay --recording REC [--gnss GNSS.csv] --model MODEL.yaml --out TRAJ.csv``
writes the estimate at every filter epoch in the truth-trajectory CSV format
(:func:`nav_core.recording.write_trajectory_csv`) with velocity, local ENU
position and standard-deviation columns, and a north/east plot next to it.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # 15x15 matrices: BLAS threads only cost time

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402
from tqdm import tqdm  # noqa: E402

from nav_core import recording  # noqa: E402
from nav_core import sensor_model as sm  # noqa: E402
from nav_core.recording import GnssRecording, ImuRecording, Trajectory  # noqa: E402
from nav_core.units import DEG  # noqa: E402
from ins_gps_kf import config as kfconfig  # noqa: E402
from ins_gps_kf.filter import STATUS_CODES, Estimate, InsGpsFilter  # noqa: E402


def run(filt: InsGpsFilter, imu: ImuRecording, gnss: GnssRecording | None, progress: bool = False) -> list[Estimate]:
    """Feed ``imu`` and ``gnss`` to ``filt`` in stamp order (a fix before an IMU sample of equal stamp)."""
    out: list[Estimate] = []
    bar = tqdm(total=len(imu), unit="epoch", disable=not progress, mininterval=0.5, desc="replay")
    start = 0
    order = np.argsort(gnss.t, kind="stable") if gnss is not None else []
    for k in order:
        stop = int(np.searchsorted(imu.t, gnss.t[k], side="left"))
        if stop > start:
            out += filt.process_imu(imu.t[start:stop], imu.gyro[start:stop], imu.accel[start:stop])
            bar.update(stop - start)
            start = stop
        filt.process_gps(gnss.t[k], gnss.lat[k], gnss.lon[k], gnss.h[k], gnss.std_enu[k], gnss.status[k])
    chunk = 65536
    for s in range(start, len(imu), chunk):
        e = min(s + chunk, len(imu))
        out += filt.process_imu(imu.t[s:e], imu.gyro[s:e], imu.accel[s:e])
        bar.update(e - s)
    bar.close()
    return out


def to_trajectory(estimates: list[Estimate], frame) -> Trajectory:
    """Estimates as a :class:`Trajectory` (geodetic via ``frame``) with ENU, std, NIS and status columns."""
    from nav_core import frames

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
        from ins_gps_kf.error_model import default_mems_model
        return default_mems_model()
    return sm.load(path)


def replay_files(recording_path, gnss_path, model_path, out_path, params: dict | None = None,
                 imu_topic=None, gps_topic=None, plot=True, progress=True):
    """Read, run, write: the ``replay`` subcommand as a function; returns (Trajectory, filter)."""
    p = kfconfig.defaults()
    p.update(params or {})
    imu = recording.read_imu(recording_path, topic=imu_topic or p["imu_topic"])
    gnss_src = gnss_path or recording_path
    gnss = recording.read_gnss(gnss_src, topic=gps_topic or p["gps_topic"])
    cfg = kfconfig.from_params(p)
    filt = InsGpsFilter(cfg, load_model(model_path))
    estimates = run(filt, imu, gnss, progress=progress)
    if filt.frame is None:
        raise recording.RecordingError(f"{gnss_src}: no valid GPS fix, so no datum for the local frame")
    traj = to_trajectory(estimates, filt.frame)
    recording.write_trajectory_csv(out_path, traj)
    if plot and len(traj):
        plot_north_east(Path(out_path).with_suffix(".png"), traj, gnss, filt.frame)
    return traj, filt


def plot_north_east(path, traj: Trajectory, gnss: GnssRecording | None, frame, truth_enu=None, title=""):
    """Fig. 6 of the paper: filter, GPS (and truth) on east/north axes, m."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 6))
    if gnss is not None and len(gnss):
        ok = np.isfinite(gnss.lat) & (gnss.status >= 0)
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


def _parse_overrides(pairs) -> dict:
    out = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise kfconfig.FilterConfigError(f"--param {pair!r}: expected NAME=VALUE")
        name, value = pair.split("=", 1)
        if name not in kfconfig.SPEC_BY_NAME:
            raise kfconfig.FilterConfigError(f"--param {name!r}: unknown parameter")
        value = yaml.safe_load(value)
        default = kfconfig.SPEC_BY_NAME[name].default
        out[name] = float(value) if isinstance(default, float) and isinstance(value, int) else value
    return out


def _evaluate(args) -> int:
    from ins_gps_kf import evaluate
    if args.claims:
        if args.dataset not in ("paper-sim", "katwijk"):
            raise recording.RecordingError(f"--claims: only paper-sim and katwijk, not {args.dataset}")
        figures = (evaluate.claims_paper_sim(args.out, seed=args.seed) if args.dataset == "paper-sim"
                   else evaluate.claims_katwijk(args.out))
    elif args.dataset == "paper-sim":
        figures = evaluate.paper_sim(args.out, seed=args.seed)
    elif args.dataset == "balzer":
        from ins_gps_kf import datasets
        figures = datasets.evaluate_balzer(args.out)
    else:
        from ins_gps_kf import datasets
        figures = datasets.evaluate_rover(args.dataset, args.out)
    print(json.dumps(figures, indent=1, default=float))
    return 0


def main(argv=None) -> int:
    """``ins-gps-kf replay ...`` (see module doc); exit 2 on bad input or config."""
    parser = argparse.ArgumentParser(prog="ins-gps-kf", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rp = sub.add_parser("replay", help="run the filter over a recording and write the trajectory CSV")
    rp.add_argument("--recording", required=True, help="rosbag2 bag (folder, .db3, .mcap) or IMU CSV")
    rp.add_argument("--gnss", help="GNSS CSV or bag (default: the recording itself)")
    rp.add_argument("--model", required=True, help="sensor-model YAML, or 'default' for the hand-tuned model")
    rp.add_argument("--out", required=True, help="output trajectory CSV")
    rp.add_argument("--params", help="ROS 2 params file (ins_gps_kf_node: ros__parameters:)")
    rp.add_argument("--param", action="append", metavar="NAME=VALUE", help="override one parameter")
    rp.add_argument("--imu-topic", help="IMU topic in a bag (default: the imu_topic parameter)")
    rp.add_argument("--gps-topic", help="GNSS topic in a bag (default: the gps_topic parameter)")
    rp.add_argument("--no-plot", action="store_true", help="do not write the PNG next to --out")
    rp.add_argument("--quiet", action="store_true", help="no progress bar")
    ev = sub.add_parser("evaluate", help="accuracy figures and plots on a simulated or real dataset")
    ev.add_argument("--dataset", required=True, choices=("paper-sim", "katwijk", "canada", "balzer"))
    ev.add_argument("--out", required=True, help="output folder (JSON figures and PNG plots)")
    ev.add_argument("--seed", type=int, default=0, help="simulation seed (paper-sim)")
    ev.add_argument("--claims", action="store_true", help="WMRA on/off x Allan-derived/hand-tuned noise model "
                    "table (paper-sim, katwijk)")
    args = parser.parse_args(argv)
    if args.command == "evaluate":
        try:
            return _evaluate(args)
        except recording.RecordingError as err:
            print(f"ins-gps-kf: error: {err}", file=sys.stderr)
            return 2
    try:
        params = kfconfig.load_params_yaml(args.params) if args.params else {}
        params.update(_parse_overrides(args.param))
        traj, filt = replay_files(args.recording, args.gnss, args.model, args.out, params, args.imu_topic,
                                  args.gps_topic, plot=not args.no_plot, progress=not args.quiet)
    except (kfconfig.FilterConfigError, recording.RecordingError, sm.SensorModelError) as err:
        print(f"ins-gps-kf: error: {err}", file=sys.stderr)
        return 2
    c = filt.counters
    print(f"wrote {args.out}: {len(traj)} epochs; fixes {c.fixes} (rejected {c.fixes_rejected}, invalid "
          f"{c.fixes_invalid}), zupts {c.zupts}, resets {c.resets}, gps resets {c.gps_resets}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
