"""``imu-sim``: the simulator's command line (subcommands; ``diagnose`` comes with the diagnosis issue)."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from nav_core.sensor_model import SensorModelError

from imu_sim.effects import EffectError
from imu_sim.plots import overview_png
from imu_sim.scenario import ScenarioError
from imu_sim.simulate import FORMATS, simulate, write_outputs


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="imu-sim", description="MEMS IMU / GPS / BP3010 simulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="simulate a scenario into a recording folder")
    sim.add_argument("--scenario", required=True, help="scenario YAML (see src/imu_sim/README.md)")
    sim.add_argument("--model", default=None, help="sensor-model YAML (default: the scenario's, else ideal)")
    sim.add_argument("--out", required=True, help="output folder")
    sim.add_argument("--seed", type=int, default=None, help="random seed (default: scenario's, else 0)")
    sim.add_argument("--rate-hz", type=float, default=None, help="IMU rate, Hz (default: scenario's, else 64)")
    sim.add_argument("--format", choices=FORMATS, default="all", help="bag, csv or all")
    sim.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3", help="rosbag2 storage")
    return parser


def _simulate(args) -> int:
    steps = tqdm(total=3, desc="imu-sim", unit="step", file=sys.stderr)
    start = time.perf_counter()
    steps.set_postfix_str("simulating")
    res = simulate(args.scenario, args.model, seed=args.seed, rate_hz=args.rate_hz)
    steps.update()
    print(f"simulated {res.info['duration_s']:.1f} s at {res.rate_hz:g} Hz ({len(res.imu)} IMU samples, "
          f"{0 if res.gnss is None else len(res.gnss)} GPS fixes) in {time.perf_counter() - start:.1f} s")
    steps.set_postfix_str("writing recording")
    paths = write_outputs(res, args.out, args.format, args.storage)
    steps.update()
    steps.set_postfix_str("plotting")
    paths["overview_png"] = overview_png(res, Path(args.out) / "overview.png")
    steps.update()
    steps.close()
    for name, path in paths.items():
        print(f"  {name}: {path}")
    if res.bp3010 is None:
        print("  (no bp3010.bin: imu_driver.bp3010_codec is not installed)")
    return 0


def main(argv=None) -> int:
    """Entry point of the ``imu-sim`` console script."""
    args = _parser().parse_args(argv)
    try:
        return _simulate(args)
    except (ScenarioError, SensorModelError, EffectError, FileExistsError, ValueError) as err:
        print(f"imu-sim: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
