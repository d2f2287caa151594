"""``nav-demo``: the main job on the built-in default scenario, no hardware needed.

Simulates the paper's drive (imu_sim), streams its BP3010 bytes from the
emulator through a real pseudo-terminal into ``bp3010_driver`` (a separate
process on DDS) and prints what the driver publishes, once a second.
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[3]
DEFAULT_SCENARIO = REPO / "config" / "scenarios" / "paper_drive.yaml"
DEFAULT_OUT = REPO / "out" / "demo"


def parse_args(argv=None):
    """Command-line options."""
    p = argparse.ArgumentParser(prog="nav-demo", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", type=Path, default=DEFAULT_SCENARIO, help="simulator scenario YAML")
    p.add_argument("--seconds", type=float, default=30.0, help="how much of the drive to stream, s of drive time")
    p.add_argument("--rate", type=float, default=1.0, help="speed: 2 streams twice as fast as real time")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="where the simulation and logs go")
    return p.parse_args(argv)


def simulate_once(scenario: Path, seed: int, out: Path) -> Path:
    """Simulate the scenario (cached by seed) and return its BP3010 byte stream."""
    from imu_sim.simulate import simulate, write_outputs

    sim_dir = out / f"sim_seed{seed}"
    stream = sim_dir / "bp3010.bin"
    if stream.exists() and stream.stat().st_mtime > scenario.stat().st_mtime:
        print(f"[demo] using the simulation in {sim_dir}")
        return stream
    print(f"[demo] simulating {scenario.name} (seed {seed}) into {sim_dir} ...")
    write_outputs(simulate(scenario, seed=seed), sim_dir, fmt="all")
    return stream


def main(argv=None) -> int:
    """Run the emulator -> pty -> driver chain and print a live summary."""
    args = parse_args(argv)
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 99)))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    args.out.mkdir(parents=True, exist_ok=True)
    stream = simulate_once(args.scenario, args.seed, args.out)

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import Imu

    from nav_core.processes import NodeProcess
    from nav_core.ros_node import Probe

    link = args.out / "bp3010_port"
    frames = int(args.seconds * 64)
    drv = NodeProcess("bp3010_driver", params_file=REPO / "config" / "bp3010_driver.yaml",
                      ros_args={"port": str(link), "reconnect_period_s": 0.2})
    rclpy.init()
    probe = Probe({"imu/data_raw": Imu})
    diags = []
    probe.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    # The driver waits for its port; start streaming once the probe sees the driver on DDS.
    if not probe.spin_until(lambda p: p.count_publishers("imu/data_raw") > 0, 30):
        print(drv.output, file=sys.stderr)
        return 1
    emu = NodeProcess("bp3010_emulator", ["--source", stream, "--link", link, "--speed", args.rate,
                                          "--max-frames", frames])
    print(f"[demo] emulator on {link} -> bp3010_driver -> imu/data_raw (ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']})")
    print(f"{'time':>6} {'msgs':>6} {'rate':>6} {'gyro z':>10} {'accel x':>9} {'accel z':>9}  driver diagnostics")
    print(f"{'s':>6} {'':>6} {'Hz':>6} {'deg/s':>10} {'m/s^2':>9} {'m/s^2':>9}")
    status = 0
    try:
        status = _watch(probe, diags, emu, frames, args.rate)
    except KeyboardInterrupt:
        pass
    finally:
        probe.destroy_node()
        rclpy.try_shutdown()
        drv_code, _ = drv.stop(), emu.stop()
    print(f"[demo] driver exited with {drv_code}; logs in {args.out}")
    (args.out / "driver.log").write_text(drv.output)
    (args.out / "emulator.log").write_text(emu.output)
    return status or drv_code


def _watch(probe, diags, emu, frames: int, rate: float) -> int:
    start = time.monotonic()
    last_n = 0
    deadline = start + frames / 64 / rate + 20
    while time.monotonic() < deadline:
        tick = time.monotonic()
        probe.spin_until(lambda p: False, 1.0)
        msgs = probe.received["imu/data_raw"]
        n = len(msgs)
        if n:
            m = msgs[-1][1]
            window = [x[1] for x in msgs[last_n:]] or [m]
            gz = np.degrees(np.mean([w.angular_velocity.z for w in window]))
            ax = np.mean([w.linear_acceleration.x for w in window])
            az = np.mean([w.linear_acceleration.z for w in window])
            d = _driver_diag(diags)
            rate_hz = (n - last_n) / (time.monotonic() - tick)
            print(f"{time.monotonic() - start:6.1f} {n:6d} {rate_hz:6.1f} {gz:10.3f} {ax:9.3f} {az:9.3f}  {d}",
                  flush=True)
        finished = n >= frames or (emu.proc.poll() is not None and n == last_n)
        last_n = n
        if finished:
            break
    received = len(probe.received["imu/data_raw"])
    print(f"[demo] received {received} of {frames} frames as sensor_msgs/Imu on imu/data_raw")
    return 0 if received >= 0.95 * frames else 1


def _driver_diag(diags) -> str:
    for arr in reversed(diags):
        for st in arr.status:
            if "bp3010_driver" in st.name:
                v = {kv.key: kv.value for kv in st.values}
                return (f"{st.message}; frames {v['frames_received']}, checksum errors {v['checksum_errors']}, "
                        f"lost {v['lost_frames']}, port {v['port_state']}")
    return "(waiting)"


if __name__ == "__main__":
    sys.exit(main())
