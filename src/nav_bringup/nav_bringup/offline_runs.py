"""The filter node's run repeated offline over the run's own bag (ROS-free): the live odometry against an offline
replay of the same input (:func:`compare_with_offline`), and KF-GINS's GNSS-outage score cut from the bag, forward
against smoothed (:func:`outage_study`), with their lines for the run report (:mod:`nav_bringup.report`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ins_gps_kf.status import FilterStatus
from nav_core import recording

FIRST_STAMP_TOLERANCE_S = 1e-4
"""s: above the rounding of the node's printed stamps, below the interval of any IMU (10 kHz) or GNSS."""
MISSED_FIXES = "fixes in the bag before the filter's first"
MISSED_IMU = "IMU samples in the bag before the filter's first"
BAG_LATE_FIXES = "fixes the filter had before the bag's first (s)"
BAG_LATE_IMU = "IMU the filter had before the bag's first (s)"


def compare_with_offline(bag: Path, odom, filter_params: dict, filter_diag: FilterStatus | dict | None = None) -> dict:
    """The recorded odometry against an offline replay of the bag's ``imu/data_corrected`` and ``gps/fix``.

    ``filter_params``: the filter node's parameters (as in the params file, with the run's
    overrides); ``filter_diag``: its last status (or /diagnostics values). Where the node's first received
    stamps (``first_imu_stamp_s``, ``first_fix_stamp_s``) come after the bag's, the node missed the
    bag's start (its subscription matched the player after playing began: the recorder, which
    subscribes once it sees the player, has it): that is counted, and the replay starts where the
    node's input did, so the difference is of the same input. Returns epochs on each side, common
    epochs, the largest position (m) and body-velocity (m/s) difference there, what the node missed at the
    start and the stamps going backwards in the live odometry.
    """
    from ins_gps_kf import config as kfconfig
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.replay import load_model, run

    p, imu, gnss, missed, odometry = _filter_input(bag, filter_params, filter_diag)
    filt = InsGpsFilter(kfconfig.from_params(p), load_model(p.get("sensor_model_path") or "default"))
    estimates = run(filt, imu, gnss, odometry=odometry)
    off_t = np.array([e.t for e in estimates])
    off_pos = np.array([e.position_n for e in estimates]).reshape(-1, 3)
    # the twist as the node builds it (one estimate each), so the live one is checked too
    off_vel = np.array([filt.odometry(e, prev).velocity_b
                        for e, prev in zip(estimates, [-np.inf] + [e.t for e in estimates[:-1]])]).reshape(-1, 3)
    live_ns, off_ns = np.round(odom.t * 1e6).astype(np.int64), np.round(off_t * 1e6).astype(np.int64)
    common, i_live, i_off = np.intersect1d(live_ns, off_ns, return_indices=True)
    diff = np.linalg.norm(odom.position[i_live] - off_pos[i_off], axis=1)
    twist_diff = np.linalg.norm(odom.velocity_body[i_live] - off_vel[i_off], axis=1)
    return {"live epochs": len(odom), "offline epochs": len(off_t), "common epochs": len(common),
            "only live": len(np.setdiff1d(live_ns, off_ns)), "only offline": len(np.setdiff1d(off_ns, live_ns)),
            "largest difference (m)": float(diff.max()) if len(diff) else float("nan"),
            "largest twist.linear difference (m/s)": float(twist_diff.max()) if len(twist_diff) else float("nan"),
            "live stamps going back": int(np.sum(np.diff(odom.t) <= 0)),
            "imu samples replayed": len(imu), **missed}


def _filter_input(bag: Path, filter_params: dict, filter_diag):
    """What the filter node had of the bag: (its core parameters, IMU, fixes, what it missed at the start, wheel
    speeds (t, m/s) with ``odometer_enabled``, else None)."""
    from ins_gps_kf import config as kfconfig

    p = {**kfconfig.defaults(), **{k: v for k, v in filter_params.items() if k in kfconfig.SPEC_BY_NAME}}
    imu = recording.read_imu(bag, topic=p["imu_topic"])
    gnss = recording.read_gnss(bag, topic=p["gps_topic"])
    imu, gnss, missed = _from_filter_start(imu, gnss, filter_diag or {})
    odometry = None
    if p["odometer_enabled"]:
        wheel = recording.read_wheel_speed(bag, topic=p["odometer_topic"])
        odometry = (wheel.t, wheel.speed_mps)
    return p, imu, gnss, missed, odometry


