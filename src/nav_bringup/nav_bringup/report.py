"""Run report: what the graph recorded against truth (or GPS), as HTML with PNG plots and a terminal summary.

``summary.json`` carries the figures for scripts. Figures follow the paper: the trajectory on north/east axes with GPS and truth
(Fig. 6), errors over time with the filter's 3-sigma bounds, the Allan deviation
of the stationary head (Fig. 3), raw against denoised signals (Figs. 4 and 5),
and the diagnostics of every node. The live odometry is checked against an offline replay of
the run's own bag (``imu/data_corrected`` and ``gps/fix`` through the same filter with the
node's parameters): the largest difference, what either side has alone, and whatever the
filter node dropped or found missing, so a run that did not give the offline answer says so. A bag's
start the filter node missed (its first received stamps, from its diagnostics, come later) is
counted and the replay starts where the node's input did; input the node had before the bag's
first message (the recorder subscribed late) is named, since no replay of that bag can match.
With a truth, GNSS outages as KF-GINS's paper scores them (60 s every 3 minutes) are cut from the bag's fixes and
the forward filter and its forward-backward smoother run over it offline (:func:`nav_eval.outages.outage_study`):
the horizontal errors with their 3-sigma bands through the outages, and the largest error per outage, each way.
"""
from __future__ import annotations

import html
import json
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from imu_calib.status import AllanStatus  # noqa: E402
from imu_driver.status import DriverStatus  # noqa: E402
from ins_gps_kf.status import INPUT_STALE_S, FilterStatus  # noqa: E402
from nav_eval.metrics import rms  # noqa: E402
from nav_bringup.offline_runs import (BAG_LATE_FIXES, BAG_LATE_IMU, MISSED_FIXES, MISSED_IMU,  # noqa: E402
                                      compare_with_offline, outage_lines, outage_table, run_outages)
from nav_bringup.status import ScenarioStatus  # noqa: E402
from nav_bringup.truth import TruthTrack  # noqa: E402
from nav_core import bagio, recording  # noqa: E402
from nav_core.earth import LocalFrame  # noqa: E402
from nav_core.frames import euler_from_quat_xyzw, wrap_angle  # noqa: E402
from nav_core.status import level_name  # noqa: E402
from nav_core.units import DEG  # noqa: E402
from sensor_health.events import Event  # noqa: E402
from sensor_health.status import ChannelStatus  # noqa: E402
from wmra_filter.status import WmraStatus  # noqa: E402


def last_diagnostics(bag: Path) -> dict:
    """Node status name -> (level, message, values) of the last /diagnostics status per name."""
    out = {}
    try:
        for _, _, msg in bagio.iter_messages(bag, ["/diagnostics"]):
            for st in msg.status:
                out[st.name] = (int(st.level), st.message, {kv.key: kv.value for kv in st.values})
    except bagio.BagDamage as err:
        out["bag"] = (2, str(err), {})
    return out


def evaluate(odom, gnss, truth: TruthTrack | None, frame: LocalFrame) -> dict:
    """Error series and RMS figures of the filter (and of raw GPS) against truth, or against GPS without truth."""
    gps_enu = frame.to_enu(gnss.lat / DEG, gnss.lon / DEG, gnss.h)
    res = {"t": odom.t, "gps_t": gnss.t, "gps_enu": gps_enu, "odom_enu": odom.position}
    rot = Rotation.from_quat(odom.quat_xyzw)
    res["vel_enu"] = rot.apply(odom.velocity_body)
    if truth is not None:
        ref = truth.at(odom.t)
        res["pos_err"] = odom.position - ref
        res["gps_err"] = gps_enu - truth.at(gnss.t)
        if truth.velocity_n is not None:
            res["vel_err"] = res["vel_enu"] - np.column_stack(
                [np.interp(odom.t, truth.t, truth.velocity_n[:, i]) for i in range(3)])
        roll, pitch, yaw = euler_from_quat_xyzw(odom.quat_xyzw)
        res["att_err"] = np.column_stack([wrap_angle(a - np.interp(odom.t, truth.t, np.unwrap(truth.rpy[:, i])))
                                          for i, a in enumerate((roll, pitch, yaw))])
        res["reference"] = "truth"
    else:
        ref = np.column_stack([np.interp(odom.t, gnss.t, gps_enu[:, i]) for i in range(3)])
        res["pos_err"] = odom.position - ref
        res["reference"] = "GPS"
    nav = odom.t >= odom.t[0]
    res["rms"] = {"horizontal position (m)": rms(np.hypot(*res["pos_err"][nav, :2].T)),
                  "vertical position (m)": rms(res["pos_err"][nav, 2])}
    if "gps_err" in res:
        res["rms"]["raw GPS horizontal (m)"] = rms(np.hypot(*res["gps_err"][:, :2].T))
    if "vel_err" in res:
        res["rms"]["horizontal velocity (m/s)"] = rms(np.hypot(*res["vel_err"][:, :2].T))
    if "att_err" in res:
        res["rms"].update({"roll (deg)": rms(res["att_err"][:, 0] / DEG), "pitch (deg)": rms(res["att_err"][:, 1] / DEG),
                           "yaw (deg)": rms(res["att_err"][:, 2] / DEG)})
    return res


