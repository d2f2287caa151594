"""Write blind diagnosis cases into folders (imu.csv, scenario.yaml, model.yaml[, truth.csv, gnss.csv], answer.json).

    .venv/bin/python benchmarks/blind/generate.py --out /tmp/blind_cases [--seeds 0-2] [--cases fixture/null,...]
    .venv/bin/python benchmarks/blind/generate.py --list

answer.json holds the concealed effect and its true parameters: for scoring only. People tuning the
diagnosis must not read the cases (see README.md).
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blindgen import cases, io  # noqa: E402
from score import parse_seeds  # noqa: E402


def main(argv=None) -> int:
    """Generate the requested cases; one line per case written."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--cases", default="all")
    ap.add_argument("--list", action="store_true", help="list the case names and exit")
    args = ap.parse_args(argv)
    if args.list:
        print("\n".join(cases.case_names()))
        return 0
    if not args.out:
        ap.error("--out is required")
    names = cases.case_names() if args.cases == "all" else args.cases.split(",")
    for seed in parse_seeds(args.seeds):
        for name in names:
            folder = io.write_case(cases.build_case(name, seed),
                                   Path(args.out) / f"{name.replace('/', '__')}__s{seed}")
            print(folder, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
