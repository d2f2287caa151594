"""Benchmark of the whole graph (prints figures): load at 1,000 Hz, a 1-hour soak at 10x, the demo on a busy CPU.

    python benchmarks/bench_graph.py [--quick] [--skip-load] [--skip-soak]
    python benchmarks/bench_graph.py --busy-cpu [--rates 1 3 8] [--duration S]

* load: the paper drive streamed through emulator -> pty -> bp3010_driver -> wmra_node ->
  ins_gps_kf_node at 15.6x real time, i.e. 1,000 IMU frames per wall second: messages
  dropped at each stage, raw -> denoised latency (wall clock, p50/p99), CPU per node.
* soak: a 1-hour drive (the real 57-minute KF-GINS car track, simulated with BP3010-grade
  errors) replayed from a bag at 10x: bag_play -> wmra_node -> ins_gps_kf_node: resident
  memory of every node at the start and the end, GPS fixes used against fixes played, and
  the node's odometry against the offline `ins-gps-kf replay` of the same denoised input.
* busy CPU (``--busy-cpu``, not in the default run): `nav-demo` at each rate, once on a quiet
  machine and once with two busy-loop processes at nice 10 for the whole run; per run the
  horizontal RMS, the largest difference between the live odometry and the offline replay of
  the run's own bag (target 5 cm at every epoch), epochs on one side only, stamps going back,
  and what the filter dropped or missed; the driver's stamps against the simulated frames'
  times; the load average at the start and each node's CPU share; the busy RMS against the
  quiet one (target within 10 %).
"""
from __future__ import annotations

import argparse
import os
import random
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
KFGINS = REPO / ".." / "shared" / "data" / "kfgins_gnss" / "GNSS-RTK.txt"


def proc_stats(pid: int) -> tuple:
    """(CPU seconds, resident MB) of a process."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    rss = next(int(line.split()[1]) for line in Path(f"/proc/{pid}/status").read_text().splitlines()
               if line.startswith("VmRSS")) / 1024
    return cpu, rss


class Sampler(threading.Thread):
    """Samples CPU and memory of the graph's processes every ``period_s``."""

    def __init__(self, graph, period_s: float = 2.0):
        super().__init__(daemon=True)
        self.graph, self.period_s, self.samples, self.stop = graph, period_s, [], threading.Event()

    def run(self):
        while not self.stop.is_set():
            row = {"t": time.monotonic()}
            for name, proc in self.graph.procs.items():
                try:
                    row[name] = proc_stats(proc.proc.pid)
                except (OSError, StopIteration):
                    pass
            self.samples.append(row)
            self.stop.wait(self.period_s)

    def report(self, names, t0, t1) -> None:
        """CPU share over [t0, t1] and memory at the start and end of each node."""
        rows = [r for r in self.samples if t0 <= r["t"] <= t1]
        for name in names:
            have = [r for r in rows if name in r]
            if len(have) < 2:
                continue
            cpu = (have[-1][name][0] - have[0][name][0]) / (have[-1]["t"] - have[0]["t"])
            peak = max(r[name][1] for r in have)
            print(f"  {name:<18} CPU {cpu:6.1%} of one core; RSS start {have[0][name][1]:6.1f} MB, "
                  f"end {have[-1][name][1]:6.1f} MB, peak {peak:6.1f} MB")