def plot_trajectory(res, truth, path: Path) -> None:
    """North against east: filter, GPS fixes, truth (the paper's Fig. 6)."""
    fig, ax = plt.subplots(figsize=(7, 7))
    if truth is not None:
        ax.plot(truth.enu[:, 0], truth.enu[:, 1], "k-", lw=2.5, alpha=0.4, label="truth")
    ax.plot(res["gps_enu"][:, 0], res["gps_enu"][:, 1], ".", ms=3, color="tab:orange", label="GPS fixes")
    ax.plot(res["odom_enu"][:, 0], res["odom_enu"][:, 1], "-", lw=1, color="tab:blue", label="INS/GPS filter")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend()
    ax.set_title("Trajectory on north/east axes (cf. paper Fig. 6)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_errors(res, odom, path: Path) -> None:
    """Position (and velocity, attitude where known) errors over time with the filter's 3-sigma bounds."""
    rows = [("pos_err", ["east", "north", "up"], "m", odom.pose_std[:, :3], 1.0)]
    if "vel_err" in res:
        rows.append(("vel_err", ["east", "north", "up"], "m/s", None, 1.0))
    if "att_err" in res:
        rows.append(("att_err", ["roll", "pitch", "yaw"], "deg", odom.pose_std[:, 3:6], 1 / DEG))
    fig, axes = plt.subplots(len(rows), 3, figsize=(13, 3.0 * len(rows)), sharex=True, squeeze=False)
    t = res["t"] - res["t"][0]
    for r, (key, names, unit, std, scale) in enumerate(rows):
        for i in range(3):
            ax = axes[r, i]
            ax.plot(t, res[key][:, i] * scale, lw=0.8, label=f"{names[i]} error")
            if std is not None:
                ax.fill_between(t, -3 * std[:, i] * scale, 3 * std[:, i] * scale, color="tab:gray", alpha=0.3,
                                label="±3σ (filter)")
            ax.set_ylabel(unit)
            ax.set_title(f"{names[i]} ({'position' if key == 'pos_err' else 'velocity' if key == 'vel_err' else 'attitude'})",
                         fontsize=9)
            if r == 0 and i == 0:
                ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"Filter errors against {res['reference']}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_raw_vs_denoised(raw, den, path: Path) -> None:
    """Raw against denoised gyro z and accel x over the most dynamic 20 s (cf. paper Figs. 4 and 5)."""
    if len(raw) < 64 or len(den) < 64:
        return
    rate = raw.rate_hz
    win = int(20 * rate)
    activity = np.convolve(np.abs(np.diff(raw.gyro[:, 2], prepend=raw.gyro[0, 2])), np.ones(win), "valid")
    i0 = int(np.argmax(activity)) if len(activity) else 0
    t0, t1 = raw.t[i0], raw.t[min(i0 + win, len(raw) - 1)]
    fig, axes = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    for ax, (name, col, scale, unit) in zip(axes, (("gyro z", ("gyro", 2), 1 / DEG, "deg/s"),
                                                    ("accel x", ("accel", 0), 1.0, "m/s²"))):
        for rec, label, style in ((raw, "raw (imu/data_raw)", dict(lw=0.6, alpha=0.6)),
                                  (den, "denoised (imu/data_corrected)", dict(lw=1.2))):
            m = (rec.t >= t0) & (rec.t <= t1)
            ax.plot(rec.t[m] - t0, getattr(rec, col[0])[m, col[1]] * scale, label=label, **style)
        ax.set_ylabel(f"{name} ({unit})")
        ax.legend(fontsize=8)
    axes[-1].set_xlabel(f"time from {t0 - raw.t[0]:.0f} s (s)")
    fig.suptitle("Raw against WMRA-denoised (cf. paper Figs. 4 and 5)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


STATUS_TYPES = {"bp3010_driver": DriverStatus, "wmra_node": WmraStatus, "ins_gps_kf_node": FilterStatus,
                "scenario_player": ScenarioStatus, "allan_node": AllanStatus,
                "sensor_health_node": ChannelStatus}
"""Node name -> its typed status (:class:`nav_core.status.NodeStatus`), the type the node writes."""


def node_status(name: str, level: int, message: str, values: dict):
    """A ``/diagnostics`` status (``node: name``) parsed through its node's type; None for a node without one."""
    cls = STATUS_TYPES.get(name.split(":")[0].strip())
    return None if cls is None else cls.from_values(values, level_name(level), message)


def filter_status(diags: dict) -> FilterStatus | None:
    """The filter node's last status, parsed through its type (:class:`ins_gps_kf.status.FilterStatus`); None
    when it published none."""
    return next((node_status(n, lvl, msg, v) for n, (lvl, msg, v) in diags.items() if n.startswith("ins_gps_kf")),
                None)


def write_report(run_dir: Path, sim_dir: Path | None = None, truth_csv: Path | None = None,
                 exit_codes: dict | None = None, filter_params: dict | None = None) -> str:
    """Write ``run_dir/report.html`` and PNGs from ``run_dir/bag``; return a one-screen summary.

    With ``filter_params`` (the filter node's parameters) the live odometry is compared with an
    offline replay of the bag (:func:`compare_with_offline`).
    """
    run_dir = Path(run_dir)
    bag = run_dir / "bag"
    diags = last_diagnostics(bag)
    try:
        odom = recording.read_odometry(bag)
    except recording.RecordingError:
        return _no_odometry(run_dir, diags, exit_codes or {})
    offline = None
    if filter_params is not None:
        try:
            offline = compare_with_offline(bag, odom, filter_params, filter_status(diags))
        except (recording.RecordingError, ValueError) as err:
            offline = {"not compared": str(err)}
    gnss = recording.read_gnss(bag)
    gnss = _finite(gnss)
    if sim_dir is not None:
        truth = TruthTrack.from_sim_dir(sim_dir)
        frame = truth.frame
    else:
        frame = LocalFrame(float(gnss.lat[0] / DEG), float(gnss.lon[0] / DEG), float(gnss.h[0]))
        truth = TruthTrack.from_csv(truth_csv, frame) if truth_csv else None
    res = evaluate(odom, gnss, truth, frame)
    plot_trajectory(res, truth, run_dir / "trajectory.png")
    plot_errors(res, odom, run_dir / "errors.png")
    figures = ["trajectory.png", "errors.png"]
    try:
        raw = recording.read_imu(bag, topic="imu/data_raw")
        den = recording.read_imu(bag, topic="imu/data_corrected")
        plot_raw_vs_denoised(raw, den, run_dir / "raw_vs_denoised.png")
        figures.append("raw_vs_denoised.png")
    except recording.RecordingError:
        raw = den = None
    if (run_dir / "allan" / "allan.png").exists():
        shutil.copy(run_dir / "allan" / "allan.png", run_dir / "allan.png")
        figures.append("allan.png")
    res["offline"] = offline
    res["outages"] = run_outages(run_dir, bag, filter_params, filter_status(diags), sim_dir, truth_csv, truth)
    if (run_dir / "outages.png").exists():
        figures.append("outages.png")
    res["stream"] = _stream_checks(raw, den, diags)
    if sim_dir is not None and raw is not None and len(raw) > 8:
        res["stamps"] = frame_time_errors(raw, sim_dir, truth.epoch_s)
    res["health_events"] = health_events(bag)
    _write_html(run_dir, res, odom, gnss, raw, den, diags, figures, exit_codes or {})
    summary = {"rms": res["rms"], "offline": offline, "outages": res["outages"], "stream": res["stream"],
               "stamps": res.get("stamps"),
               "sensor_health_events": [e.to_dict() for e in res["health_events"]],
               "exit_codes": exit_codes or {}}
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=1, default=str))
    return _summary(run_dir, res, odom, gnss, raw, den, diags, exit_codes or {})


