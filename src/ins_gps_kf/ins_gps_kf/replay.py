"""The ``ins-gps-kf`` CLI: the node's filter over a recording (rosbag2 bag, or IMU and GNSS CSVs) as fast as it can.

``ins-gps-kf replay --recording REC [--gnss GNSS.csv] --model MODEL.yaml --out TRAJ.csv``
writes the estimate at every filter epoch in the truth-trajectory CSV format
(:func:`nav_core.recording.write_trajectory_csv`) with velocity, local ENU
position and standard-deviation columns, and a north/east plot next to it, and prints the run's
counts (``--json``: as JSON), rejected input included. Built on :mod:`ins_gps_kf.offline`; other
packages add subcommands through the ``ins_gps_kf.cli`` entry point group (``evaluate``: nav_eval).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # 15x15 matrices: BLAS threads only cost time

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from importlib.metadata import entry_points  # noqa: E402
from pathlib import Path  # noqa: E402

import yaml  # noqa: E402

import numpy as np  # noqa: E402

from nav_core import recording, units  # noqa: E402
from nav_core.units import DEG  # noqa: E402
from nav_core.cli import about, add_common, parse_args, run_cli  # noqa: E402
from nav_core.params import did_you_mean  # noqa: E402
from nav_core.outputs import check_out_file, staged_file  # noqa: E402
from ins_gps_kf import config as kfconfig, error_model as em, track_check  # noqa: E402
from ins_gps_kf.filter import ALIGNING, InsGpsFilter  # noqa: E402
from ins_gps_kf.offline import EstimateTable, load_model, plot_north_east, run, table_trajectory  # noqa: E402
from ins_gps_kf.smoother import ForwardStore, smooth_table  # noqa: E402


GNSS_END_WARN_S = 10.0  # fixes this far apart, or ending this long before the IMU, are said (a cut file or outage)
SMOOTH_BLOCK = 512  # epochs the smoother holds in memory (store rows, a backward block): ~3 MB, not 11


def smooth_block(n_states: int) -> int:
    """Epochs the smoother holds in memory with ``n_states`` error states: :data:`SMOOTH_BLOCK` rows of the 15-state
    filter's width (~3 MB), fewer for wider rows (3 Gauss-Markov states per bias axis: 27 states, 3.3x the bytes a
    row; 512 of them took the 2-hour drive's peak from 279 to 299 MB)."""
    return max(16, SMOOTH_BLOCK * ForwardStore.row_width(em.N_STATES) // ForwardStore.row_width(n_states))


def forward_path(out_path) -> Path:
    """Where ``--smooth`` writes the forward trajectory beside the smoothed one: ``OUT.forward.csv``."""
    out = Path(out_path)
    return out.with_name(f"{out.stem}.forward{out.suffix or '.csv'}")


def replay_files(recording_path, gnss_path, model_path, out_path, params: dict | None = None,
                 imu_topic=None, gps_topic=None, plot=True, progress=True, smooth=False, odometry_path=None):
    """Read, run, write: the ``replay`` subcommand as a function; returns (Trajectory, filter). With ``smooth``
    the trajectory written to ``out_path`` (and returned) is the smoothed one (:mod:`ins_gps_kf.smoother`), the
    forward one goes to :func:`forward_path`. Wheel speeds (:func:`wheel_speeds`) turn ``odometer_enabled`` on."""
    p = kfconfig.defaults()
    p.update(params or {})
    recording.refuse_topic_without_bag(recording_path, "--imu-topic", imu_topic)
    recording.refuse_topic_without_bag(gnss_path or recording_path, "--gps-topic", gps_topic)
    imu = recording.read_imu(recording_path, topic=imu_topic or p["imu_topic"])
    gnss_src = gnss_path or recording_path
    gnss = recording.read_gnss(gnss_src, topic=gps_topic or p["gps_topic"])
    wheel = wheel_speeds(recording_path, odometry_path, p)
    for damage in dict.fromkeys(r.damage for r in (imu, gnss, wheel) if r is not None and r.damage):
        print(f"ins-gps-kf: warning: {damage}", file=sys.stderr)  # read past it: say what was lost
    odometry = None if wheel is None else (wheel.t, wheel.speed_mps)
    p["odometer_enabled"] = wheel is not None
    cfg = kfconfig.from_params(p)
    for warning in check_recordings(imu, gnss, cfg, imu_topic or p["imu_topic"]):
        print(f"ins-gps-kf: warning: {warning}", file=sys.stderr)
    filt = InsGpsFilter(cfg, load_model(model_path))
    estimates = EstimateTable()  # compact rows, not Estimate objects: a 2-hour 64-Hz drive held 90 MB of those
    block = smooth_block(filt.n_states)
    filt.recorder = ForwardStore(filt.n_states, ram_rows=block) if smooth else None
    try:
        run(filt, imu, gnss, progress=progress, odometry=odometry, sink=estimates.extend)
        if filt.frame is None:
            raise recording.RecordingError(f"{gnss_src}: no valid GPS fix, so no datum for the local frame")
        if not len(estimates):
            raise recording.RecordingError(f"{imu.source}: no filter epoch, nothing to write: {_why_no_epoch(filt)}")
        check_fixes_against_ins(imu, gnss, estimates, filt)
        smoothed = smooth_table(filt.recorder, estimates, block) if smooth else estimates
    finally:
        if filt.recorder is not None:
            filt.recorder.close()
            filt.recorder = None
    traj = table_trajectory(smoothed, filt.frame)
    recording.write_trajectory_csv(out_path, traj)
    if smooth:
        recording.write_trajectory_csv(forward_path(out_path), table_trajectory(estimates, filt.frame))
    if plot and len(traj):
        with staged_file(Path(out_path).with_suffix(".png"), force=True) as tmp:  # checked by the caller
            plot_north_east(tmp, traj, gnss, filt.frame, title=f"ins_gps_kf: {Path(out_path).stem}")
    return traj, filt


def wheel_speeds(recording_path, odometry_path, params: dict):
    """The wheel odometer's speeds the replay uses (:class:`nav_core.recording.WheelSpeedRecording`), or None:
    ``odometry_path`` (CSV ``t,speed_mps``, or a bag's ``odometer_topic``) when given; else, with
    ``odometer_enabled``, the recording bag's ``odometer_topic`` (as the node subscribes to it); else none (a
    warning when the bag has that topic). RecordingError naming the file and topic when asked-for speeds are
    missing."""
    topic = params["odometer_topic"]
    if odometry_path is not None:
        return recording.read_wheel_speed(odometry_path, topic=topic)
    from nav_core import bagio

    in_bag = bagio.is_bag(recording_path) and bagio.norm_topic(topic) in bagio.topics(recording_path)
    if params["odometer_enabled"]:
        if not bagio.is_bag(recording_path):
            raise recording.RecordingError(f"{recording_path}: odometer_enabled but no wheel speeds: give "
                                           "--odometry ODOM.csv (t,speed_mps) or a bag with the odometer_topic")
        return recording.read_wheel_speed(recording_path, topic=topic)
    if in_bag:
        print(f"ins-gps-kf: warning: {recording_path} has wheel speeds on {topic}, not used: --param "
              "odometer_enabled=true uses them", file=sys.stderr)
    return None


def check_recordings(imu, gnss, cfg, imu_topic: str) -> list[str]:
    """Warnings about ``imu`` and ``gnss`` for the filter configured by ``cfg``; RecordingError (naming the file
    and the field) when they cannot give a navigation solution: no samples, stamps that are not seconds of
    one clock (median interval longer than a filter epoch, fixes outside the IMU's time), impossible units."""
    src = imu.source
    csv = src.endswith(".csv")
    if len(imu) < 2:
        raise recording.RecordingError(f"{src}: {len(imu)} IMU sample(s){'' if csv else f' on {imu_topic}'}, "
                                       "the filter needs a recording")
    t_name = "column t" if csv else f"{imu_topic} header stamps"
    dt = float(np.median(np.diff(imu.t)))
    if not 0.0 < dt <= 0.5 / cfg.filter_rate_hz:
        raise recording.RecordingError(
            f"{src}: {t_name}: median sample interval {dt:.6g} s, expected a positive interval shorter than half "
            f"the filter's {1.0 / cfg.filter_rate_hz:g}-s epoch (time in ms or ns? rows in reverse order?)")
    unit = units.imu_unit_problem(imu.gyro, imu.accel, "columns gx, gy, gz" if csv else f"{imu_topic} angular_velocity",
                                  "columns ax, ay, az" if csv else f"{imu_topic} linear_acceleration")
    if unit:
        raise recording.RecordingError(f"{src}: {unit}")
    out = []
    check = recording.check_timestamps(imu.t, src, max_gap_s=cfg.time_jump)
    if not check.ok:
        out.append(check.summary())
    if gnss is not None and len(gnss):
        t0, t1 = imu.t[0] - cfg.time_jump, imu.t[-1] + cfg.time_jump
        inside = int(np.sum((gnss.t >= t0) & (gnss.t <= t1)))
        spans = (f"fixes t {np.nanmin(gnss.t):.10g} to {np.nanmax(gnss.t):.10g} s, IMU t {imu.t[0]:.10g} to "
                 f"{imu.t[-1]:.10g} s")
        if inside < min(2, len(gnss)):
            raise recording.RecordingError(f"{gnss.source}: {inside} of {len(gnss)} fixes fall within the IMU "
                                           f"recording's time ({spans}): not one clock, or not seconds?")
        if inside < len(gnss):
            out.append(f"{gnss.source}: {len(gnss) - inside} of {len(gnss)} fixes fall outside the IMU recording's "
                       f"time ({spans}); the filter drops them")
        t_fix = np.sort(gnss.t[np.isfinite(gnss.t)])
        gaps = np.flatnonzero(np.diff(t_fix) > GNSS_END_WARN_S)
        if len(gaps):
            k = gaps[0]
            out.append(f"{gnss.source}: {len(gaps)} gap(s) over {GNSS_END_WARN_S:g} s between fixes (first: "
                       f"{t_fix[k]:.10g} to {t_fix[k + 1]:.10g} s); the INS runs alone there")
        lead = imu.t[-1] - np.nanmax(gnss.t)
        if lead > GNSS_END_WARN_S:
            out.append(f"{gnss.source}: the last fix is {lead:.4g} s before the end of the IMU recording ({spans}); "
                       "the INS runs alone after it (GNSS file cut short?)")
    return out


def check_fixes_against_ins(imu, gnss, estimates: EstimateTable, filt: InsGpsFilter) -> None:
    """RecordingError naming the GNSS file when its fixes cannot be the motion the IMU measured (``estimates``: the
    forward filter's, :class:`ins_gps_kf.offline.EstimateTable`): their velocity
    changes differ from the INS's by a factor of ``TRACK_RATIO`` or more, or the filter rejected most of them."""
    c = filt.counters
    enu = filt.frame.to_enu(gnss.lat / DEG, gnss.lon / DEG, gnss.h)
    ratio = track_check.track_disagreement(imu.t, imu.accel, estimates.column("t"), estimates.column("quat_xyzw"),
                                           estimates.column("accel_bias"), gnss.t, enu)
    if ratio is not None and not 1.0 / track_check.TRACK_RATIO < ratio < track_check.TRACK_RATIO:
        unit = " (near 1/57.3: radians read as degrees?)" if abs(np.log(ratio * 180.0 / np.pi)) < np.log(2.0) else ""
        raise recording.RecordingError(
            f"{gnss.source}: the fixes' velocity changes are {ratio:.3g} times the INS's{unit} (median over "
            f"{track_check.TRACK_WINDOW_S:g}-s windows): not the motion the IMU measured. Likely: "
            f"{track_check.LIKELY_CAUSES}")
    if c.fixes >= 20 and c.fixes_rejected > track_check.REJECTED_FRACTION * c.fixes:
        raise recording.RecordingError(
            f"{gnss.source}: the filter rejected {c.fixes_rejected} of {c.fixes} fixes (persistently: the INS "
            f"and the fixes disagree, {c.gps_resets} GPS resets). Likely: a std far below the fixes' real scatter "
            f"(set gps_std_m), {track_check.LIKELY_CAUSES}")


def _why_no_epoch(filt: InsGpsFilter) -> str:
    """Why a run produced no epoch, in the filter's parameters' words."""
    cfg = filt.cfg
    if filt.counters.resets:
        return f"the filter was reset {filt.counters.resets} time(s), last: {filt.counters.reset_reasons[-1]}"
    if filt.input.alignment_not_gravity:
        return f"it never found the IMU at rest: {filt.input.last_rejection}"
    if filt.status == ALIGNING and cfg.alignment_mode == "stationary":
        return (f"it never finished aligning: it needs {cfg.min_alignment_time_s:g} s or more at rest (block-mean "
                f"rate below {cfg.stationary_gyro / DEG:g} deg/s: stationary_gyro_dps) before the vehicle moves; "
                "for a recording that starts moving set alignment_mode: in_motion")
    return f"the filter is still {filt.status!r} at the end of the recording"


def _parse_overrides(pairs) -> dict:
    out = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise kfconfig.FilterConfigError(f"--param {pair!r}: expected NAME=VALUE")
        name, value = pair.split("=", 1)
        if name not in kfconfig.SPEC_BY_NAME:
            raise kfconfig.FilterConfigError(f"--param {name!r}: unknown parameter"
                                             f"{did_you_mean(name, kfconfig.SPEC_BY_NAME)}")
        value = yaml.safe_load(value)
        default = kfconfig.SPEC_BY_NAME[name].default
        out[name] = float(value) if isinstance(default, float) and isinstance(value, int) else value
    return out


def _plugins(subparsers) -> None:
    """Subcommands other packages register (entry point group ``ins_gps_kf.cli``: ``evaluate`` from nav_eval)."""
    for ep in entry_points(group="ins_gps_kf.cli"):
        ep.load()(subparsers)


def _summary(filt: InsGpsFilter) -> dict:
    """The run's event and rejected-input counts (what the node's diagnostics give)."""
    c = filt.counters
    return {"epochs": c.epochs, "fixes": c.fixes, "fixes_rejected": c.fixes_rejected, "fixes_invalid": c.fixes_invalid,
            "zupts": c.zupts, "nhc_updates": c.nhc_updates, "nhc_rejected": c.nhc_rejected,
            "odometer_updates": c.odometer_updates, "odometer_rejected": c.odometer_rejected,
            "odometer_gaps": c.odometer_gaps,
            "odometer_scale_pct": 100.0 * filt.odometer.scale if filt.cfg.odometer_enabled else None,
            "nhc_mounting_pitch_yaw_deg": filt.nhc.mounting_deg(), "resets": c.resets, "gps_resets": c.gps_resets,
            "reset_reasons": c.reset_reasons,
            "input": filt.input_counters}


def main(argv=None) -> int:
    """``ins-gps-kf replay ...`` (see module doc); exit 2 on bad input or config."""
    parser = argparse.ArgumentParser(prog="ins-gps-kf", **about(
        "Run the node's INS/GPS filter over a recording (rosbag2 bag, or IMU and GNSS CSVs) as fast as it can.",
        "ins-gps-kf replay --recording my_bag --imu-topic /imu/data --gps-topic /fix --model default "
        "--out out/trajectory.csv"))
    add_common(parser)
    sub = parser.add_subparsers(dest="command", required=True)
    rp = sub.add_parser("replay", help="run the filter over a recording and write the trajectory CSV", **about(
        "Run the filter over a recording; write the trajectory CSV, its plot and the run's counts.",
        "ins-gps-kf replay --recording my_bag --imu-topic /imu/data --gps-topic /fix --model default "
        "--param imu_rate_hz=100 --out out/trajectory.csv",
        "ins-gps-kf replay --recording imu.csv --gnss gnss.csv --model sensor_model.yaml --out out/trajectory.csv"))
    add_common(rp, force=True, sub=True)
    rp.add_argument("--recording", required=True, help="rosbag2 bag (folder, .db3, .mcap) or IMU CSV")
    rp.add_argument("--gnss", help="GNSS CSV or bag (default: the recording itself)")
    rp.add_argument("--model", required=True, help="sensor-model YAML, or 'default' for the hand-tuned model")
    rp.add_argument("--out", required=True, help="output trajectory CSV (new; --force overwrites it and its PNG)")
    rp.add_argument("--params", help="ROS 2 params file (ins_gps_kf_node: ros__parameters:)")
    rp.add_argument("--param", action="append", metavar="NAME=VALUE", help="override one parameter")
    rp.add_argument("--imu-topic", help="IMU topic in a bag (default: the imu_topic parameter)")
    rp.add_argument("--gps-topic", help="GNSS topic in a bag (default: the gps_topic parameter)")
    rp.add_argument("--no-plot", action="store_true", help="do not write the PNG next to --out")
    rp.add_argument("--quiet", action="store_true", help="no progress bar")
    rp.add_argument("--odometry", metavar="ODOM.csv", help="wheel speeds (CSV with columns t,speed_mps: s, m/s "
                    "forward; or a bag's odometer_topic) as updates with the odometer's scale factor as a filter "
                    "state; with --param odometer_enabled=true and no --odometry, the recording bag's "
                    "odometer_topic (odom/wheel) is used")
    rp.add_argument("--smooth", action="store_true", help="forward-backward (RTS) smoothing: --out gets the smoothed "
                    "trajectory with its smoothed std, OUT.forward.csv the forward one")
    rp.add_argument("--json", action="store_true", help="print the run's counts (events, rejected input) as JSON")
    _plugins(sub)
    args = parse_args(parser, argv)
    return run_cli("ins-gps-kf", _replay if args.command == "replay" else args.run, args)


def _replay(args) -> int:
    """The ``replay`` subcommand: outputs checked before the run, written whole."""
    check_out_file(args.out, args.force)
    if args.smooth:
        check_out_file(forward_path(args.out), args.force)
    if not args.no_plot:
        check_out_file(Path(args.out).with_suffix(".png"), args.force)
    params = kfconfig.load_params_yaml(args.params) if args.params else {}
    params.update(_parse_overrides(args.param))
    traj, filt = replay_files(args.recording, args.gnss, args.model, args.out, params, args.imu_topic,
                              args.gps_topic, plot=not args.no_plot, progress=not args.quiet, smooth=args.smooth,
                              odometry_path=args.odometry)
    if args.json:
        print(json.dumps(_summary(filt), indent=1))
        return 0
    c, bad = filt.counters, {k: v for k, v in filt.input_counters.items() if v and isinstance(v, int)}
    if args.smooth:
        print(f"smoothed: {args.out}, forward: {forward_path(args.out)}")
    print(f"wrote {args.out}: {len(traj)} epochs; fixes {c.fixes} (rejected {c.fixes_rejected}, invalid "
          f"{c.fixes_invalid}), zupts {c.zupts}, resets {c.resets}, gps resets {c.gps_resets}; input flagged: "
          + (", ".join(f"{k} {v}" for k, v in bad.items()) or "none"))
    if bad:
        print(f"ins-gps-kf: warning: {filt.input.last_rejection} (last of {filt.input.total()})", file=sys.stderr)
    if filt.input.fixes_std_unknown:
        print(f"ins-gps-kf: warning: {filt.input.fixes_std_unknown} fixes carry no std (0, negative or not finite: "
              f"unknown); their std: {filt.input.unknown_fix_std}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
