"""``nav-batch``: one single-recording tool over a fleet's recordings on Dask distributed, one task per recording.

    nav-batch allan    REC... --out DIR [--workers N | --scheduler tcp://HOST:PORT] [--resume] [allan options]
    nav-batch diagnose REC... --out DIR --scenario S.yaml --model M.yaml [...]
    nav-batch replay   REC... --out DIR --model M.yaml [...]

``DIR/<recording stem>/`` holds what ``imu-calib allan``, ``imu-sim diagnose`` or ``ins-gps-kf replay`` writes for
that recording (``replay``: ``trajectory.csv`` and ``.png``); ``DIR/results.csv`` has one row per recording:
``recording, status (ok|error), message, wall_s`` and the tool's key figures. ``--workers N`` starts a Dask
LocalCluster of N single-threaded worker processes on this machine; ``--scheduler`` uses a running cluster.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from nav_core.cli import about, add_common, number, parse_args, run_cli
from nav_core.outputs import OutputError, check_out_dir

from nav_batch import batch, results
from nav_batch.tools import TOOLS


def build_parser() -> argparse.ArgumentParser:
    """The parser: one subcommand per tool, each with the cluster options and its tool's options."""
    parser = argparse.ArgumentParser(prog="nav-batch", **about(
        "Run one single-recording tool over a fleet's recordings on Dask, one task per recording.\n"
        + __doc__.split("\n", 1)[1].rstrip(),
        "nav-batch allan bags/*.mcap --out out/fleet_allan --workers 2",
        "nav-batch replay bags/*.mcap --model default --imu-topic /imu/data --gps-topic /fix --out out/fleet_replay "
        "--scheduler tcp://10.0.0.5:8786"))
    add_common(parser)
    sub = parser.add_subparsers(dest="tool", required=True)
    for name, help_text, example in (
            ("allan", "imu-calib allan on each recording", "nav-batch allan bags/*.mcap --out out/fleet_allan"),
            ("diagnose", "imu-sim diagnose on each recording (one scenario and model for all)",
             "nav-batch diagnose run1.csv run2.csv --scenario scenario.yaml --model model.yaml --out out/fleet_diag"),
            ("replay", "ins-gps-kf replay on each recording (a bag with imu and gps topics)",
             "nav-batch replay bags/*.mcap --model default --out out/fleet_replay --workers 2")):
        p = sub.add_parser(name, help=help_text, **about(f"Run {help_text}, one Dask task per recording.", example))
        p.add_argument("recordings", nargs="+", metavar="REC", help="recordings (bag folders, .mcap, .db3, .csv)")
        p.add_argument("--out", type=Path, required=True, help="output folder (new or empty; --force, --resume)")
        add_common(p, force=True, sub=True)
        where = p.add_mutually_exclusive_group()
        where.add_argument("--workers", type=number(1, 1024, integer=True), default=None,
                           help="worker processes of a local Dask cluster (default: the CPU count)")
        where.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
        p.add_argument("--resume", action="store_true", help="keep the rows already ok in --out, run the rest")
        p.add_argument("--no-progress", action="store_true", help="no progress bar")
        _tool_options(name, p)
    return parser


def _tool_options(name: str, p: argparse.ArgumentParser) -> None:
    """The single-recording command's options that nav-batch passes on, spelled as there."""
    if name == "allan":
        p.add_argument("--topic", help="IMU topic in a bag (imu-calib's default when not given)")
        p.add_argument("--format", choices=("auto", "ucalgary", "adis"), help="recording format (imu-calib allan)")
        p.add_argument("--per-decade", type=number(0, 100, integer=True), help="cluster times per decade")
        p.add_argument("--base-model", help="sensor model whose deterministic terms are kept")
        p.add_argument("--split-at-gaps", action="store_true", help="analyse the longest unbroken segment")
    elif name == "diagnose":
        p.add_argument("--scenario", required=True, help="scenario YAML (the same for every recording)")
        p.add_argument("--model", required=True, help="sensor-model YAML")
        p.add_argument("--max-effects", type=number(0, 16, integer=True), help="most effects to add")
    else:
        p.add_argument("--model", required=True, help="sensor-model YAML, or 'default'")
        p.add_argument("--params", help="ROS 2 params file (ins_gps_kf_node: ros__parameters:)")
        p.add_argument("--param", action="append", metavar="NAME=VALUE", help="override one filter parameter")
        p.add_argument("--imu-topic", help="IMU topic in the bags")
        p.add_argument("--gps-topic", help="GNSS topic in the bags")
        p.add_argument("--no-plot", action="store_true", help="no trajectory.png")


