"""nav-batch: one task per recording on Dask; each folder byte for byte what the single command writes; a damaged
input is an error row; --resume runs only what is not ok; the existing-output rules; a separate scheduler and
two workers on loopback, one of them killed mid-run."""
import csv
import os
import signal
import socket
import subprocess
import time

import numpy as np
import pytest
import yaml

from imu_calib import synthetic
from nav_batch.batch import plan
from nav_batch.tools import run_one
from nav_core import sensor_model
from nav_core.outputs import OutputError
from nav_core.processes import executable
from nav_core.recording import ImuRecording, write_bag, write_imu_csv

EPOCH = "1700000000"  # SOURCE_DATE_EPOCH: the sensor models' created_utc, so two runs can be compared byte for byte
MODEL = sensor_model.SensorModel(
    gyro=sensor_model.TriadModel(white_noise=np.full(3, 8.7e-4), bias_instability=np.full(3, 3e-4)),
    accel=sensor_model.TriadModel(white_noise=np.full(3, 1.2e-3)), sample_rate_hz=20.0)


def _static_csvs(folder, n, duration_s=300.0):
    folder.mkdir(exist_ok=True)
    return [str(write_imu_csv(folder / f"rec{k}.csv",
                              synthetic.static_recording(MODEL, duration_s, np.random.default_rng(k))))
            for k in range(n)]


def _damaged(folder):
    path = folder / "damaged.csv"
    path.write_bytes(os.urandom(400))  # not text: no header, no rows
    return str(path)


def _env():
    env = dict(os.environ, SOURCE_DATE_EPOCH=EPOCH, OPENBLAS_NUM_THREADS="1")
    return env


def _batch(args, env=None, timeout=300):
    return subprocess.run([executable("nav-batch"), *args, "--no-progress"], capture_output=True, text=True,
                          env=env or _env(), timeout=timeout)


def _rows(out):
    with open(out / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _same_files(a, b):
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir()), (a, b)
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), f"{a / name} differs from {b / name}"
    return names


def _single(command, argv):
    """The single-recording command as a user types it."""
    proc = subprocess.run([executable(command), *argv], capture_output=True, text=True, env=_env(), timeout=300)
    assert proc.returncode == 0, proc.stderr


def test_two_recordings_with_one_stem_are_refused_before_any_work(tmp_path):
    with pytest.raises(OutputError, match="a/rec.csv and b/rec.mcap both write"):
        plan(["a/rec.csv", "b/rec.mcap"], tmp_path / "out")
    assert plan(["a/rec.csv", "bags/drive_bag"], tmp_path)["bags/drive_bag"] == tmp_path / "drive_bag"


def test_a_damaged_recording_is_an_error_row_naming_it_not_an_exception(tmp_path):
    bad = _damaged(tmp_path)
    row = run_one("allan", bad, str(tmp_path / "out" / "damaged"), {})
    assert row["status"] == "error" and bad in row["message"] and "imu-calib allan: error" in row["message"]
    assert not (tmp_path / "out").exists()


