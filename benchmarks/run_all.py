"""Run every package benchmark (benchmarks/bench_*.py) and print their figures one after another.

    python benchmarks/run_all.py [--quick]
"""
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    """Run each benchmark in its own process; report any that failed."""
    extra = [a for a in sys.argv[1:] if a == "--quick"]
    failed = []
    for bench in sorted(HERE.glob("bench_*.py")):
        print(f"\n=== {bench.stem} {' '.join(extra)}", flush=True)
        t0 = time.monotonic()
        code = subprocess.call([sys.executable, str(bench), *extra])
        print(f"=== {bench.stem}: exit {code} after {time.monotonic() - t0:.0f} s", flush=True)
        if code:
            failed.append(bench.stem)
    if failed:
        print(f"\nfailed: {', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
