"""The live graph on a busy CPU gives the offline answer (issue 15), in CI's time budget.

The demo's graph (scenario_player -> bp3010_driver -> wmra_node -> ins_gps_kf_node, allan_node,
bag_record) on the first 100 s of the paper drive at 3x, with two busy-loop processes at nice 10
for the whole run. The live odometry must equal the offline replay of the run's own bag at every
epoch (5 cm), no stamp may go back, the filter may drop nothing, the driver's stamps must sit on
the simulated frames' times (median within 3 ms), and its horizontal RMS must be within 10 % of
the quiet offline pipeline on the simulated data (batch WMRA + replay, no graph).
The full-drive figures at RATE=1, 3 and 8 come from ``benchmarks/bench_graph.py --busy-cpu``.
"""
import json
import subprocess
import sys

import numpy as np
import pytest
import yaml
from nav_msgs.msg import Odometry

from nav_bringup import demo
from nav_bringup.graph import REPO, Graph
from nav_bringup.live_status_ros import graph_probe
from nav_bringup.report import write_report
from nav_bringup.truth import TruthTrack
from nav_core import recording, sensor_model

pytestmark = [pytest.mark.ros, pytest.mark.slow]
SIM_SECONDS = 100.0
RATE = 3.0


def _offline_rms(sim_dir, params: dict) -> float:
    """Horizontal RMS of the quiet offline pipeline on the simulated data: batch WMRA, then the filter."""
    from ins_gps_kf import config as kfconfig
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.replay import run
    from wmra_filter import wmra_node
    from wmra_filter.wmra import denoise_imu

    truth = TruthTrack.from_sim_dir(sim_dir)
    model = sensor_model.load(demo.DEFAULT_MODEL)
    values = {p.name: p.default for p in wmra_node.PARAMS}
    values.update(yaml.safe_load(demo.PARAMS_FILE.read_text())["wmra_node"]["ros__parameters"])
    imu, gnss = recording.read_imu(sim_dir / "imu.csv"), recording.read_gnss(sim_dir / "gnss.csv")
    den = denoise_imu(imu.gyro, imu.accel, model, wmra_node.config_from_params(values, model))
    epoch = truth.epoch_s
    filt = InsGpsFilter(kfconfig.from_params({k: v for k, v in params.items() if k in kfconfig.SPEC_BY_NAME}),
                        model)
    estimates = run(filt, recording.ImuRecording(imu.t + epoch, den.gyro, den.accel),
                    recording.GnssRecording(gnss.t + epoch, gnss.lat, gnss.lon, gnss.h, gnss.std_enu, gnss.status))
    t = np.array([e.t for e in estimates])
    pos = np.array([e.position_n for e in estimates])
    return float(np.sqrt(np.mean(np.sum((pos - truth.at(t))[:, :2] ** 2, axis=1))))


def test_on_a_busy_cpu_the_live_graph_gives_the_offline_answer(tmp_path, ros_env):
    sim_dir = tmp_path / "sim"
    demo.simulate_scenario(demo.DEFAULT_SCENARIO, demo.DEFAULT_MODEL, 7, sim_dir, duration_s=SIM_SECONDS + 2,
                           fmt="csv")
    run_dir = tmp_path / "run"
    args = demo.parse_args(["--rate", str(RATE), "--duration", str(SIM_SECONDS), "--out", str(tmp_path)])
    specs = demo.graph_specs(args, run_dir, sim_dir)
    graph = Graph(specs, ros_env, args.params, log_dir=run_dir / "logs")
    loops = [subprocess.Popen(["nice", "-n", "10", sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        with graph_probe({"odometry/filtered": Odometry}) as probe:
            graph.start(timeout_s=90)
            finished = probe.spin_until(lambda p: "scenario_player" in graph.dead(), SIM_SECONDS / RATE + 90)
            assert finished, {k: v.output[-2000:] for k, v in graph.procs.items()}
            probe.spin_until(lambda p: False, 2.0)
    finally:
        codes = graph.stop()
        for proc in loops:
            proc.kill()
            proc.wait()
    assert all(code == 0 for code in codes.values()), codes
    params = demo.filter_params(args.params, specs)
    write_report(run_dir, sim_dir=sim_dir, exit_codes=codes, filter_params=params)
    summary = json.loads((run_dir / "summary.json").read_text())
    off, stream = summary["offline"], summary["stream"]

    assert off["common epochs"] > 80
    assert off["largest difference (m)"] < 0.05, off
    assert off["only live"] == 0 and off["only offline"] <= 2, off  # the node drops its last second at shutdown
    assert off["live stamps going back"] == 0
    assert stream["imu/data_raw stamps going back"] == 0 and stream["imu/data_corrected stamps going back"] == 0
    assert stream["messages the filter dropped"] == 0
    # stamp gaps the filter saw were in the driver's output already (issue 15's driver item), none were added
    assert stream["IMU samples missing in the filter's input"] <= stream["imu/data_raw samples missing"]
    # the driver's stamps on the frames' simulated times: load does not bend them (1 ms of wall time at 3x;
    # measured 0.2-0.8 ms of simulated time; 10-40 ms while the player's frames ran behind its /clock)
    assert abs(summary["stamps"]["driver stamp - frame time median (ms)"]) < 3.0, summary["stamps"]
    live_rms, quiet_rms = summary["rms"]["horizontal position (m)"], _offline_rms(sim_dir, params)
    # hard again since the player's frames and /clock share one zero: 4 runs at 1.016, 1.017, 1.018 and 0.898 x
    # quiet (the filter's answer flips between two values on sub-ms stamp differences near t = 1 s; 40 replays
    # with the runs' stamp errors moved around: 0.898-1.025 x); 1.18 x once in four while stamps ran 10-40 ms late
    assert live_rms <= 1.1 * quiet_rms, f"busy RMS {live_rms:.3f} m > 1.1 x quiet {quiet_rms:.3f} m"