def outage_study(bag: Path, filter_params: dict, filter_diag, truth_csv: Path, epoch_s: float, png: Path) -> dict:
    """KF-GINS's outage score on this run: 60-s outages every 3 minutes cut from the bag's fixes, the forward filter
    (the node's parameters) and its smoothed pass against the truth (CSV time + ``epoch_s`` = bag stamps); the plot
    to ``png``; the figures (:func:`nav_eval.outages.figures`)."""
    from ins_gps_kf.offline import load_model
    from nav_eval import outages

    p, imu, gnss, _, odometry = _filter_input(bag, filter_params, filter_diag)
    truth = recording.read_trajectory_csv(truth_csv)
    truth.t = truth.t + epoch_s
    figs, e_fwd, e_smo, windows = outages.outage_study(imu, gnss, truth, p, load_model(p["sensor_model_path"] or
                                                                                        "default"), odometry=odometry)
    if not windows:
        return {"not run": f"the run's {gnss.t[-1] - gnss.t[0]:.0f} s of fixes hold no 60-s outage 3 minutes in"}
    outages.plot(png, e_fwd, e_smo, windows, title="GNSS outages cut from this run's bag (60 s every 3 min), offline: "
                 "forward and smoothed horizontal error, 3σ bands")
    return figs


def _from_filter_start(imu, gnss, diag: dict):
    """The bag's IMU and fixes from the filter node's first received stamps on; what was before them (counts),
    and how long the filter had input before the bag's first (s: the recorder subscribed late)."""
    st = diag if isinstance(diag, FilterStatus) else FilterStatus.from_values(diag)
    t_imu, t_fix = (float("nan") if t is None else t for t in (st.first_imu_stamp_s, st.first_fix_stamp_s))
    # the node prints its stamps to 1 us and a float64 near 1.7e9 s resolves 0.24 us: match within
    # FIRST_STAMP_TOLERANCE_S (a 1e-7 tolerance took the bag's first sample for one the filter missed)
    keep_imu = imu.t >= t_imu - FIRST_STAMP_TOLERANCE_S if np.isfinite(t_imu) else np.ones(len(imu), bool)
    keep_fix = gnss.t >= t_fix - FIRST_STAMP_TOLERANCE_S if np.isfinite(t_fix) else np.ones(len(gnss), bool)
    missed = {MISSED_IMU: int(np.sum(~keep_imu)), MISSED_FIXES: int(np.sum(~keep_fix)),
              BAG_LATE_IMU: round(max(0.0, imu.t[0] - t_imu), 3) if len(imu) and np.isfinite(t_imu) else 0.0,
              BAG_LATE_FIXES: round(max(0.0, gnss.t[0] - t_fix), 3) if len(gnss) and np.isfinite(t_fix) else 0.0}
    if not (missed[MISSED_IMU] or missed[MISSED_FIXES]):
        return imu, gnss, missed
    return imu.select(keep_imu), gnss.select(keep_fix), missed


def run_outages(run_dir, bag, filter_params, filter_diag, sim_dir, truth_csv, truth) -> dict:
    """:func:`outage_study` of the run when there is a truth and the filter's parameters; else why not."""
    if filter_params is None or truth is None:
        return {"not run": "needs the truth (a simulated run, or --truth) and the filter's parameters"}
    csv = Path(sim_dir) / "truth.csv" if sim_dir is not None else Path(truth_csv)
    try:
        return outage_study(bag, filter_params, filter_diag, csv, truth.epoch_s, run_dir / "outages.png")
    except (recording.RecordingError, ValueError) as err:
        return {"not run": str(err)}


def outage_lines(study) -> list:
    """The outage study on the terminal: forward against smoothed, the largest error per outage."""
    if not study:
        return []
    if "not run" in study:
        return [f"    GNSS outages (offline, 60 s every 3 min): not run ({study['not run']})"]
    fwd, smo = study["forward_largest_per_outage_m"], study["smoothed_largest_per_outage_m"]
    return [f"    GNSS outages cut from the bag (offline, {len(fwd)} x 60 s every 3 min), largest horizontal error "
            f"per outage, RMS: forward {study['forward_largest_rms_m']:.2f} m, smoothed "
            f"{study['smoothed_largest_rms_m']:.2f} m",
            "      each (forward / smoothed, m): " + ", ".join(f"{f:.1f} / {s:.1f}" for f, s in zip(fwd, smo)),
            f"      horizontal RMS over the run: forward {study['forward_horizontal_rms_m']:.2f} m, smoothed "
            f"{study['smoothed_horizontal_rms_m']:.2f} m; smoothed no worse at "
            f"{100 * study['smoothed_no_worse_fraction']:.0f} % of epochs"]


def outage_table(study) -> dict:
    """The outage study's rows for the HTML report."""
    if not study or "not run" in study:
        return study or {}
    rows = {f"outage {a:.0f}-{b:.0f} s: largest forward / smoothed (m)": f"{f:.2f} / {s:.2f}"
            for (a, b), f, s in zip(study["outages"], study["forward_largest_per_outage_m"],
                                    study["smoothed_largest_per_outage_m"])}
    return {**rows, **{k: v for k, v in study.items() if not isinstance(v, list)}}
