"""The two-host run's part of the report: the link's cuts, the gap they left and the recovery, from the compute
host's bag (everything there was received on the compute host, log times on its simulated clock).

Figures (``summary.json``): ``hosts``, ``link_cuts`` (``{at_s, for_s}``, simulated seconds from the start of the
drive), ``odometry_max_gap_s`` (the longest time between two odometry messages the compute host received, by
their log times), ``gnss_resumed_after_s`` (per cut: from the link's return to the first filter status that
counts more fixes than any status before it; the status comes once a simulated second, so this is an upper
bound within 1 s),
``input_stale_max_s`` (the longest input staleness the filter reported through the cuts, its steady-clock s),
``live_vs_offline_max_m`` and ``horizontal_rms_m`` (the report's: live odometry against the offline replay of
this bag, and against the truth),
``horizontal_rms_outside_cuts_m`` (against the truth, the epochs stamped inside a cut left out),
``odometry_stamp_max_gap_s`` (the longest time between two odometry stamps: about the filter epoch when the
samples of a cut were delivered after it, as the sensor data's reliable QoS does, nav_bringup.hosts.link_qos; the
cut's length when they were lost) and ``imu_samples_missing`` (in the filter's input, by the IMU's stamps).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from nav_core import bagio

ODOM, DIAG = "odometry/filtered", "diagnostics"
STALE_AFTER_S = 5.0
"""s of simulated time after a link's return in which the filter's stale reports still belong to the cut (later
ones are the end of the run: the player done, the graph not yet stopped)."""


def _series(bag: Path):
    """(odometry log times s, [(log time s, fixes, input_stale_s)] of the filter's statuses)."""
    odom, diag = [], []
    for topic, log_ns, msg in bagio.iter_messages(bag, [ODOM, DIAG]):
        if bagio.norm_topic(topic) == ODOM:
            odom.append(log_ns * 1e-9)
            continue
        for st in msg.status:
            if st.name.startswith("ins_gps_kf"):
                values = {kv.key: kv.value for kv in st.values}
                diag.append((log_ns * 1e-9, int(float(values.get("fixes", 0))),
                             float(values.get("input_stale_s", 0) or 0)))
    return np.array(odom), diag


def filter_statuses(bag: Path) -> list:
    """[(log time s, fixes fused, input_stale_s)] of the filter's statuses in ``bag``, in log order."""
    return _series(bag)[1]


def stale_during_cuts(statuses: list, cuts: list, epoch_s: float) -> list:
    """The input staleness (s) the filter reported during the cuts, from ``statuses`` as :func:`filter_statuses`
    gives them: logged from a status period before a cut's start (they are logged at the last ``/clock`` the
    compute host received, which the cut's start, the probe's ``/clock``, can be a hair past) to
    :data:`STALE_AFTER_S` after the link's return; ``epoch_s``: the drive's start, clock s. The staleness every run
    shows after the drive (the player done, the graph not yet stopped) is not the cut's and is left out."""
    return [s for cut in cuts for t, _, s in statuses
            if epoch_s + cut["at_s"] - 1.0 <= t <= epoch_s + cut["restored_at_s"] + STALE_AFTER_S]


def _summary(run_dir: Path) -> dict:
    """The report's summary.json ({} when the run had no odometry to report)."""
    path = Path(run_dir) / "summary.json"
    return json.loads(path.read_text()) if path.exists() else {}


def rms_outside_cuts(odom, cuts: list, epoch_s: float, sim_dir) -> float | None:
    """Horizontal RMS of the odometry (a ``nav_core.recording`` OdometryRecording) against the simulation's truth
    (m) over the epochs stamped outside the cuts; None without a simulation."""
    if sim_dir is None:
        return None
    from nav_bringup.truth import TruthTrack

    err = np.hypot(*(odom.position - TruthTrack.from_sim_dir(sim_dir).at(odom.t))[:, :2].T)
    out = np.ones(len(odom), bool)
    for cut in cuts:
        out &= ~((odom.t >= epoch_s + cut["at_s"]) & (odom.t <= epoch_s + cut["restored_at_s"]))
    return float(np.sqrt(np.mean(err[out] ** 2))) if out.any() else None


def link_figures(run_dir: Path, cuts: list, epoch_s: float, sim_dir=None) -> dict:
    """The two-host figures of ``run_dir`` (its bag and summary.json); ``epoch_s``: the drive's start, clock s;
    ``sim_dir``: the simulation (its truth gives the RMS outside the cuts)."""
    from nav_core import recording

    odom, diag = _series(Path(run_dir) / "bag")
    try:
        stamped = recording.read_odometry(Path(run_dir) / "bag")
    except recording.RecordingError:  # a drive too short to align: the report says so, these figures are None
        stamped = []
    resumed, stale = [], [0.0] + stale_during_cuts(diag, cuts, epoch_s)
    for cut in cuts:
        back = epoch_s + cut["restored_at_s"]
        # every fix fused before the link returned counts as before, those queued before the cut and fused in it
        # too (the status then comes on the steady clock, logged at the stopped simulated time)
        before = max((f for t, f, _ in diag if t <= back), default=0)
        after = next((t for t, f, _ in diag if t > back and f > before), None)
        resumed.append(None if after is None else round(after - back, 3))
    summary = _summary(run_dir)
    offline, stream = summary.get("offline") or {}, summary.get("stream") or {}
    return {"hosts": 2, "link_cuts": [{"at_s": c["at_s"], "for_s": c["for_s"]} for c in cuts],
            "odometry_max_gap_s": round(float(np.max(np.diff(odom))), 3) if len(odom) > 1 else None,
            "odometry_stamp_max_gap_s": round(float(np.max(np.diff(stamped.t))), 3) if len(stamped) > 1 else None,
            "imu_samples_missing": stream.get("IMU samples missing in the filter's input"),
            "gnss_resumed_after_s": resumed[0] if len(resumed) == 1 else (resumed or None),
            "input_stale_max_s": round(max(stale), 3),
            "live_vs_offline_max_m": offline.get("largest difference (m)"),
            "horizontal_rms_m": (summary.get("rms") or {}).get("horizontal position (m)"),
            "horizontal_rms_outside_cuts_m":
                rms_outside_cuts(stamped, cuts, epoch_s, sim_dir) if cuts and len(stamped) else None}


def plot_link(run_dir: Path, cuts: list, epoch_s: float, path: Path) -> Path:
    """Odometry spacing and the filter's fused fixes against simulated time, the cuts shaded."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    odom, diag = _series(Path(run_dir) / "bag")
    diag = [d for d in diag if d[0] >= epoch_s - 60.0]  # recorded before the first /clock: log time 0
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    if len(odom) > 1:
        ax1.plot(odom[1:] - epoch_s, np.diff(odom), ".", ms=2)
    if diag:
        t, fixes, stale = (np.array(v) for v in zip(*diag))
        ax2.plot(t - epoch_s, fixes, "-", label="fixes fused")
        ax2b = ax2.twinx()
        ax2b.plot(t - epoch_s, stale, "r.", ms=3, label="input stale (s, filter)")
        ax2b.set_ylabel("input stale (s)", color="r")
    for cut in cuts:
        for ax in (ax1, ax2):
            ax.axvspan(cut["at_s"], cut["restored_at_s"], color="0.85", label="link down" if ax is ax1 else None)
    ax1.set_ylabel("odometry spacing (s)")
    if cuts:  # the only labelled artist (matplotlib warns on an empty legend: a run without a cut)
        ax1.legend(loc="upper left")
    ax2.set_ylabel("fixes fused")
    ax2.set_xlabel("simulated time from the start of the drive (s)")
    ax1.set_title("two hosts: the link cut, the gap and the recovery (compute host's bag)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def add_to_report(run_dir: Path, cuts: list, epoch_s: float, sim_dir=None) -> dict:
    """Add the two-host figures to ``summary.json`` and the link plot to ``report.html``; return the figures."""
    run_dir = Path(run_dir)
    figures = link_figures(run_dir, cuts, epoch_s, sim_dir)
    summary = _summary(run_dir)
    summary.update(figures)
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=1, default=str))
    plot_link(run_dir, cuts, epoch_s, run_dir / "link.png")
    html = run_dir / "report.html"
    if html.exists():
        rows = "".join(f"<tr><td>{k}</td><td>{v}</td></tr>" for k, v in figures.items())
        part = f'<h2>Two hosts</h2><table>{rows}</table><img src="link.png">'
        text = html.read_text()
        html.write_text(text.replace("</body>", part + "</body>") if "</body>" in text else text + part)
    return figures
