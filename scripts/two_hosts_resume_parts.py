"""What a two-host cut run's ``gnss_resumed_after_s`` is made of, from the compute host's bag (docs/two_hosts.md).

    python scripts/two_hosts_resume_parts.py RUN_DIR [RUN_DIR ...]

Per run (a ``nav-demo --hosts 2 --cut-link`` folder with link_cuts.json), in simulated s after the link returned
(log times on the compute host's simulated clock): the first fix stamped after the cut's first second received,
the first odometry stamped after it published, and the status that counted a fix more (the report's figure).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from nav_bringup.link_report import filter_statuses
from nav_core import bagio


def parts(run: Path) -> dict:
    """``fixes_back_s``, ``odometry_of_cut_s``, ``status_s`` (s after the link returned) of one cut run."""
    cut = json.loads((run / "link_cuts.json").read_text())[0]
    back = cut["epoch_s"] + cut["restored_at_s"]
    in_cut = cut["epoch_s"] + cut["at_s"] + 1.0  # stamped after the cut's first second: sent while it was down
    first = {}
    for topic, log_ns, msg in bagio.iter_messages(run / "bag", ["gps/fix", "odometry/filtered"]):
        topic = bagio.norm_topic(topic)
        if topic not in first and bagio.stamp_to_s(msg.header.stamp) > in_cut:
            first[topic] = round(log_ns * 1e-9 - back, 3)
    statuses = filter_statuses(run / "bag")
    before = max((f for t, f, _ in statuses if t <= back), default=0)
    status = next((round(t - back, 3) for t, f, _ in statuses if t > back and f > before), None)
    return {"fixes_back_s": first.get("gps/fix"), "odometry_of_cut_s": first.get("odometry/filtered"),
            "status_s": status}


def main(argv=None) -> int:
    """Print each run's parts, then median / p90 / largest of each."""
    rows = {}
    for run in map(Path, (sys.argv[1:] if argv is None else argv)):
        rows[run] = parts(run)
        print(run, rows[run])
    for key in ("fixes_back_s", "odometry_of_cut_s", "status_s"):
        v = np.array([r[key] for r in rows.values() if r[key] is not None])
        if len(v):
            print(f"{key}: median {np.median(v):.2f}, p90 {np.percentile(v, 90):.2f}, largest {v.max():.2f} "
                  f"({len(v)} runs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
