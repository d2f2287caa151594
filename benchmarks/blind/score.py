"""Score the pinned ``imu-sim diagnose`` on blind cases (issue 24): named first, clean nulls, coverage.

    nice -n 10 .venv/bin/python benchmarks/blind/score.py --seeds 0-1 [--cases all|fixture/null,...]
        [--rev HEAD] [--work /tmp/blind] [--workers 2] [--report out.md]

Freezes ``src/imu_sim`` at ``--rev`` (``git archive``) and runs ``.venv/bin/imu-sim diagnose`` with that
snapshot first on PYTHONPATH, so edits in the shared tree during a run do not mix into the score.
Cases, outputs and per-case rows stay in ``--work`` (not in the repository: tuners must not read them);
only the summary (rates and classes of miss) is printed and written to ``--report``.
A scenario key the CLI refuses (``attitude_tolerance_deg`` at the time of writing) is dropped and the
case run again; the refusal is counted as an input finding.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
from blindgen import cases, io  # noqa: E402

AXES = "xyz"


def parse_seeds(text: str):
    """'0-4' or '0,3,7' -> list of ints."""
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out.extend(range(int(a), int(b) + 1) if b else [int(a)])
    return out


def freeze(rev: str, work: Path) -> tuple[Path, str]:
    """Export src/imu_sim at ``rev`` into ``work``; returns (package root, commit hash)."""
    sha = subprocess.check_output(["git", "-C", str(ROOT), "rev-parse", rev], text=True).strip()
    dest = work / f"frozen_{sha[:10]}"
    if not dest.exists():
        tmp = work / f"frozen_tmp_{os.getpid()}"
        tmp.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", sha, "src/imu_sim"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
        tmp.rename(dest)
    return dest / "src" / "imu_sim", sha


def run_diagnose(folder: Path, pkg_root: Path, timeout_s: float, drop=()):
    """Run the CLI on a case folder; returns (exit code, stderr tail, seconds)."""
    scen = folder / "scenario.yaml"
    if drop:
        data = yaml.safe_load(scen.read_text())
        for key in drop:
            data.pop(key, None)
        scen = folder / "scenario_cli.yaml"
        scen.write_text(yaml.safe_dump(data, sort_keys=False, width=120))
    cmd = ["nice", "-n", "10", str(ROOT / ".venv" / "bin" / "imu-sim"), "diagnose", "--force",
           "--recording", str(folder / "imu.csv"), "--scenario", str(scen), "--model", str(folder / "model.yaml"),
           "--out", str(folder / "out")]
    if (folder / "gnss.csv").exists():
        cmd += ["--gnss", str(folder / "gnss.csv")]
    # One BLAS thread per diagnosis: two cases run side by side on two cores, and threaded BLAS under load made a
    # long-table case ~10x slower (60 min against 2-8 min).
    env = dict(os.environ, PYTHONPATH=str(pkg_root), MPLBACKEND="Agg",
               OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    t0 = time.monotonic()
    try:
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return -9, "timeout", time.monotonic() - t0
    return proc.returncode, proc.stderr.strip()[-400:], time.monotonic() - t0


def expand(params: dict) -> dict:
    """Answer parameters as flat keys: vectors key[x], 3x3 key[xy] (off-diagonal), scalars key."""
    out = {}
    for key, val in params.items():
        if isinstance(val, list) and val and isinstance(val[0], list):
            for i in range(3):
                for j in range(3):
                    if i != j:
                        out[f"{key}[{AXES[i]}{AXES[j]}]"] = val[i][j]
        elif isinstance(val, list):
            for i, v in enumerate(val):
                out[f"{key}[{AXES[i]}]"] = v
        else:
            out[key] = val
    return out


def coverage(answer: dict, finding: dict):
    """(covered, scored) over the concealed effect's true parameters the finding reports intervals for."""
    truth = expand(answer["params"])
    if answer["effect"] == "vibration":  # amplitude signs depend on the phase convention: frequency only
        truth = {k: v for k, v in truth.items() if k == "frequency_hz"}
    intervals = finding.get("intervals") or {}
    covered = scored = 0
    for key, (lo, hi) in ((k, v) for k, v in intervals.items() if isinstance(v, list) and len(v) == 2):
        base = re.sub(r"\[[a-z]+\]$", "", key)
        value = truth.get(key, truth.get(base))
        if value is None and key.startswith(("gyro[", "accel[")) and answer["effect"] not in (
                "scale_factor", "axis_misalignment"):
            continue
        if value is None and len(truth) == 1 and len(intervals) == 1:  # one scalar each (Earth rate, gravity)
            value = next(iter(truth.values()))
        if value is None:
            continue
        if answer["effect"] in ("scale_factor", "axis_misalignment") and not key.startswith("gyro"):
            value = 0.0 if key.startswith("accel") else value
        scored += 1
        covered += int(lo <= value <= hi)
    return covered, scored