def test_resume_with_force_is_a_usage_error(tmp_path):
    proc = _batch(["allan", "x.csv", "--out", str(tmp_path / "o"), "--resume", "--force"])
    assert proc.returncode == 2 and "--resume" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_allan_batch_writes_what_imu_calib_allan_writes_and_resumes_only_what_is_not_ok(tmp_path):
    recs = _static_csvs(tmp_path / "in", 2) + [_damaged(tmp_path / "in")]
    out = tmp_path / "batch"
    proc = _batch(["allan", *recs, "--out", str(out), "--workers", "2"])
    assert proc.returncode == 1, proc.stderr  # one row is an error
    rows = _rows(out)
    assert [r["recording"] for r in rows] == recs and [r["status"] for r in rows] == ["ok", "ok", "error"]
    assert recs[2] in rows[2]["message"] and "missing column" in rows[2]["message"]
    for rec, row in zip(recs[:2], rows):
        stem = os.path.basename(rec)[:-4]
        _single("imu-calib", ["allan", rec, "--out", str(tmp_path / "single" / stem), "--no-progress"])
        assert _same_files(out / stem, tmp_path / "single" / stem) == ["allan.png", "imu.yaml", "sensor_model.yaml"]
        model = sensor_model.load(out / stem / "sensor_model.yaml")
        assert float(row["gyro_white_noise_y"]) == model.gyro.white_noise[1]
        assert float(row["wall_s"]) > 0
    assert not (out / "damaged").exists() and not list(out.glob(".*partial*"))

    again = _batch(["allan", *recs, "--out", str(out), "--workers", "1"])  # existing output: the usual rule
    assert again.returncode == 2 and "--force" in again.stderr and len(again.stderr.strip().splitlines()) == 1

    stamps = {p: p.stat().st_mtime_ns for p in (out / "rec0").iterdir()}
    write_imu_csv(recs[2], synthetic.static_recording(MODEL, 300.0, np.random.default_rng(9)))  # repaired
    resumed = _batch(["allan", *recs, "--out", str(out), "--workers", "1", "--resume"])
    assert resumed.returncode == 0, resumed.stderr
    assert "2 carried over" in resumed.stdout
    rows2 = _rows(out)
    assert [r["status"] for r in rows2] == ["ok"] * 3 and rows2[:2] == rows[:2]  # kept as they were
    assert {p: p.stat().st_mtime_ns for p in (out / "rec0").iterdir()} == stamps  # not run again
    assert (out / "damaged" / "sensor_model.yaml").exists()

    other = _batch(["allan", *recs, "--out", str(out), "--workers", "1", "--resume", "--per-decade", "5"])
    assert other.returncode == 2 and "--resume continues only that batch" in other.stderr

    forced = _batch(["allan", recs[0], "--out", str(out), "--workers", "1", "--force"])
    assert forced.returncode == 0, forced.stderr
    assert sorted(p.name for p in out.iterdir()) == ["batch.json", "rec0", "results.csv"]  # replaced whole
    assert not list(tmp_path.glob(".batch.old-*"))


def _drive_bag(path, seed):
    from ins_gps_kf import synthetic as syn
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=25.0)
    rng = np.random.default_rng(seed)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, 32.0), rng, 1e-4, 0.01, 1e-3, 1e-3)
    return str(write_bag(path, imu, syn.gnss(motion, 32.0, 1.0, rng), imu_topic="imu/data_corrected"))


