"""``imu-sim``: the simulator's command line: ``simulate``, ``diagnose`` (sim versus real), ``prepare-real``."""
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
    diag = sub.add_parser("diagnose", help="sim versus real: locate the mismatch, name and model the missing physics")
    diag.add_argument("--recording", required=True, help="rosbag2 bag or recording CSV (t, gx..az[, temp_c], SI)")
    diag.add_argument("--scenario", required=True, help="scenario YAML (trajectory or static_segments)")
    diag.add_argument("--model", required=True, help="sensor-model YAML: what the simulation believes")
    diag.add_argument("--out", required=True, help="output folder (diagnosis.json, model_updated.yaml, report.html)")
    diag.add_argument("--gnss", default=None, help="GNSS CSV (t, lat_deg, lon_deg, h_m, std_e, std_n, std_u)")
    diag.add_argument("--max-effects", type=int, default=4, help="most effects to add (iterations)")
    prep = sub.add_parser("prepare-real", help="write recording CSV + scenario + noise model for a real data set")
    prep.add_argument("--dataset", choices=("adis16405", "ucalgary_updown"), required=True)
    prep.add_argument("--data-dir", required=True, help="folder of the data set (../shared/data/<name>)")
    prep.add_argument("--run", default="imu1", help="ADIS16405 run name (imu1..imu6)")
    prep.add_argument("--duration-s", type=float, default=None, help="crop (s)")
    prep.add_argument("--out", required=True)
    return parser


def _diagnose(args) -> int:
    from imu_sim.diagnose.case import load_case
    from imu_sim.diagnose.engine import diagnose
    from imu_sim.diagnose.report import write_all
    case = load_case(args.recording, args.scenario, args.model, args.gnss)
    steps = tqdm(desc="imu-sim diagnose", unit="pass", file=sys.stderr)
    diag = diagnose(case, max_effects=args.max_effects, progress=steps)
    steps.close()
    paths = write_all(diag, args.out, {"recording": args.recording, "scenario": args.scenario, "model": args.model})
    res = diag.result
    print("mismatch: " + ("yes" if res["mismatch"] else "no"))
    for f in res["findings"]:
        print(f"  {f['effect']}: {f['share_of_mismatch']:.0%} of the mismatch; channels {', '.join(f['channels'])}; "
              f"fit {f['fit_before']:.4g} -> {f['fit_after']:.4g}")
    for name, path in paths.items():
        print(f"  {name}: {path}")
    return 0


def _prepare_real(args) -> int:
    from imu_sim.diagnose import real
    data = Path(args.data_dir)
    if args.dataset == "adis16405":
        paths = real.prepare_adis(data / f"{args.run}.npz", args.out, args.duration_s)
    else:
        paths = real.prepare_updown(data / "x_adi_up.txt", data / "x_adi_down.txt", args.out)
    for name, path in paths.items():
        print(f"  {name}: {path}")
    return 0


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
    from nav_core.recording import RecordingError
    args = _parser().parse_args(argv)
    run = {"simulate": _simulate, "diagnose": _diagnose, "prepare-real": _prepare_real}[args.command]
    try:
        return run(args)
    except (ScenarioError, SensorModelError, EffectError, FileExistsError, RecordingError, OSError,
            ValueError) as err:
        print(f"imu-sim: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