def _stream_checks(raw, den, diags) -> dict:
    """Stamps going back in the recorded IMU streams, and what the filter node dropped or missed."""
    out = {}
    for name, rec in (("imu/data_raw", raw), ("imu/data_corrected", den)):
        if rec is not None:
            out[f"{name} stamps going back"] = int(np.sum(np.diff(rec.t) <= 0))
    # samples missing in the bag: upstream of the denoiser and the filter (raw), or lost by the recorder
    # where the filter's own count says it missed none (then the offline replay lacks what the node had)
    for name, rec in (("imu/data_raw", raw), ("imu/data_corrected", den)):
        if rec is not None and len(rec) > 1:
            steps = np.round(np.diff(rec.t) * rec.rate_hz)
            out[f"{name} samples missing"] = int(np.sum(steps[steps > 1] - 1))
    if raw is not None and den is not None and len(raw) and len(den):
        # the denoiser subscribed late (DDS discovery at the player's start) or the recorder lost its start
        out["imu/data_corrected start - imu/data_raw start (s)"] = round(float(den.t[0] - raw.t[0]), 3)
    kf = filter_status(diags)
    if kf is not None:
        out.update({"IMU samples the filter received": kf.imu_received, "messages the filter dropped": kf.late_dropped,
                    "IMU samples missing in the filter's input": kf.imu_missing})
    return out