TOOL_OPTIONS = {"allan": ("topic", "format", "per_decade", "base_model", "split_at_gaps"),
                "diagnose": ("scenario", "model", "max_effects"),
                "replay": ("model", "params", "param", "imu_topic", "gps_topic", "no_plot")}


def options_of(args) -> dict:
    """The tool's options as given (paths as typed: the worker reads them as the single command would)."""
    return {k: getattr(args, k) for k in TOOL_OPTIONS[args.tool] if getattr(args, k) not in (None, False)}


def check_output(args, options: dict) -> dict:
    """Apply the existing-output rules before any work; recording -> rows carried over (``--resume``)."""
    if args.resume and args.force:
        raise OutputError("--resume keeps the rows already ok and --force replaces the folder: give one of them")
    inputs = list(args.recordings) + [v for k, v in options.items() if k in ("scenario", "model", "base_model")]
    check_out_dir(args.out, args.force, allow_existing=args.resume, inputs=inputs)
    if args.resume and args.out.is_dir():
        return batch.carried_over(args.out, batch.plan(args.recordings, args.out), args.tool, options)
    return {}


QUIET_CLUSTER = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                 "distributed.admin.system-monitor.interval": "2s"}
"""A local cluster's housekeeping, made lighter: the workers' stack sampler (every 10 ms) off, the event-loop
watchdog tick at 1 s (20 ms by default) and the system monitor at 2 s; idle, two workers then cost 0.5 CPU-s per
20 s instead of 1.4 (measured here), which on 2 cores is time the recordings do not get."""


def connect(args):
    """A Dask client: on the given scheduler, or on a new LocalCluster of single-threaded worker processes."""
    import dask
    from distributed import Client, LocalCluster

    if args.scheduler:
        return Client(args.scheduler, timeout="30s"), None
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # inherited by the workers: one core per worker process
    dask.config.set(QUIET_CLUSTER)  # passed on to the workers by their nannies
    cluster = LocalCluster(n_workers=args.workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster), cluster


def run(args) -> int:
    """The batch: check the output, run every recording not yet ok, print the summary; 1 when a row is error."""
    from tqdm import tqdm

    options = options_of(args)
    done = check_output(args, options)
    folders = batch.plan(args.recordings, args.out)
    with batch.replacing(args.out, args.force, args.recordings):
        args.out.mkdir(parents=True, exist_ok=True)
        results.write_batch(args.out, args.tool, options)
        bar = tqdm(total=len(folders), initial=len(done), desc=f"nav-batch {args.tool}", unit="rec",
                   disable=args.no_progress, file=sys.stderr)
        counts = {"ok": sum(1 for r in done.values() if r["status"] == "ok"), "error": 0}

        def progress(row):
            counts[row["status"]] += 1
            bar.set_postfix(counts)
            bar.update(1)

        client, cluster = connect(args)
        try:
            rows = batch.run_batch(client, args.tool, folders, options, args.out, done, progress)
        finally:
            bar.close()
            client.close()
            if cluster is not None:
                cluster.close()
    for row in rows:
        if row["status"] != "ok":
            print(f"nav-batch: error row: {row['message']}", file=sys.stderr)
    print(f"nav-batch {args.tool}: {counts['ok']} ok, {counts['error']} error of {len(rows)} "
          f"({len(done)} carried over); wrote {args.out / results.RESULTS}")
    return 0 if counts["error"] == 0 else 1


def main(argv=None) -> int:
    """Console-script entry point: exit 0 all ok, 1 some rows error, 2 a usage or output error."""
    args = parse_args(build_parser(), argv)
    return run_cli(f"nav-batch {args.tool}", run, args)


if __name__ == "__main__":
    sys.exit(main())
