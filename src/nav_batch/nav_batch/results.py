"""``DIR/results.csv`` (one row per recording) and ``DIR/batch.json`` (what the batch ran), read and written whole."""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from nav_core.outputs import OutputError, atomic_write_text

BASE_COLUMNS = ("recording", "status", "message", "wall_s", "cpu_s")
RESULTS = "results.csv"
BATCH = "batch.json"


def write_rows(out_dir: Path, rows: list, columns: tuple) -> Path:
    """Write ``rows`` (dicts; missing figures left empty) to ``out_dir/results.csv`` through a rename."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=BASE_COLUMNS + tuple(columns), extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return atomic_write_text(Path(out_dir) / RESULTS, buf.getvalue())


def read_rows(out_dir: Path) -> dict:
    """recording -> row of an earlier run's results.csv ({} when there is none)."""
    required = BASE_COLUMNS[:4]
    path = Path(out_dir) / RESULTS
    if not path.exists():
        return {}
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or not set(required) <= set(reader.fieldnames):
            raise OutputError(f"{path}: not a nav-batch results file (columns {reader.fieldnames}); "
                              f"expected {', '.join(required)}")
        return {row["recording"]: row for row in reader}


def write_batch(out_dir: Path, tool: str, options: dict) -> Path:
    """Record the tool and its options, so that ``--resume`` continues the same batch and no other."""
    return atomic_write_text(Path(out_dir) / BATCH, json.dumps({"tool": tool, "options": options}, indent=1,
                                                                sort_keys=True) + "\n")


def check_same_batch(out_dir: Path, tool: str, options: dict) -> None:
    """OutputError unless ``out_dir`` holds a batch of ``tool`` with the same ``options`` (or no batch yet)."""
    path = Path(out_dir) / BATCH
    if not path.exists():
        if any(Path(out_dir).iterdir()):
            raise OutputError(f"{out_dir}: --resume needs a nav-batch folder ({BATCH} missing); choose a new --out")
        return
    done = json.loads(path.read_text())
    now = json.loads(json.dumps({"tool": tool, "options": options}))  # the JSON form: tuples become lists
    if done != now:
        raise OutputError(f"{out_dir}: holds a batch of {done['tool']} with options {done['options']}; --resume "
                          f"continues only that batch (this one: {tool} {options})")
