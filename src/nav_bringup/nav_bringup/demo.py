"""``nav-demo``: the main job on the built-in default scenario (no hardware needed), or on a recording.

Simulates the paper's drive with BP3010-grade errors (cached per seed), then runs
the live graph, each node its own process on DDS::

    scenario_player (emulator -> pty, GPS, /clock) -> bp3010_driver -> wmra_node -> ins_gps_kf_node
                                                     allan_node (stationary head)   bag_record (everything)
                                                     sensor_health_node (names sensor faults live)

and ends with a report (HTML with PNG plots, and a summary on the terminal).
``--recording BAG`` replays a bag through bag_play -> wmra_node -> ins_gps_kf_node instead (the same side nodes).
"""
from __future__ import annotations

import argparse
import os
import random
import shutil
import sys
import tempfile
import time
from pathlib import Path

from nav_bringup.description import PLAYER_SETTLE_S, GraphInputs, navigation_graph, played_topics  # noqa: F401
from nav_bringup import hosts
from nav_bringup.graph import PARAMS_FILE, REPO, Graph, GraphError
from nav_core.cli import USER_ERRORS, about, add_common, debug_wanted, number, one_line
from nav_core.cli import parse_args as cli_parse_args
from nav_core.outputs import check_out_dir

DEFAULT_SCENARIO = REPO / "config" / "scenarios" / "paper_drive.yaml"
DEFAULT_MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
DEFAULT_OUT = REPO / "out" / "demo"


def parse_args(argv=None):
    """Command-line options."""
    detail = __doc__.split("\n\n", 1)[1]
    p = argparse.ArgumentParser(prog="nav-demo", **about(
        "Run the live navigation graph on the built-in drive (no hardware needed) or on a recording, with a report."
        "\n\n" + detail.rstrip(),
        "nav-demo --rate 8", "nav-demo --duration 120", "nav-demo --recording out/katwijk --rate 4"))
    p.add_argument("--rate", type=number(0.0, 100.0, low_open=True), default=1.0,
                   help="speed in (0, 100]: 4 runs four times faster than real time")
    p.add_argument("--duration", type=number(0.0, None), default=0.0,
                   help="stop after this much simulated time, s (0: all)")
    p.add_argument("--scenario", type=Path, default=DEFAULT_SCENARIO, help="simulator scenario YAML")
    p.add_argument("--model", type=Path, default=DEFAULT_MODEL, help="sensor-model YAML (simulation and nodes)")
    p.add_argument("--seed", type=number(0, 2**63 - 1, integer=True), default=1)
    p.add_argument("--recording", type=Path, default=None,
                   help="replay this rosbag2 bag, or a folder written by nav-convert, instead of simulating")
    p.add_argument("--truth", type=Path, default=None, help="truth CSV for --recording (else compared with GPS)")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="folder for the simulation, bag, logs, report")
    p.add_argument("--params", type=Path, default=PARAMS_FILE, help="the graph's params file")
    p.add_argument("--hosts", type=int, choices=(1, 2), default=1,
                   help="2: the sensor host (player, driver) and the compute host (the other nodes) in two network "
                        "namespaces joined by a veth link (root only; nav_bringup.hosts)")
    p.add_argument("--cut-link", metavar="AT_S:FOR_S", default=None,
                   help="with --hosts 2: take the link down at AT_S of simulated time for FOR_S seconds")
    add_common(p)
    return cli_parse_args(p, argv)


def simulate_scenario(scenario: Path, model: Path, seed: int, out: Path, duration_s: float | None = None,
                      fmt: str = "all") -> dict:
    """Simulate ``scenario`` (its first ``duration_s`` when given) with ``model`` into ``out``; the scenario
    (:class:`imu_sim.scenario.Scenario`, read by :func:`imu_sim.scenario.load` as every entry point reads it)."""
    from imu_sim import scenario as scenario_mod
    from imu_sim.simulate import simulate, write_outputs
    from nav_core import sensor_model

    scen = scenario_mod.load(scenario)
    if duration_s is not None:
        scen.duration_s = float(duration_s)
    write_outputs(simulate(scen, model=sensor_model.load(model), seed=seed), out, fmt=fmt)
    return scen


SIM_MARKER = ".nav-demo-simulation"  # in a simulation folder nav-demo wrote: the names it wrote there, one a line


class DemoError(RuntimeError):
    """A user error the demo reports in one line (exit 2)."""