def frame_time_errors(raw, sim_dir: Path, epoch_s: float) -> dict | None:
    """Driver stamps minus the simulated times of their frames, ms (p1, median, p99, largest); None if not found.

    Frame k of ``sim_dir/bp3010.bin`` is made at ``epoch_s + (k + 1) / 64``. Each recorded sample
    is found among the frames by its values (the recorder may miss some; the stamps' steps cannot
    tell, since stamps ahead of the model advance by less than a period).
    """
    from imu_driver.bp3010_codec import DEFAULT_FORMAT
    from imu_driver.emulator import BASE_RATE_HZ, counts_from_source

    rate = round(raw.rate_hz)
    if rate != BASE_RATE_HZ:
        return None
    gyro = counts_from_source(str(Path(sim_dir) / "bp3010.bin"), 0.0, 0)[:, :3] * DEFAULT_FORMAT.dtheta_lsb_rad * rate
    head = raw.gyro[:8]
    windows = np.lib.stride_tricks.sliding_window_view(gyro[:, 0], len(head))
    found = [k for k in np.flatnonzero(np.all(np.isclose(windows, head[:, 0], rtol=0, atol=1e-9), axis=1))
             if np.allclose(gyro[k:k + len(head)], head, rtol=0, atol=1e-9)]
    if len(found) != 1:
        return None
    k = _frame_numbers(raw.gyro, gyro, found[0])
    ok = k >= 0
    err = (raw.t[ok] - epoch_s - (k[ok] + 1) / rate) * 1e3
    p1, p50, p99 = np.percentile(err, [1, 50, 99])
    return {"driver stamp - frame time p1 (ms)": float(p1), "driver stamp - frame time median (ms)": float(p50),
            "driver stamp - frame time p99 (ms)": float(p99),
            "driver stamp - frame time largest (ms)": float(err[np.argmax(np.abs(err))])}