def run_graph(specs, env, player: str, timeout_s: float, topics: dict, imu_topics=()):
    """Start the graph, probe ``topics`` and /diagnostics until the player exits; return what was seen.

    ``imu_topics`` are taken in raw batches (cheap enough not to load the machine at 1 kHz); they
    appear in the result as (receive time, stamp ns array) pairs.
    """
    from nav_bringup.graph import PARAMS_FILE, Graph
    from nav_bringup.live_status_ros import diag_values, graph_probe
    from nav_core.ros_node import ImuBatchSubscription

    graph = Graph(specs, env, PARAMS_FILE)
    sampler = Sampler(graph)
    try:
        with graph_probe(topics) as probe:
            for topic in imu_topics:
                probe.received[topic] = []
                ImuBatchSubscription(probe, topic, lambda b, topic=topic: probe.received[topic].append(
                    (time.monotonic(), b.t_ns)), 0.002)
            graph.start(timeout_s=90)
            sampler.start()
            t0 = time.monotonic()
            probe.spin_until(lambda p: player in graph.dead(), timeout_s)
            t1 = time.monotonic()
            probe.spin_until(lambda p: False, 3.0)
    finally:
        sampler.stop.set()
        codes = graph.stop()
    return probe.received, diag_values(probe), sampler, (t0, t1), codes


def bench_load(env, quick: bool) -> None:
    """1,000 IMU frames per second through the live graph."""
    from imu_sim.simulate import simulate, write_outputs
    from nav_bringup.graph import NodeSpec
    from nav_core import sensor_model

    from imu_sim.trajectory import paper_drive_segments

    rate = 1000.0 / 64.0
    scen = yaml.safe_load((REPO / "config" / "scenarios" / "paper_drive.yaml").read_text())
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if quick:
            scen["duration_s"] = 120.0
        else:  # the paper's 3-minute leg driven 26 times: 4,725 s of drive, 5 minutes of wall time at 15.6x
            segments = paper_drive_segments()
            scen["segments"] = segments[:1] + segments[1:12] * 26
            scen.pop("trajectory")
        (tmp / "s.yaml").write_text(yaml.safe_dump(scen))
        write_outputs(simulate(tmp / "s.yaml", model=sensor_model.load(MODEL), seed=5), tmp / "sim", fmt="csv")
        sim, link = {"use_sim_time": True}, tmp / "port"
        m = {"sensor_model_path": str(MODEL)}
        specs = [NodeSpec("bp3010_driver", dict(sim, port=str(link), reconnect_period_s=0.1)),
                 NodeSpec("wmra_node", dict(sim, **m)),
                 NodeSpec("ins_gps_kf_node", dict(sim, **m, datum_lat_deg=scen["latitude_deg"],
                                                  datum_lon_deg=scen["longitude_deg"], datum_h_m=scen["height_m"])),
                 NodeSpec("scenario_player", {"sim_dir": str(tmp / "sim"), "link": str(link), "rate": rate})]
        seen, diags, sampler, (t0, t1), codes = run_graph(
            specs, env, "scenario_player", 1200, {}, imu_topics=("imu/data_raw", "imu/data_corrected"))
    frames = int(diags.get("scenario_player", {}).get("frames_sent", 0))
    drv, wm, kf = (diags.get(n, {}) for n in ("bp3010_driver", "wmra_node", "ins_gps_kf_node"))
    print(f"load: {frames} frames at 1,000 Hz over {t1 - t0:.0f} s of wall time (a {frames / 64:.0f} s "
          f"drive at 15.6x; target 5 minutes)")
    print(f"  driver published {drv.get('frames_received')} (checksum errors {drv.get('checksum_errors')}, lost "
          f"{drv.get('lost_frames')}); wmra received {wm.get('received')}, published {wm.get('published')}, "
          f"restarts {wm.get('restarts')}; filter epochs {kf.get('epochs')}; target: nothing dropped")
    raw = {int(ns): t for t, stamps in seen["imu/data_raw"] for ns in stamps}
    lat = [t - raw[ns] for t, stamps in seen["imu/data_corrected"] for ns in stamps.tolist() if ns in raw]
    if len(raw) >= 0.95 * int(drv.get("frames_received", 0) or 1) and lat:
        print(f"  raw -> denoised latency (wall): p50 {np.percentile(lat, 50) * 1e3:.0f} ms, "
              f"p99 {np.percentile(lat, 99) * 1e3:.0f} ms (includes the WMRA window delay of "
              f"{wm.get('delay_s')} s of sensor time = {float(wm.get('delay_s', 0)) / rate * 1e3:.0f} ms at 15.6x)")
    else:
        print(f"  raw -> denoised latency: not measured (the probe itself received only {len(raw)} raw messages)")
    sampler.report(["scenario_player", "bp3010_driver", "wmra_node", "ins_gps_kf_node"], t0, t1)
    print(f"  exit codes {codes}")


