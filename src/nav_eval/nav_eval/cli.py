"""``ins-gps-kf evaluate``: accuracy figures and plots on a simulated or real dataset (JSON on stdout).

Registered as a plugin of the ``ins-gps-kf`` CLI (entry point group ``ins_gps_kf.cli``), so the
runtime package ``ins_gps_kf`` offers the command without importing the evaluations.
"""
from __future__ import annotations

import json

from nav_core.recording import RecordingError

DATASETS = ("paper-sim", "katwijk", "canada", "balzer")


def add_parser(subparsers) -> None:
    """Add the ``evaluate`` subcommand to the ``ins-gps-kf`` parser; it runs :func:`evaluate`."""
    ev = subparsers.add_parser("evaluate", help="accuracy figures and plots on a simulated or real dataset")
    ev.add_argument("--dataset", required=True, choices=DATASETS)
    ev.add_argument("--out", required=True, help="output folder (JSON figures and PNG plots)")
    ev.add_argument("--seed", type=int, default=0, help="simulation seed (paper-sim)")
    ev.add_argument("--scenario", help="scenario YAML for paper-sim (default: the workspace's "
                    "config/scenarios/paper_drive.yaml, found from $MEMS_NAV_ROOT or the current folder up)")
    ev.add_argument("--claims", action="store_true", help="WMRA on/off x Allan-derived/hand-tuned noise model "
                    "table (paper-sim, katwijk)")
    ev.add_argument("--force", action="store_true", help="write into an existing non-empty --out")
    ev.set_defaults(run=evaluate)


def evaluate(args) -> int:
    """Run the chosen evaluation and print its figures as JSON; RecordingError for a bad dataset choice."""
    from nav_core.outputs import check_out_dir
    from nav_eval import claims, datasets, paper_sim

    check_out_dir(args.out, getattr(args, "force", False))  # before the work, not after it
    if args.claims:
        if args.dataset not in ("paper-sim", "katwijk"):
            raise RecordingError(f"--claims: only paper-sim and katwijk, not {args.dataset}")
        figures = (claims.claims_paper_sim(args.out, seed=args.seed, scenario=args.scenario)
                   if args.dataset == "paper-sim" else claims.claims_katwijk(args.out))
    elif args.dataset == "paper-sim":
        figures = paper_sim.paper_sim(args.out, seed=args.seed, scenario=args.scenario)
    elif args.dataset == "balzer":
        figures = datasets.evaluate_balzer(args.out)
    else:
        figures = datasets.evaluate_rover(args.dataset, args.out)
    print(json.dumps(figures, indent=1, default=float))
    return 0