def _frame_numbers(recorded, sent, first: int, look_ahead: int = 64) -> np.ndarray:
    """Index in ``sent`` (n, 3) of each ``recorded`` (m, 3) row, in order from ``first``; -1 where not found."""
    if first + len(recorded) <= len(sent) and np.allclose(recorded, sent[first:first + len(recorded)], rtol=0,
                                                          atol=1e-9):
        return first + np.arange(len(recorded))
    out, j = np.full(len(recorded), -1), first
    for i, row in enumerate(recorded):
        hits = np.flatnonzero(np.all(np.abs(sent[j:j + look_ahead] - row) <= 1e-9, axis=1))
        if len(hits):
            out[i] = j = j + hits[0]
            j += 1
    return out


def _no_odometry(run_dir: Path, diags: dict, codes: dict) -> str:
    """The run ended before the filter navigated (too short to align, or no GPS): say so, with its state."""
    kf = filter_status(diags)
    state = f"{kf.message} ({kf.alignment})" if kf is not None else "no diagnostics from the filter"
    refused = kf if kf is not None and kf.input.alignment_not_gravity else None
    why = (f"It never found the IMU at rest: {refused.input.last_rejection} "
           f"({refused.input.alignment_not_gravity} blocks refused)." if refused else
           "It aligns on the first 45 s at rest and takes its heading from the GPS course once the vehicle "
           "moves, so a run must last beyond that.")
    text = f"=== Navigation report: {run_dir}\n    the filter published no odometry: {state}. {why}"
    if codes:
        text += "\n    exit codes: " + ", ".join(f"{k} {v}" for k, v in codes.items())
    (run_dir / "report.html").write_text(f"<!doctype html><html><body><pre>{html.escape(text)}</pre></body></html>")
    return text


def _finite(gnss):
    return gnss.select(np.isfinite(gnss.lat) & np.isfinite(gnss.lon) & (gnss.status >= 0))


def _counts(odom, gnss, raw, den) -> dict:
    dur = odom.t[-1] - odom.t[0] if len(odom) > 1 else 0.0
    out = {"odometry messages": len(odom), "odometry rate (Hz)": (len(odom) - 1) / dur if dur else float("nan"),
           "GPS fixes": len(gnss)}
    if raw is not None:
        out.update({"imu/data_raw messages": len(raw), "imu/data_corrected messages": len(den)})
    return out


HEALTH_EVENTS_TOPIC = "sensor_health/events"


def health_events(bag: Path) -> list:
    """The events sensor_health_node published (one JSON :class:`sensor_health.events.Event` each), in order."""
    try:
        return [Event.from_dict(json.loads(msg.data)) for _, _, msg in bagio.iter_messages(bag, [HEALTH_EVENTS_TOPIC])]
    except (bagio.BagDamage, ValueError, KeyError):
        return []


def _health_lines(events) -> list:
    lines = [f"    sensor health: {len(events)} events" + (":" if events else " (sensor_health_node named no fault)")]
    return lines + [f"      t {e.t_s:.3f} s (onset {e.onset_s:.3f} s) {e.level} {e.effect} {','.join(e.channels)}: "
                    f"{e.message}" for e in events]


