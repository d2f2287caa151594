"""``nav-eval`` (also ``ins-gps-kf evaluate``): accuracy figures and plots on a simulated or real dataset, or of a smoothed replay's
trajectories through GNSS outages against a truth (``--trajectory``, :mod:`nav_eval.outages`); JSON on stdout.

Registered as a plugin of the ``ins-gps-kf`` CLI (entry point group ``ins_gps_kf.cli``), so the
runtime package ``ins_gps_kf`` offers the command without importing the evaluations.
"""
from __future__ import annotations

import argparse
import json

from nav_core.cli import about, add_common, parse_args, run_cli
from nav_core.recording import RecordingError

DATASETS = ("paper-sim", "katwijk", "canada", "balzer")


PURPOSE = "Measure the filter's accuracy on the simulated paper drive or a real recording: JSON figures and plots."
EXAMPLES = ("evaluate --dataset katwijk --out out/eval_katwijk",
            "evaluate --dataset paper-sim --claims --seed 1 --out out/claims",
            "evaluate --trajectory out/smoothed.csv --truth truth.csv --out out/eval_outages")


def add_parser(subparsers) -> None:
    """Add the ``evaluate`` subcommand to the ``ins-gps-kf`` parser; it runs :func:`evaluate`."""
    ev = subparsers.add_parser("evaluate", help="accuracy figures and plots on a simulated or real dataset",
                               **about(PURPOSE, *(f"ins-gps-kf {e}" for e in EXAMPLES)))
    _add_arguments(ev)


def build_parser() -> argparse.ArgumentParser:
    """The ``nav-eval`` parser: the same arguments as ``ins-gps-kf evaluate``."""
    parser = argparse.ArgumentParser(prog="nav-eval", **about(
        PURPOSE, *(f"nav-eval {e.removeprefix('evaluate ')}" for e in EXAMPLES)))
    _add_arguments(parser)
    add_common(parser)
    return parser


def main(argv=None) -> int:
    """Console script ``nav-eval`` (the same command as ``ins-gps-kf evaluate``)."""
    return run_cli("nav-eval", evaluate, parse_args(build_parser(), argv))


def _add_arguments(ev) -> None:
    """The evaluation's options on parser ``ev``."""
    ev.add_argument("--dataset", choices=DATASETS, help="a dataset to run the filter on (or --trajectory)")
    ev.add_argument("--trajectory", metavar="OUT.csv", help="the smoothed trajectory of ins-gps-kf replay --smooth "
                    "(OUT.forward.csv beside it is the forward one): forward and smoothed horizontal errors with "
                    "their 3-sigma bands through the GNSS outages, and the largest error per outage")
    ev.add_argument("--forward", metavar="FORWARD.csv", help="with --trajectory: the forward trajectory (default "
                    "OUT.forward.csv)")
    ev.add_argument("--truth", metavar="TRUTH.csv", help="with --trajectory: the truth trajectory CSV")
    ev.add_argument("--outage", action="append", metavar="T0:T1", help="with --trajectory: an outage window, s "
                    "(repeat; default: the gaps over 10 s between the forward filter's GNSS updates)")
    ev.add_argument("--out", required=True, help="output folder (JSON figures and PNG plots)")
    ev.add_argument("--seed", type=int, default=0, help="simulation seed (paper-sim)")
    ev.add_argument("--scenario", help="scenario YAML for paper-sim (default: the workspace's "
                    "config/scenarios/paper_drive.yaml, found from $MEMS_NAV_ROOT or the current folder up)")
    ev.add_argument("--claims", action="store_true", help="WMRA on/off x Allan-derived/hand-tuned noise model "
                    "table (paper-sim, katwijk)")
    ev.add_argument("--force", action="store_true", help="replace an existing non-empty --out (once the new one is written)")
    ev.set_defaults(run=evaluate)


def evaluate(args) -> int:
    """Run the chosen evaluation and print its figures as JSON; RecordingError for a bad dataset choice.

    ``--out`` is checked before the work and written whole: the figures and plots go to a temporary
    folder next to it, renamed into place when all is written (a failure leaves ``--out`` as it was).
    """
    from nav_core.outputs import staged_dir

    if (args.dataset is None) == (args.trajectory is None):
        raise RecordingError("give either --dataset or --trajectory (with --truth)")
    if args.trajectory is not None and args.truth is None:
        raise RecordingError("--trajectory needs --truth TRUTH.csv (the errors are against it)")
    if args.claims and args.dataset not in ("paper-sim", "katwijk"):
        raise RecordingError(f"--claims: only paper-sim and katwijk, not {args.dataset}")
    inputs = tuple(p for p in (getattr(args, "scenario", None), args.trajectory, args.forward, args.truth) if p)
    with staged_dir(args.out, getattr(args, "force", False), inputs=inputs) as tmp:  # checked before the work
        figures = _run(args, tmp)
    print(json.dumps(figures, indent=1, default=float))
    return 0


def _run(args, out_dir) -> dict:
    """The evaluation ``args`` ask for, written into ``out_dir``; its figures."""
    from nav_eval import claims, datasets, outages, paper_sim

    if args.trajectory is not None:
        return outages.evaluate_files(args.trajectory, args.truth, out_dir, args.forward, _windows(args.outage))
    if args.claims:
        return (claims.claims_paper_sim(out_dir, seed=args.seed, scenario=args.scenario)
                if args.dataset == "paper-sim" else claims.claims_katwijk(out_dir))
    if args.dataset == "paper-sim":
        return paper_sim.paper_sim(out_dir, seed=args.seed, scenario=args.scenario)
    if args.dataset == "balzer":
        return datasets.evaluate_balzer(out_dir)
    return datasets.evaluate_rover(args.dataset, out_dir)


def _windows(specs) -> list | None:
    """``--outage T0:T1`` windows as (t0, t1) s; None when none given. RecordingError naming a bad one."""
    if not specs:
        return None
    out = []
    for spec in specs:
        try:
            t0, t1 = (float(v) for v in spec.split(":"))
        except ValueError:
            raise RecordingError(f"--outage {spec!r}: expected T0:T1 in s") from None
        if not t1 > t0:
            raise RecordingError(f"--outage {spec!r}: T1 must be after T0")
        out.append((t0, t1))
    return out