def bench_soak(env, quick: bool) -> None:
    """A 1-hour recording replayed at 10x: memory flat, no dropped fix, output equal to the offline run."""
    from imu_sim.simulate import BAG_EPOCH_S, simulate
    from nav_bringup.graph import NodeSpec
    from nav_core import recording, sensor_model
    from nav_core.recording import GnssRecording, ImuRecording

    scen = {"name": "kfgins_track", "gnss_track": str(KFGINS.resolve()), "rate_hz": 64,
            "gps": {"rate_hz": 1, "sigma_m": [1.0, 1.0, 2.0]},
            "physics": {"earth_rotation": {}, "coriolis": {}, "gravity_model": {}}}
    if quick:  # a smoke run: the graph starts, plays, stops and is compared with the offline run
        scen["duration_s"] = 120.0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "s.yaml").write_text(yaml.safe_dump(scen))
        res = simulate(tmp / "s.yaml", model=sensor_model.load(MODEL), seed=9, with_bytes=False)
        imu = ImuRecording(res.imu.t + BAG_EPOCH_S, res.imu.gyro, res.imu.accel)
        gnss = GnssRecording(res.gnss.t + BAG_EPOCH_S, res.gnss.lat, res.gnss.lon, res.gnss.h, res.gnss.std_enu,
                             res.gnss.status)
        recording.write_bag(tmp / "rec", imu, gnss, storage="mcap")
        sim, m = {"use_sim_time": True}, {"sensor_model_path": str(MODEL)}
        specs = [NodeSpec("wmra_node", dict(sim, **m)), NodeSpec("ins_gps_kf_node", dict(sim, **m)),
                 # only the output: the comparison replays the played recording offline
                 NodeSpec("bag_record", dict(sim, output=str(tmp / "out"), topics=["odometry/filtered"])),
                 # the recorder subscribes to the nodes' outputs once it discovers them: give it time before playing
                 NodeSpec("bag_play", {"bag": str(tmp / "rec"), "rate": 10.0, "start_delay_s": 3.0})]
        _, diags, sampler, (t0, t1), codes = run_graph(specs, env, "bag_play", 3600, {})
        kf, wm = diags.get("ins_gps_kf_node", {}), diags.get("wmra_node", {})
        print(f"soak: {len(imu) / 64 / 60:.0f} min recording at 10x in {t1 - t0:.0f} s; GPS fixes played "
              f"{len(gnss)}, used by the filter {kf.get('fixes')} (rejected {kf.get('rejected_fixes')}, late "
              f"{kf.get('late_dropped')}); IMU samples played {len(imu)}, received by wmra "
              f"{wm.get('received')} (filled {wm.get('filled_samples')}, restarts {wm.get('restarts')}), "
              f"published {wm.get('published')}, reached the filter {kf.get('imu_received')}")
        sampler.report(["bag_play", "wmra_node", "ins_gps_kf_node", "bag_record"], t0, t1)
        _compare_offline(tmp)
        print(f"  exit codes {codes}")