def simulate_once(scenario: Path, model: Path, seed: int, out: Path) -> Path:
    """Simulate the scenario with the model (cached by seed); return the simulation folder.

    A stale cache is replaced name by name: only what nav-demo wrote there (listed in its marker
    file) is removed; a folder of that name nav-demo did not write is refused (DemoError).
    """
    sim_dir = out / f"sim_seed{seed}"
    newest_input = max(scenario.stat().st_mtime, model.stat().st_mtime)
    if sim_dir.exists() and not (sim_dir / SIM_MARKER).is_file() and any(sim_dir.iterdir()):
        raise DemoError(f"{sim_dir} exists and was not written by nav-demo (no {SIM_MARKER}): "
                        "move it away or choose another --out")
    if (sim_dir / "bp3010.bin").exists() and (sim_dir / "bp3010.bin").stat().st_mtime > newest_input:
        print(f"[demo] using the simulation in {sim_dir}")
        return sim_dir
    print(f"[demo] simulating {scenario.name} with {model.name} (seed {seed}) into {sim_dir}")
    out.mkdir(parents=True, exist_ok=True)
    fresh = Path(tempfile.mkdtemp(prefix=f".sim_seed{seed}.", dir=out))
    try:
        simulate_scenario(scenario, model, seed, fresh)
        _replace_simulation(sim_dir, fresh)
    finally:
        shutil.rmtree(fresh, ignore_errors=True)  # a temporary folder of our own
    return sim_dir


def _replace_simulation(sim_dir: Path, fresh: Path) -> None:
    """Move the entries of ``fresh`` into ``sim_dir``, removing only entries nav-demo wrote there before."""
    sim_dir.mkdir(parents=True, exist_ok=True)
    ours = set((sim_dir / SIM_MARKER).read_text().split()) if (sim_dir / SIM_MARKER).is_file() else set()
    names = sorted(p.name for p in fresh.iterdir())
    present = [sim_dir / n for n in names if (sim_dir / n).exists() or (sim_dir / n).is_symlink()]
    foreign = [p for p in present if p.name not in ours]
    if foreign:  # checked before anything is removed
        raise DemoError(f"{foreign[0]} exists and was not written by nav-demo: move it away or choose another --out")
    for old in present:
        shutil.rmtree(old) if old.is_dir() and not old.is_symlink() else old.unlink()
    for name in names:
        (fresh / name).rename(sim_dir / name)
    (sim_dir / SIM_MARKER).write_text("".join(f"{n}\n" for n in names))


def _use_converted_folder(args) -> None:
    """A nav-convert folder brings its bag, truth, sensor model and params: use what the user did not set."""
    folder = args.recording
    if not (folder / "bag").is_dir():
        return
    args.recording = folder / "bag"
    if args.truth is None and (folder / "truth.csv").exists():
        args.truth = folder / "truth.csv"
    if args.model == DEFAULT_MODEL and (folder / "sensor_model.yaml").exists():
        args.model = folder / "sensor_model.yaml"
    if args.params == PARAMS_FILE and (folder / "navigation.yaml").exists():
        args.params = folder / "navigation.yaml"


def check_inputs(args) -> None:
    """The files the graph will read, checked before anything starts (a user error, exit 2, naming the file):
    the params file (the filter's section validated as ``ins-gps-kf replay`` does), the sensor model, the
    scenario, the recording and the truth. Each node checks its own parameters again when it starts."""
    from imu_sim import scenario
    from ins_gps_kf import config as kfconfig
    from nav_core import bagio, recording, sensor_model

    if not args.params.is_file():
        raise DemoError(f"{args.params}: params file not found (--params)")
    data = kfconfig.read_params_file(args.params)
    if kfconfig.node_section(data, args.params) is not None:
        kfconfig.load_params_yaml(args.params)
    sensor_model.load(args.model)
    if args.recording is None:
        scenario.load(args.scenario)
    if args.recording is not None and not bagio.is_bag(args.recording):
        raise DemoError(f"{args.recording}: --recording is not a rosbag2 bag (folder with metadata.yaml, .db3, "
                        ".mcap) or a nav-convert folder" + ("" if args.recording.exists() else ": not found"))
    if args.truth is not None:
        recording.read_trajectory_csv(args.truth)


