"""``bp3010_emulator``: stream BP3010 frames to a pseudo-terminal (or a real port), with fault injection."""
import argparse
import os
import sys
import tempfile
from pathlib import Path

from imu_driver.emulator import SCENARIOS, Emulator, FaultPlan, PtyPort, SerialPort, counts_from_source
from nav_core.cli import about, number
from nav_core.cli import parse_args as cli_parse_args


def parse_args(argv=None):
    """Command-line options."""
    p = argparse.ArgumentParser(prog="bp3010_emulator", **about(
        "Stream BP3010 frames to a pseudo-terminal (or a real port), with fault injection.",
        "bp3010_emulator --source rotating --link /tmp/bp3010 --garbage-every 20"))
    p.add_argument("--source", default="still",
                   help=f"built-in scenario {SCENARIOS}, a BP3010 .bin stream, or a recording (CSV/bag) at 64 Hz")
    p.add_argument("--seconds", type=number(0.0, 1e6, low_open=True), default=60.0,
                   help="length of a built-in scenario, s")
    p.add_argument("--seed", type=int, default=0, help="seed of the built-in scenario's noise and of the faults")
    p.add_argument("--link", default=None, help="symlink to create for the pty slave (default: a temp path)")
    p.add_argument("--port", default=None, help="write to this real serial port instead of a pty")
    p.add_argument("--baud", type=int, default=38400)
    p.add_argument("--speed", type=number(0.0, 1e4, low_open=True), default=1.0, help="real-time multiplier (2 = twice as fast)")
    p.add_argument("--loop", action="store_true", help="repeat the source forever")
    p.add_argument("--max-frames", type=int, default=None)
    p.add_argument("--flip-probability", type=number(0.0, 1.0), default=0.0, help="chance per frame of one flipped byte")
    p.add_argument("--drop-probability", type=number(0.0, 1.0), default=0.0, help="chance per frame of one dropped byte")
    p.add_argument("--garbage-every", type=number(0.0, None), default=0.0, help="insert a garbage burst every this many s")
    p.add_argument("--garbage-bytes", type=int, default=40)
    p.add_argument("--disconnect-at", type=float, action="append", default=[],
                   help="unplug at this time (s of stream); repeatable")
    p.add_argument("--disconnect-for", type=number(0.0, None), default=5.0, help="how long each unplug lasts, s")
    return cli_parse_args(p, argv)


def main(argv=None) -> int:
    """Run the emulator until the source ends or Ctrl-C."""
    args = parse_args(argv)
    try:
        counts = counts_from_source(args.source, args.seconds, args.seed)
    except (ValueError, OSError) as err:
        print(f"bp3010_emulator: error: {err}", file=sys.stderr)
        return 2
    if args.port:
        port = SerialPort(args.port, args.baud)
    else:
        link = Path(args.link or Path(tempfile.gettempdir()) / f"bp3010-{os.getpid()}")
        port = PtyPort(link)
    faults = FaultPlan(args.flip_probability, args.drop_probability, args.garbage_every, args.garbage_bytes,
                       tuple(args.disconnect_at), args.disconnect_for, args.seed)
    print(f"PORT {port.link}", flush=True)
    emu = Emulator(port, counts, faults=faults, speed=args.speed, loop=args.loop,
                   log=lambda s: print(s, flush=True))
    try:
        stats = emu.run(args.max_frames)
    except KeyboardInterrupt:
        stats = emu.stats
    finally:
        port.unplug()
    print(f"DONE {stats}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