@pytest.mark.slow
def test_replay_and_diagnose_batches_write_what_the_single_commands_write(tmp_path):
    from ins_gps_kf import error_model

    model = str(sensor_model.save(error_model.default_mems_model(), tmp_path / "model.yaml"))
    bags = [_drive_bag(tmp_path / f"drive{k}", k) for k in range(2)]
    proc = _batch(["replay", *bags, "--out", str(tmp_path / "rb"), "--workers", "2", "--model", model,
                   "--param", "alignment_time_s=15.0"])
    assert proc.returncode == 0, proc.stderr
    for bag, row in zip(bags, _rows(tmp_path / "rb")):
        name = os.path.basename(bag)
        _single("ins-gps-kf", ["replay", "--recording", bag, "--model", model, "--param", "alignment_time_s=15.0",
                              "--out", str(tmp_path / "single" / name / "trajectory.csv"), "--quiet"])
        assert _same_files(tmp_path / "rb" / name, tmp_path / "single" / name) == ["trajectory.csv",
                                                                                   "trajectory.png"]
        assert row["status"] == "ok" and int(row["epochs"]) > 50 and int(row["fixes"]) > 30

    rate, n = 50.0, 1500
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(yaml.safe_dump({"latitude_deg": 45.0, "longitude_deg": 7.0, "height_m": 200.0,
                                        "rate_hz": rate, "gps": False, "static_segments": [
                                            {"t0": 0.0, "t1": n / rate + 1.0, "roll_deg": 0.0, "pitch_deg": 0.0,
                                             "yaw_deg": 0.0}]}))
    truth = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 1e-4)),
                                     accel=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=rate)
    smodel = str(sensor_model.save(truth, tmp_path / "static_model.yaml"))
    recs = []
    for k in range(2):
        rng = np.random.default_rng(k)
        t = np.arange(1, n + 1) / rate
        rec = ImuRecording(t, rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-2, (n, 3)) + [0, 0, 9.8])
        recs.append(str(write_imu_csv(tmp_path / f"static{k}.csv", rec)))
    proc = _batch(["diagnose", *recs, "--out", str(tmp_path / "db"), "--workers", "2", "--scenario", str(scenario),
                   "--model", smodel])
    assert proc.returncode == 0, proc.stderr
    for rec, row in zip(recs, _rows(tmp_path / "db")):
        name = os.path.basename(rec)[:-4]
        _single("imu-sim", ["diagnose", "--recording", rec, "--scenario", str(scenario), "--model", smodel,
                           "--out", str(tmp_path / "single" / name)])
        assert "diagnosis.json" in _same_files(tmp_path / "db" / name, tmp_path / "single" / name)
        assert row["status"] == "ok" and row["mismatch"] in ("yes", "no")


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _running_on(address, name, timeout_s=240.0):
    """The key of a task the worker called ``name`` is running (asked of the scheduler), once it runs one."""
    from distributed import Client
    with Client(address, timeout="30s") as client:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            workers = client.scheduler_info()["workers"]
            addr = next((a for a, w in workers.items() if w.get("name") == name), None)
            keys = client.processing().get(addr, ()) if addr else ()
            if keys:
                time.sleep(1.0)  # well inside the task (each takes several seconds), not at its hand-over
                return str(list(keys)[0])
            time.sleep(0.1)
    raise AssertionError(f"worker {name} never ran a task")


@pytest.mark.slow
def test_a_batch_on_a_separate_scheduler_loses_nothing_when_a_worker_is_killed_mid_run(tmp_path):
    # four recordings: the killed worker holds one or two of them, the other worker is left its own and those
    recs = _static_csvs(tmp_path / "in", 4, duration_s=600.0)
    address = f"tcp://127.0.0.1:{_free_port()}"
    env = _env()
    dask = executable("dask")
    logs = {name: open(tmp_path / f"{name}.log", "w") for name in ("scheduler", "w1", "w2")}
    procs = {"scheduler": subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port",
                                            address.rsplit(":", 1)[1], "--no-dashboard"], env=env,
                                           stdout=logs["scheduler"], stderr=subprocess.STDOUT)}
    try:
        time.sleep(3)
        for name in ("w1", "w2"):  # no nanny: a killed worker stays dead, the other one must finish everything
            procs[name] = subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-nanny", "--name", name,
                                            "--no-dashboard", "--host", "127.0.0.1"], env=env,
                                           stdout=logs[name], stderr=subprocess.STDOUT)
        out = tmp_path / "batch"
        batch = subprocess.Popen([executable("nav-batch"), "allan", *recs, "--out", str(out), "--scheduler", address,
                                  "--no-progress"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        running = _running_on(address, "w1")  # a recording's task w1 is running now, which its death interrupts
        os.kill(procs["w1"].pid, signal.SIGKILL)
        stdout, stderr = batch.communicate(timeout=400)
        assert batch.returncode == 0, stderr
        assert running.startswith("nav-batch-allan-")
        rows = _rows(out)
        assert [r["recording"] for r in rows] == recs and all(r["status"] == "ok" for r in rows), rows
        assert sorted(p.name for p in out.iterdir()) == sorted(["batch.json", "results.csv"] +
                                                               [f"rec{k}" for k in range(len(recs))])
        for k in range(len(recs)):
            assert sorted(p.name for p in (out / f"rec{k}").iterdir()) == ["allan.png", "imu.yaml",
                                                                           "sensor_model.yaml"]
        logs["scheduler"].flush()
        assert "Remove worker" in (tmp_path / "scheduler.log").read_text()  # the scheduler saw w1 go
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for proc in procs.values():
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
        for fh in logs.values():
            fh.close()