def graph_inputs(args, run_dir: Path, sim_dir: Path | None) -> GraphInputs:
    """This run's inputs to the one graph description (:func:`nav_bringup.description.navigation_graph`)."""
    common = dict(sensor_model=str(args.model.resolve()), rate=args.rate, bag_out=str(run_dir / "bag"),
                  allan_dir=str(run_dir / "allan"))
    if sim_dir is None:
        section = filter_section(args.params)
        wheel = section.get("odometer_topic", "odom/wheel") if section.get("odometer_enabled") else None
        gps = section.get("gps_topic", "gps/fix")
        return GraphInputs("recording", recording=str(args.recording.resolve()),
                           played_topics=played_topics(args.recording, gps, wheel), gps_topic=gps,
                           wheel_topic=wheel or "", **common)
    return GraphInputs("simulation", sim_dir=str(sim_dir), port=str(run_dir / "bp3010_port"),
                       duration_s=args.duration, reconnect_period_s=0.2, **common)


def graph_specs(args, run_dir: Path, sim_dir: Path | None) -> list:
    """The nodes of this run, in start order (the player last: it waits for the graph)."""
    return navigation_graph(graph_inputs(args, run_dir, sim_dir))


def filter_section(params_file: Path) -> dict:
    """The filter node's parameters in the params file, by the one section rule
    (:func:`ins_gps_kf.config.node_section`: ``/**`` then ``ins_gps_kf_node``)."""
    from ins_gps_kf import config as kfconfig

    found = kfconfig.node_section(kfconfig.read_params_file(params_file), params_file)
    return found[0] if found else {}


def filter_params(params_file: Path, specs) -> dict:
    """The filter node's parameters in this run: the params file's section with the run's overrides."""
    overrides = next((s.overrides for s in specs if s.executable == "ins_gps_kf_node"), {})
    return {k: v for k, v in {**filter_section(params_file), **overrides}.items()
            if k != "use_sim_time" and not k.startswith("qos_overrides")}  # node-only: DDS, not the filter


def main(argv=None) -> int:
    """Simulate (or take the recording), run the graph, write the report."""
    args = parse_args(argv)
    if args.recording is not None:
        _use_converted_folder(args)
    env = dict(os.environ)
    env.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 99)))
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if args.hosts == 2:
        env = hosts.discovery_env(env)  # across the link: no localhost-only discovery
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    try:
        cut = hosts.plan(args.hosts, args.cut_link, args.duration)  # not root: one line, exit 2, before any work
        check_inputs(args)
        check_out_dir(args.out, allow_existing=True)  # a file or an unwritable --out fails before any work
        sim_dir = None if args.recording else simulate_once(args.scenario, args.model, args.seed, args.out)
    except (DemoError,) + USER_ERRORS as err:
        if debug_wanted(args):
            raise
        print(f"nav-demo: error: {one_line(err)}", file=sys.stderr)
        return 2
    run_dir = args.out / time.strftime("run_%Y%m%d_%H%M%S")
    run_dir.mkdir(parents=True)
    two = hosts.HostRun(cut, args.rate) if args.hosts == 2 else None
    specs = graph_specs(args, run_dir, sim_dir)
    # reliable and kept on one host too: best effort, a recorder on a busy CPU lost 325 of the 37406 samples the
    # filter received in a Katwijk replay at 8x (CI at 180dd93), and the report's replay of its bag cannot match
    graph = Graph(hosts.link_qos(specs), env, args.params, log_dir=run_dir / "logs",
                  prefix=two.prefix if two else None, progress=lambda text: print(f"[demo] {text}", flush=True))
    player = "bag_play" if args.recording else "scenario_player"
    print(f"[demo] starting the graph (ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}); output in {run_dir}")
    try:
        from nav_bringup.live_status_ros import watch

        watch(graph, player, sim_dir, on_clock=two.on_clock if two else None, start=graph.start)
    except GraphError as err:
        print(f"[demo] {err}", file=sys.stderr)
        graph.stop()
        return 2 if err.exit_code == 2 else 1  # a node refused its configuration: a user error
    except KeyboardInterrupt:
        print("[demo] interrupted")
    codes = graph.stop()
    print("[demo] exit codes: " + ", ".join(f"{k} {v}" for k, v in codes.items()))
    from nav_bringup.report import write_report

    # a minute or two on 2 cores after a whole drive: the offline replay, the GNSS-outage study, the plots
    print("[demo] writing the report: the bag replayed offline, GNSS outages cut from it, the plots", flush=True)
    summary = write_report(run_dir, sim_dir=sim_dir, truth_csv=args.truth, exit_codes=codes,
                           filter_params=filter_params(args.params, graph.specs))
    print(summary)
    if two:
        print(two.finish(run_dir, sim_dir))
        if two.cutter is not None and two.cutter.missed():
            print(f"nav-demo: error: {two.cutter.missed()}", file=sys.stderr)
            return 1
    return 0 if all(c == 0 for c in codes.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