def _compare_offline(tmp: Path) -> None:
    """The node's odometry against the offline pipeline on the played recording: batch WMRA, `ins-gps-kf replay`.

    The streaming WMRA equals the batch one sample for sample and the node equals the replay for the
    same input (both tested), so any difference means a message was lost or reordered on the way.
    """
    import subprocess
    import sys

    from nav_bringup.graph import PARAMS_FILE
    from nav_core import recording, sensor_model
    from wmra_filter import wmra_node
    from wmra_filter.wmra import denoise_imu

    model = sensor_model.load(MODEL)
    values = {p.name: p.default for p in wmra_node.PARAMS}
    values.update(yaml.safe_load(PARAMS_FILE.read_text())["wmra_node"]["ros__parameters"])
    imu, gnss = recording.read_imu(tmp / "rec"), recording.read_gnss(tmp / "rec")
    den = denoise_imu(imu.gyro, imu.accel, model, wmra_node.config_from_params(values, model))
    recording.write_bag(tmp / "denoised", recording.ImuRecording(imu.t, den.gyro, den.accel), gnss, storage="mcap")
    traj_csv = tmp / "offline.csv"
    cmd = [str(Path(sys.executable).parent / "ins-gps-kf"), "replay", "--recording", str(tmp / "denoised"),
           "--model", str(MODEL), "--params", str(PARAMS_FILE), "--param", f"sensor_model_path={MODEL}",
           "--imu-topic", "imu/data_raw", "--out", str(traj_csv), "--quiet", "--no-plot"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode:
        print(f"  offline replay failed: {run.stderr[-500:]}")
        return
    odom, off = recording.read_odometry(tmp / "out"), recording.read_trajectory_csv(traj_csv)
    common, i_node, i_off = np.intersect1d(np.round(odom.t, 3), np.round(off.t, 3), return_indices=True)
    off_enu = np.column_stack([off.extra[k] for k in ("e_m", "n_m", "u_m")])
    gap = np.max(np.abs(odom.position[i_node] - off_enu[i_off])) if len(common) else np.nan
    print(f"  node odometry (as recorded) {len(odom)} epochs, offline batch WMRA + replay {len(off)} epochs, "
          f"common stamps {len(common)}, largest position difference there {gap:.3g} m")


def busy_loops(n: int = 2, niceness: int = 10) -> list:
    """Start ``n`` busy-loop processes at ``niceness`` (the caller kills them)."""
    import subprocess
    import sys

    return [subprocess.Popen(["nice", "-n", str(niceness), sys.executable, "-c", "while True: pass"])
            for _ in range(n)]


def children_cpu(parent: int) -> dict:
    """(pid, node name) -> CPU seconds of each child process of ``parent`` (a console script: its script's name)."""
    out = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) != parent:
                continue
            argv = (stat.parent / "cmdline").read_bytes().split(b"\0")
        except (OSError, IndexError, ValueError):
            continue
        name = Path((argv[1] if len(argv) > 1 and b"python" in argv[0] else argv[0]).decode()).name
        if name:  # an exited child (zombie) has no command line
            out[int(stat.parent.name), name] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return out


def run_demo(out: Path, rate: float, duration_s: float, env: dict, busy: bool) -> dict:
    """One `nav-demo` run (optionally with two nice-10 busy loops throughout); its summary.json, wall time, CPU."""
    import json
    import subprocess
    import sys

    loops = busy_loops() if busy else []
    start, load = time.monotonic(), os.getloadavg()[0]
    cpu = {}  # (pid, node) -> (first sample time, CPU s), (last sample time, CPU s)
    try:
        cmd = [str(Path(sys.executable).parent / "nav-demo"), "--rate", str(rate), "--out", str(out)]
        if duration_s:
            cmd += ["--duration", str(duration_s)]
        demo = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        reader = threading.Thread(target=lambda: setattr(demo, "output", demo.communicate()), daemon=True)
        reader.start()
        while demo.poll() is None:
            now = time.monotonic()
            for key, seconds in children_cpu(demo.pid).items():
                cpu[key] = (cpu.get(key, ((now, seconds),))[0], (now, seconds))
            time.sleep(1.0)
        reader.join()
    finally:
        for proc in loops:
            proc.kill()
            proc.wait()
    runs = sorted(out.glob("run_*"), key=lambda p: p.stat().st_mtime)
    if not runs or not (runs[-1] / "summary.json").exists():  # a node's exit code is reported, not fatal
        stdout, stderr = getattr(demo, "output", ("", ""))
        raise RuntimeError(f"nav-demo failed (exit {demo.returncode}):\n{stdout[-3000:]}\n{stderr[-2000:]}")
    summary = json.loads((runs[-1] / "summary.json").read_text())
    summary["wall_s"], summary["load_at_start"] = time.monotonic() - start, load
    summary["cpu_share"] = {name: (b[1] - a[1]) / (b[0] - a[0]) for (_, name), (a, b) in cpu.items() if b[0] > a[0]}
    summary["run_dir"] = str(runs[-1])
    return summary