def score_case(name: str, seed: int, work: Path, pkg_root: str, timeout_s: float, perfect: bool = False) -> dict:
    """Generate (if needed) and diagnose one case; the row of its outcome."""
    folder = work / "cases" / f"{name.replace('/', '__')}__s{seed}"
    row_path = folder / "row.json"
    if row_path.exists():
        return json.loads(row_path.read_text())
    if not (folder / "answer.json").exists():
        io.write_case(cases.build_case(name, seed, perfect_reference=perfect), folder)
    answer = json.loads((folder / "answer.json").read_text())
    input_notes = []
    code, err, secs = run_diagnose(folder, Path(pkg_root), timeout_s)
    refused = re.search(r"unknown key\(s\) \[([^\]]*)\]", err or "")
    if code == 2 and refused:
        keys = [k.strip(" '\"") for k in refused.group(1).split(",")]
        input_notes.append(f"scenario key refused: {', '.join(keys)}")
        code, err, secs2 = run_diagnose(folder, Path(pkg_root), timeout_s, drop=keys)
        secs += secs2
    row = {"case": name, "seed": seed, "effect": answer["effect"], "grade": answer["grade"],
           "class": answer["class"], "exit": code, "seconds": round(secs, 1), "input_notes": input_notes}
    if code != 0:
        row["error"] = err
    else:
        diag = json.loads((folder / "out" / "diagnosis.json").read_text())
        found = [f["effect"] for f in diag.get("findings", [])]
        row["findings"] = found
        row["first"] = found[0] if found else None
        if answer["effect"] in found:
            cov, n = coverage(answer, diag["findings"][found.index(answer["effect"])])
            row["covered"], row["scored"] = cov, n
    row_path.write_text(json.dumps(row, indent=1))
    return row


def miss_class(row: dict) -> str | None:
    """The class of a miss ('<scenario> <effect>: named <x> first'), None for a hit / clean null."""
    if row["exit"] != 0:
        return f"{row['class']}: input refused or failed ({row.get('error', '')[:60]})"
    eff = row["effect"]
    if eff is None:
        if not row["findings"]:
            return None
        return f"{row['class']} null: {row['first']} reported"
    if row["first"] == eff:
        return None
    tail = "" if eff in row["findings"] else ", concealed effect not found"
    return f"{row['class']} {eff}: {row['first'] or 'nothing'} named first{tail}"


