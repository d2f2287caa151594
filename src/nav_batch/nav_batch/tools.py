"""The three batch tools: each runs its single-recording command's own ``main`` in-process on one recording.

``nav-batch allan`` calls ``imu_calib.cli.main(["allan", REC, "--out", DIR/<stem>, ...])``, ``diagnose`` calls
``imu_sim.cli.main(["diagnose", ...])`` and ``replay`` calls ``ins_gps_kf.replay.main(["replay", ...])``: the same
parsing, checks, computation and writers as the command a user types, so ``DIR/<stem>/`` holds byte for byte what
that command writes (the sensor models' ``created_utc`` too when ``SOURCE_DATE_EPOCH`` is set). Their one-line
error is the batch row's message. Each tool also reads its key figures back from the files it wrote.
"""
from __future__ import annotations

import contextlib
import io
import json
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

# One recording at a time per worker process: the tools plot with matplotlib's pyplot (not thread-safe) and
# print to the process's stdout, which the task captures.
_ONE_AT_A_TIME = threading.Lock()
AXES = "xyz"


@dataclass(frozen=True)
class Tool:
    """How to run one single-recording command on one input and what to read back."""
    name: str
    command: str                                    # the command a user types, for messages and docs
    argv: Callable[[str, Path, dict], list]         # (recording, out folder, options) -> argv of its main
    figures: Callable[[Path, str], dict]            # (out folder, captured stdout) -> key figures
    columns: tuple                                  # names of the key-figure columns of results.csv


def _allan_argv(rec: str, out: Path, opt: dict) -> list:
    argv = ["allan", rec, "--out", str(out), "--force", "--no-progress"]
    for flag in ("topic", "format", "per_decade", "base_model"):
        if opt.get(flag) is not None:
            argv += ["--" + flag.replace("_", "-"), str(opt[flag])]
    return argv + (["--split-at-gaps"] if opt.get("split_at_gaps") else [])


def _allan_figures(out: Path, stdout: str) -> dict:
    from nav_core import sensor_model
    model = sensor_model.load(out / "sensor_model.yaml")
    row = {"duration_s": model.provenance.get("duration_s")}
    for triad in ("gyro", "accel"):
        tri = model.triad(triad)
        for term in ("white_noise", "bias_instability"):
            row.update({f"{triad}_{term}_{AXES[i]}": float(v) for i, v in enumerate(getattr(tri, term))})
    return row


ALLAN_COLUMNS = ("duration_s",) + tuple(f"{tr}_{term}_{a}" for tr in ("gyro", "accel")
                                        for term in ("white_noise", "bias_instability") for a in AXES)


def _diagnose_argv(rec: str, out: Path, opt: dict) -> list:
    argv = ["diagnose", "--recording", rec, "--scenario", opt["scenario"], "--model", opt["model"],
            "--out", str(out), "--force"]
    return argv + (["--max-effects", str(opt["max_effects"])] if opt.get("max_effects") is not None else [])


def _diagnose_figures(out: Path, stdout: str) -> dict:
    result = json.loads((out / "diagnosis.json").read_text())
    return {"mismatch": "yes" if result["mismatch"] else "no",
            "findings": ";".join(f["effect"] for f in result["findings"])}


REPLAY_FILE = "trajectory.csv"


def _replay_argv(rec: str, out: Path, opt: dict) -> list:
    argv = ["replay", "--recording", rec, "--model", opt["model"], "--out", str(out / REPLAY_FILE), "--force",
            "--quiet", "--json"]
    for flag in ("params", "imu_topic", "gps_topic"):
        if opt.get(flag) is not None:
            argv += ["--" + flag.replace("_", "-"), str(opt[flag])]
    for pair in opt.get("param") or ():
        argv += ["--param", pair]
    return argv + (["--no-plot"] if opt.get("no_plot") else [])


def _replay_figures(out: Path, stdout: str) -> dict:
    counts = json.loads(stdout[stdout.index("{"):])  # --json: the run's counts are the whole of stdout
    return {k: counts[k] for k in REPLAY_COLUMNS}


REPLAY_COLUMNS = ("epochs", "fixes", "fixes_rejected", "fixes_invalid", "zupts", "resets")


def _main_of(tool: str):
    """The console-script main of the tool's single-recording command (imported on the worker)."""
    if tool == "allan":
        from imu_calib.cli import main
    elif tool == "diagnose":
        from imu_sim.cli import main
    else:
        from ins_gps_kf.replay import main
    return main


TOOLS = {
    "allan": Tool("allan", "imu-calib allan", _allan_argv, _allan_figures, ALLAN_COLUMNS),
    "diagnose": Tool("diagnose", "imu-sim diagnose", _diagnose_argv, _diagnose_figures, ("mismatch", "findings")),
    "replay": Tool("replay", "ins-gps-kf replay", _replay_argv, _replay_figures, REPLAY_COLUMNS),
}


def _message(stderr: str, rc: int) -> str:
    """The row's message: the command's error line (exit != 0) or its warnings, one line."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    if rc != 0:
        errors = [ln for ln in lines if "error" in ln]
        return (errors or lines or [f"exit status {rc}"])[-1]
    return " | ".join(ln for ln in lines if "warning" in ln)


def run_one(tool: str, recording: str, out_dir: str, options: dict) -> dict:
    """Run ``tool`` on ``recording`` into ``out_dir``; the results.csv row (status ok or error, message, wall_s,
    key figures). Never raises for bad input: that is an error row naming the recording."""
    spec = TOOLS[tool]
    out = Path(out_dir)
    if tool == "replay":
        out.mkdir(parents=True, exist_ok=True)  # replay writes a file into the folder
    with _ONE_AT_A_TIME:
        start, cpu = time.perf_counter(), time.process_time()
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                rc = _main_of(tool)(spec.argv(recording, out, options))
            except SystemExit as stop:  # argparse: a bad option value
                rc = stop.code if isinstance(stop.code, int) else 2
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    row = {"recording": recording, "status": "ok" if rc == 0 else "error",
           "message": _message(stderr.getvalue(), rc), "wall_s": round(wall, 3), "cpu_s": round(cpu, 3)}
    if rc == 0:
        try:
            row.update(spec.figures(out, stdout.getvalue()))
        except (OSError, ValueError, KeyError) as err:
            row.update(status="error", message=f"{recording}: {spec.command} wrote no readable result: {err}")
    else:
        if tool == "replay" and out.is_dir() and not any(out.iterdir()):
            out.rmdir()  # made for the trajectory that was never written
        if recording not in row["message"]:
            row["message"] = f"{recording}: {row['message']}"
    return row
