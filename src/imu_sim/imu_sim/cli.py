"""``imu-sim``: the simulator's command line: ``simulate``, ``diagnose`` (sim versus real), ``prepare-real``."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from nav_core.cli import about, add_common, number, parse_args, run_cli
from nav_core.outputs import check_out_dir, rebase, staged_dir

from imu_sim.plots import overview_png
from imu_sim.scenario import MAX_RATE_HZ, load as load_scenario
from imu_sim.simulate import FORMATS, simulate, write_outputs


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="imu-sim", **about(
        "Simulate a MEMS IMU, GPS and BP3010 stream, and diagnose a simulation against a real recording.",
        "imu-sim simulate --scenario config/scenarios/paper_drive.yaml --out out/drive"))
    add_common(parser)
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="simulate a scenario into a recording folder", **about(
        "Simulate a scenario into a recording folder: bag and/or CSVs, BP3010 stream, truth, GPS.",
        "imu-sim simulate --scenario config/scenarios/paper_drive.yaml --model config/sensor_models/bp3010.yaml "
        "--seed 1 --out out/drive"))
    add_common(sim, force=True, sub=True)
    sim.add_argument("--scenario", required=True, help="scenario YAML (see src/imu_sim/README.md)")
    sim.add_argument("--model", default=None, help="sensor-model YAML (default: the scenario's, else ideal)")
    sim.add_argument("--out", required=True, help="output folder (new or empty; --force replaces it)")
    sim.add_argument("--seed", type=number(0, 2**63 - 1, integer=True), default=None,
                     help="random seed >= 0 (default: scenario's, else 0)")
    sim.add_argument("--rate-hz", type=number(0.0, MAX_RATE_HZ, low_open=True), default=None,
                     help=f"IMU rate in (0, {MAX_RATE_HZ:g}] Hz (default: scenario's, else 64)")
    sim.add_argument("--format", choices=FORMATS, default="all", help="bag, csv or all")
    sim.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3", help="rosbag2 storage")
    diag = sub.add_parser("diagnose", help="sim versus real: locate the mismatch, name and model the missing physics",
                          **about("Compare a recording with its simulation; name and fit the physical effects "
                                  "that explain the difference.",
                                  "imu-sim diagnose --recording out/ucal/imu.csv --scenario out/ucal/scenario.yaml "
                                  "--model out/ucal/model.yaml --out out/ucal_diag"))
    add_common(diag, force=True, sub=True)
    diag.add_argument("--recording", required=True, help="rosbag2 bag or recording CSV (t, gx..az[, temp_c], SI)")
    diag.add_argument("--scenario", required=True, help="scenario YAML (trajectory or static_segments)")
    diag.add_argument("--model", required=True, help="sensor-model YAML: what the simulation believes")
    diag.add_argument("--out", required=True, help="output folder (diagnosis.json, model_updated.yaml, report.html)")
    diag.add_argument("--gnss", default=None, help="GNSS CSV (t, lat_deg, lon_deg, h_m, std_e, std_n, std_u)")
    diag.add_argument("--max-effects", type=number(0, 16, integer=True), default=4,
                      help="most effects to add (iterations, 0-16)")
    prep = sub.add_parser("prepare-real", help="write recording CSV + scenario + noise model for a real data set",
                          **about("Write a recording CSV, its scenario and a noise model for a public real data set.",
                                  "imu-sim prepare-real --dataset ucalgary_updown "
                                  "--data-dir ../shared/data/ucalgary_adi_updown --out out/ucal"))
    add_common(prep, force=True, sub=True)
    prep.add_argument("--dataset", choices=("adis16405", "ucalgary_updown"), required=True)
    prep.add_argument("--data-dir", required=True, help="folder of the data set (../shared/data/<name>)")
    prep.add_argument("--run", default="imu1", help="ADIS16405 run name (imu1..imu6)")
    prep.add_argument("--duration-s", type=number(0.0, None, low_open=True), default=None, help="crop (s)")
    prep.add_argument("--out", required=True)
    return parser


def _diagnose(args) -> int:
    from imu_sim.diagnose.case import load_case
    from imu_sim.diagnose.engine import diagnose
    from imu_sim.diagnose.report import write_all
    inputs = (args.recording, args.scenario, args.model, args.gnss)
    check_out_dir(args.out, args.force, inputs=inputs)
    case = load_case(args.recording, args.scenario, args.model, args.gnss)
    steps = tqdm(desc="imu-sim diagnose", unit="pass", file=sys.stderr)
    diag = diagnose(case, max_effects=args.max_effects, progress=steps)
    steps.close()
    with staged_dir(args.out, args.force, inputs) as tmp:
        paths = write_all(diag, tmp, {"recording": args.recording, "scenario": args.scenario, "model": args.model})
    paths = rebase(paths, tmp, args.out)
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
    with staged_dir(args.out, args.force, inputs=(data,)) as tmp:
        if args.dataset == "adis16405":
            paths = real.prepare_adis(data / f"{args.run}.npz", tmp, args.duration_s)
        else:
            paths = real.prepare_updown(data / "x_adi_up.txt", data / "x_adi_down.txt", tmp)
    paths = rebase(paths, tmp, args.out)
    for name, path in paths.items():
        print(f"  {name}: {path}")
    return 0


def _simulate(args) -> int:
    inputs = (args.scenario, args.model)
    check_out_dir(args.out, args.force, inputs=inputs)  # before the work: a bad --out fails now, not after it
    scenario = load_scenario(args.scenario)  # a bad file fails before the progress bar starts
    steps = tqdm(total=3, desc="imu-sim", unit="step", file=sys.stderr)
    start = time.perf_counter()
    try:
        steps.set_postfix_str("simulating")
        res = simulate(scenario, args.model, seed=args.seed, rate_hz=args.rate_hz)
        steps.update()
        print(f"simulated {res.info['duration_s']:.1f} s at {res.rate_hz:g} Hz ({len(res.imu)} IMU samples, "
              f"{0 if res.gnss is None else len(res.gnss)} GPS fixes) in {time.perf_counter() - start:.1f} s")
        steps.set_postfix_str("writing recording")
        with staged_dir(args.out, args.force, inputs) as tmp:  # all outputs appear together, or none
            paths = write_outputs(res, tmp, args.format, args.storage)
            steps.update()
            steps.set_postfix_str("plotting")
            paths["overview_png"] = overview_png(res, tmp / "overview.png")
        paths = rebase(paths, tmp, args.out)
        steps.update()
    finally:
        steps.close()
    for name, path in paths.items():
        print(f"  {name}: {path}")
    if res.bp3010 is None:
        print("  (no bp3010.bin: imu_driver.bp3010_codec is not installed)")
    return 0


def main(argv=None) -> int:
    """Entry point of the ``imu-sim`` console script: exit 2 with one line for bad input (``--debug``: traceback)."""
    args = parse_args(_parser(), argv)
    run = {"simulate": _simulate, "diagnose": _diagnose, "prepare-real": _prepare_real}[args.command]
    return run_cli("imu-sim", run, args)


if __name__ == "__main__":
    sys.exit(main())