def summarise(rows, sha: str) -> str:
    """Markdown summary: per case, overall and classes of miss (no individual cases)."""
    by_case = defaultdict(list)
    for r in rows:
        by_case[r["case"]].append(r)
    last = subprocess.run(["git", "-C", str(ROOT), "log", "-1", "--format=%h %cI", sha, "--", "src/imu_sim"],
                          capture_output=True, text=True).stdout.strip()
    lines = [f"diagnosis frozen at {sha[:10]} (src/imu_sim last changed in {last}); {len(rows)} runs", "",
             "| case | runs | grades | named first / null clean | interval coverage | median s |",
             "|---|---|---|---|---|---|"]
    eff_hit = eff_n = null_ok = null_n = cov = scored = 0
    for name in cases.case_names():
        rs = by_case.get(name)
        if not rs:
            continue
        grades = ",".join(sorted({r["grade"][:3] for r in rs}))
        secs = sorted(r["seconds"] for r in rs)[len(rs) // 2]
        if rs[0]["effect"] is None:
            ok = sum(1 for r in rs if r["exit"] == 0 and not r["findings"])
            null_ok, null_n = null_ok + ok, null_n + len(rs)
            lines.append(f"| {name} | {len(rs)} | {grades} | clean {ok}/{len(rs)} | | {secs:.0f} |")
        else:
            hit = sum(1 for r in rs if r["exit"] == 0 and r["first"] == r["effect"])
            c, n = sum(r.get("covered", 0) for r in rs), sum(r.get("scored", 0) for r in rs)
            eff_hit, eff_n, cov, scored = eff_hit + hit, eff_n + len(rs), cov + c, scored + n
            lines.append(f"| {name} | {len(rs)} | {grades} | first {hit}/{len(rs)} | "
                         f"{c}/{n} | {secs:.0f} |")
    pct = lambda a, b: f"{100.0 * a / b:.0f} %" if b else "-"  # noqa: E731
    lines += ["", f"**Effect cases named first: {eff_hit}/{eff_n} = {pct(eff_hit, eff_n)}; "
                  f"null cases clean: {null_ok}/{null_n} = {pct(null_ok, null_n)}; "
                  f"intervals covering the true parameter: {cov}/{scored} = {pct(cov, scored)}** "
                  "(coverage over the parameters of the concealed effect when it is found).", "",
              "| class of miss | runs |", "|---|---|"]
    misses = Counter(m for m in map(miss_class, rows) if m)
    lines += [f"| {m} | {k} |" for m, k in misses.most_common()]
    instead = Counter(f"{r['first'] or 'nothing'} ({'null' if r['effect'] is None else 'effect case'})"
                      for r in rows if miss_class(r) and r["exit"] == 0)
    lines += ["", "| named first instead (all scenario classes) | runs |", "|---|---|"]
    lines += [f"| {m} | {k} |" for m, k in instead.most_common()]
    notes = Counter(n for r in rows for n in r["input_notes"])
    if notes:
        lines += ["", "Input findings: " + "; ".join(f"{n} ({k} runs)" for n, k in notes.items())]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Generate, run and summarise; rows are kept in --work so a run resumes."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--cases", default="all")
    ap.add_argument("--rev", default="HEAD")
    ap.add_argument("--work", default="/tmp/blind_score")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--timeout-s", type=float, default=1200.0)
    ap.add_argument("--report", default=None)
    ap.add_argument("--summarise-only", action="store_true",
                    help="only summarise the rows already in --work (e.g. of a run stopped at a deadline)")
    ap.add_argument("--perfect-reference", action="store_true",
                    help="control run: fixtures at their nominal attitudes, drive truth without its error")
    args = ap.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    pkg_root, sha = freeze(args.rev, work)
    names = cases.case_names() if args.cases == "all" else args.cases.split(",")
    if args.summarise_only:
        rows = [json.loads(p.read_text()) for p in sorted((work / "cases").glob("*/row.json"))]
        return report([r for r in rows if r["case"] in names], sha, args)
    jobs = [(n, s) for s in parse_seeds(args.seeds) for n in names]
    rows = []
    with ProcessPoolExecutor(args.workers) as pool:
        futs = {pool.submit(score_case, n, s, work, str(pkg_root), args.timeout_s,
                           args.perfect_reference): (n, s) for n, s in jobs}
        for i, fut in enumerate(as_completed(futs), 1):
            row = fut.result()
            rows.append(row)
            print(f"[{i}/{len(jobs)}] {row['case']} s{row['seed']} ({row['grade']}): "
                  f"{'ok' if miss_class(row) is None else 'MISS'} {row['seconds']:.0f} s", flush=True)
    return report(rows, sha, args)


def report(rows, sha: str, args) -> int:
    """Print the summary of ``rows`` and write it to ``args.report`` if given."""
    text = summarise(rows, sha)
    if args.perfect_reference:
        text = "CONTROL (perfect reference: no fixture error, no drive-truth error)\n" + text
    print(text)
    if args.report:
        Path(args.report).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