def bench_busy_cpu(env, rates, duration_s: float) -> None:
    """The demo quiet and on a busy CPU at each rate: live = offline replay, no backward stamps, same RMS."""
    out = Path(tempfile.mkdtemp(prefix="bench_busy_"))
    print(f"busy CPU: nav-demo{f' --duration {duration_s:g}' if duration_s else ''} quiet, then with two "
          f"busy loops at nice 10 for the whole run (folders in {out})")
    for rate in rates:
        quiet = run_demo(out / f"rate{rate:g}", rate, duration_s, env, busy=False)
        busy = run_demo(out / f"rate{rate:g}", rate, duration_s, env, busy=True)
        for name, s in (("quiet", quiet), ("busy", busy)):
            off, st = s["offline"], s["stream"]
            print(f"  RATE={rate:g} {name:<5} {s['wall_s']:5.0f} s wall: horizontal RMS "
                  f"{s['rms']['horizontal position (m)']:.3f} m; live - offline replay: largest "
                  f"{off['largest difference (m)']:.2g} m over {off['common epochs']} epochs (only live "
                  f"{off['only live']}, only offline {off['only offline']}); stamps going back: odometry "
                  f"{off['live stamps going back']}, raw {st.get('imu/data_raw stamps going back')}, denoised "
                  f"{st.get('imu/data_corrected stamps going back')}; filter dropped "
                  f"{st.get('messages the filter dropped')}, missing "
                  f"{st.get('IMU samples missing in the filter' + chr(39) + 's input')}"
                  f" (in the bag: raw {st.get('imu/data_raw samples missing')}, denoised "
                  f"{st.get('imu/data_corrected samples missing')}); exit codes other than 0: "
                  f"{ {k: v for k, v in s['exit_codes'].items() if v} or 'none'}")
            stamps = {k.split()[-2]: v for k, v in (s.get("stamps") or {}).items()}
            print(f"           driver stamp - simulated frame time (ms): " + ", ".join(
                f"{k} {v:.1f}" for k, v in stamps.items()) + f"; load average at start {s['load_at_start']:.1f}"
                  "; CPU (share of one core): " + ", ".join(
                f"{k} {v:.0%}" for k, v in sorted(s["cpu_share"].items(), key=lambda kv: -kv[1])))
        q, b = quiet["rms"]["horizontal position (m)"], busy["rms"]["horizontal position (m)"]
        print(f"  RATE={rate:g} busy RMS / quiet RMS = {b / q:.3f} (target within 10 %)")


def main() -> None:
    """Run the benchmarks."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="2 minutes of drive, 2 minutes of soak")
    p.add_argument("--skip-load", action="store_true")
    p.add_argument("--skip-soak", action="store_true")
    p.add_argument("--busy-cpu", action="store_true", help="only the demo quiet and on a busy CPU")
    p.add_argument("--rates", type=float, nargs="+", default=[1.0, 3.0, 8.0], help="--busy-cpu: demo rates")
    p.add_argument("--duration", type=float, default=0.0, help="--busy-cpu: simulated seconds (0: the whole drive)")
    args = p.parse_args()
    env = dict(os.environ, ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", str(random.randint(200, 230))),
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    if args.busy_cpu:
        bench_busy_cpu(env, args.rates, args.duration)
        return
    if not args.skip_load:
        bench_load(env, args.quick)
    if not args.skip_soak:
        bench_soak(env, args.quick)


if __name__ == "__main__":
    main()