def _summary(run_dir, res, odom, gnss, raw, den, diags, codes) -> str:
    lines = [f"=== Navigation report: {run_dir / 'report.html'}",
             f"    reference: {res['reference']}; {len(odom)} filter epochs over {odom.t[-1] - odom.t[0]:.0f} s"]
    lines += [f"    {k:<32} {v:10.3f}" for k, v in res["rms"].items()]
    lines += [f"    {k:<32} {v:10.3f}" if isinstance(v, float) else f"    {k:<32} {v:10d}"
              for k, v in _counts(odom, gnss, raw, den).items()]
    lines += [f"    {k:<38} {v:4d}" if isinstance(v, int) else f"    {k:<38} {v:7.3f}"
              for k, v in res.get("stream", {}).items()]
    lines += [f"    {k:<38} {v:7.1f}" for k, v in (res.get("stamps") or {}).items()]
    off = res.get("offline")
    if off and "not compared" in off:
        lines.append(f"    live against offline replay: not compared ({off['not compared']})")
    elif off:
        if off.get(MISSED_FIXES) or off.get(MISSED_IMU):
            lines.append(f"    the filter missed the bag's first {off[MISSED_FIXES]} fixes and {off[MISSED_IMU]} IMU "
                         "samples: its subscriptions matched the player after playing began (DDS discovery); "
                         "the replay starts where its input did")
        if off.get(BAG_LATE_FIXES) or off.get(BAG_LATE_IMU):
            lines.append(f"    the bag lacks the filter's first {off[BAG_LATE_FIXES]:.1f} s of fixes and "
                         f"{off[BAG_LATE_IMU]:.1f} s of IMU: the recorder subscribed after playing began, so "
                         "the offline replay of the bag cannot give the live answer")
        lines.append(f"    live against offline replay of the bag: largest difference {off['largest difference (m)']:.3g} m "
                     f"(twist.linear {off['largest twist.linear difference (m/s)']:.3g} m/s) "
                     f"over {off['common epochs']} common epochs (live {off['live epochs']}, offline "
                     f"{off['offline epochs']}; only live {off['only live']}, only offline {off['only offline']})")
    lines += outage_lines(res.get("outages"))
    for name, (level, message, values) in sorted(diags.items()):
        status = node_status(name, level, message, values)
        detail = status.summary() if status is not None else ""
        lines.append(f"    [{level_name(level):5}] {name}: {message}" + (f" ({detail})" if detail else ""))
        if isinstance(status, FilterStatus) and status.input_stale_s > INPUT_STALE_S and _player_done(codes):
            lines.append("            (its last status came after the player stopped: the input ended with the "
                         "drive, not in a fault)")
    lines += _health_lines(res.get("health_events", []))
    if codes:
        lines.append("    exit codes: " + ", ".join(f"{k} {v}" for k, v in codes.items()))
    return "\n".join(lines)


def _player_done(codes: dict) -> bool:
    """Whether the run's player (scenario_player or bag_play) exited 0 (the end of its drive, or Ctrl-C)."""
    return any(codes.get(player) == 0 for player in ("scenario_player", "bag_play"))


def _table(rows: dict) -> str:
    cells = "".join(f"<tr><td>{html.escape(str(k))}</td><td>{v:.4g}</td></tr>" if isinstance(v, float)
                    else f"<tr><td>{html.escape(str(k))}</td><td>{html.escape(str(v))}</td></tr>"
                    for k, v in rows.items())
    return f"<table>{cells}</table>"


def _write_html(run_dir, res, odom, gnss, raw, den, diags, figures, codes) -> None:
    diag_rows = "".join(
        f"<tr><td>{html.escape(n)}</td><td>{level_name(l)}</td>"
        f"<td>{html.escape(m)}</td><td>{html.escape(', '.join(f'{k}={v}' for k, v in vals.items()))}</td></tr>"
        for n, (l, m, vals) in sorted(diags.items()))
    imgs = "".join(f'<h2>{f.replace("_", " ").replace(".png", "")}</h2><img src="{f}" style="max-width:100%">'
                   for f in figures)
    no_offline = {"not compared": "no filter parameters given"}
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>Navigation report</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td{{padding:2px 10px;border-bottom:1px solid #ddd}}
table{{border-collapse:collapse;margin-bottom:1em}}</style></head><body>
<h1>Navigation report</h1><p>Run folder: {html.escape(str(run_dir))}. Errors against {res['reference']}.</p>
<h2>Accuracy (RMS)</h2>{_table(res['rms'])}
<h2>Messages</h2>{_table(_counts(odom, gnss, raw, den))}
<h2>Stamps and drops</h2>{_table({**res.get("stream", {}), **(res.get("stamps") or {})})}
<h2>Live odometry against an offline replay of the bag</h2>{_table(res.get("offline") or no_offline)}
<h2>GNSS outages cut from the bag (offline): forward against smoothed</h2>{_table(outage_table(res.get("outages")))}
<h2>Sensor health events</h2><pre>{html.escape(chr(10).join(_health_lines(res.get("health_events", []))))}</pre>
<h2>Exit codes</h2>{_table(codes)}
{imgs}
<h2>Diagnostics (last status of every node)</h2><table>{diag_rows}</table>
</body></html>"""
    (run_dir / "report.html").write_text(page)
