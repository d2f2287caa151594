"""Run one tool over many recordings on a Dask cluster: one task per recording, rows written as they finish.

The output folder follows :mod:`nav_core.outputs`: a new or empty ``--out``; ``--force`` replaces an existing
one (the old folder is removed only once the new batch has a row for every input, and is put back if the batch
stops before); ``--resume`` keeps the rows already ok and runs the rest. Each recording's folder is written by its
tool through a staged rename, so a task killed half-way (its worker died) leaves no half-written folder: Dask
runs it again on another worker and the rename of the run that completes puts the folder in place.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from nav_core.outputs import OutputError, check_out_dir

from nav_batch import results
from nav_batch.tools import TOOLS, run_one

BAG_SUFFIXES = (".csv", ".mcap", ".db3", ".npz", ".txt", ".yaml")


def stem(recording: str) -> str:
    """The folder name of a recording's outputs: the file name without its suffix (a bag folder: its name)."""
    path = Path(recording)
    return path.stem if path.suffix.lower() in BAG_SUFFIXES else path.name


def plan(recordings: list, out_dir: Path) -> dict:
    """recording -> its output folder; OutputError when two recordings would share one (same stem)."""
    seen = {}
    for rec in recordings:
        name = stem(rec)
        if name in (results.RESULTS, results.BATCH) or name.startswith("."):
            raise OutputError(f"{rec}: its outputs would go to {out_dir / name}, a name nav-batch uses itself; "
                              "rename the recording")
        if name in seen and seen[name] != rec:
            raise OutputError(f"{seen[name]} and {rec} both write {out_dir / name}: give recordings distinct "
                              "names (the folder is the file name without its suffix)")
        seen[name] = rec
    return {rec: out_dir / name for name, rec in seen.items()}


def carried_over(out_dir: Path, folders: dict, tool: str, options: dict) -> dict:
    """--resume: rows of the earlier run that are ok and whose folder is still there."""
    results.check_same_batch(out_dir, tool, options)
    old = results.read_rows(out_dir)
    return {rec: old[rec] for rec in folders if rec in old and old[rec]["status"] == "ok" and folders[rec].is_dir()}


@contextmanager
def replacing(out_dir: Path, force: bool, inputs):
    """``--force``: move an existing ``out_dir`` aside, remove it once the block ends normally, else put it back."""
    if not (force and out_dir.exists()):
        yield
        return
    check_out_dir(out_dir, force=True, inputs=inputs)
    aside = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
    os.rename(out_dir, aside / out_dir.name)
    try:
        yield
    except BaseException:
        shutil.rmtree(out_dir, ignore_errors=True)
        os.rename(aside / out_dir.name, out_dir)
        aside.rmdir()
        raise
    shutil.rmtree(aside, ignore_errors=True)


def remove_partials(out_dir: Path) -> None:
    """Remove the staging folders of tasks whose worker died half-way (their rerun wrote the real folder)."""
    for path in out_dir.glob(".*.partial-*"):
        shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)


def failed_row(recording: str, tool: str, err: BaseException) -> dict:
    """The row of a task that Dask could not finish (its workers kept dying, or the worker lacked a package)."""
    from distributed.scheduler import KilledWorker
    if isinstance(err, KilledWorker):
        why = "the worker running it died each time it was tried (crash or out of memory)"
    else:
        why = f"{type(err).__name__}: {err}"
    return {"recording": recording, "status": "error", "wall_s": "", "cpu_s": "",
            "message": f"{recording}: {TOOLS[tool].command} did not finish: {why}"}


def run_batch(client, tool: str, folders: dict, options: dict, out_dir: Path, done: dict, progress=None) -> list:
    """Submit one task per recording not in ``done``, write results.csv after each one; the rows in input order."""
    from distributed import as_completed

    columns = TOOLS[tool].columns
    rows = dict(done)
    todo = [rec for rec in folders if rec not in done]
    token = f"{os.getpid()}-{time.time_ns()}"
    futures = {client.submit(run_one, tool, rec, str(folders[rec]), options, key=f"nav-batch-{tool}-{i}-{token}",
                             pure=False): rec for i, rec in enumerate(todo)}
    for future in as_completed(futures):
        rec = futures[future]
        try:
            rows[rec] = future.result()
        except Exception as err:  # noqa: BLE001 - the task itself never raises: this is the cluster's failure
            rows[rec] = failed_row(rec, tool, err)
        ordered = [rows[r] for r in folders if r in rows]
        results.write_rows(out_dir, ordered, columns)
        if progress is not None:
            progress(rows[rec])
    remove_partials(out_dir)
    return [rows[r] for r in folders]
