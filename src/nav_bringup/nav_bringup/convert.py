"""``nav-convert``: turn a public recording into a bag the graph can replay, with its truth, model and params.

    nav-convert katwijk --out DIR      # ESA Katwijk beach rover (NaveGo), reference truth
    nav-convert canada --out DIR       # UTIAS Canadian planetary run 3 (NaveGo), reference truth
    nav-convert balzer [--csv F] --out DIR   # balzer82/Kalman car drive, Dresden (no truth: GPS)

DIR gets ``bag/`` (imu/data_raw, gps/fix; stamps = source time + 1.7e9 s),
``truth.csv`` where the source has a reference, ``sensor_model.yaml`` (the noise of
the stationary head when there is one, else the project's MEMS default, at the
recording's rate) and ``navigation.yaml`` (the graph's params with this
recording's rates and alignment time). Then ``nav-demo --recording DIR``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from nav_eval import datasets as kf_datasets
from nav_eval import rovers
from nav_core import recording, sensor_model
from nav_core.cli import about, add_common, parse_args, run_cli
from nav_core.outputs import check_out_dir, staged_dir
from nav_core.recording import ImuRecording
from nav_core.workspace import shared_data
from nav_bringup.graph import PARAMS_FILE, REPO

EPOCH_S = 1_700_000_000.0
DEFAULT_MODEL = REPO / "config" / "sensor_models" / "bp3010.yaml"
BALZER_CSV = shared_data("balzer_car/2014-03-26-000-Data.csv")
# Filter settings each source needs: the ones the filter's evaluation of that recording uses.
KF_OVERRIDES = {"katwijk": kf_datasets.KATWIJK_PARAMS, "canada": kf_datasets.CANADA_PARAMS,
                "balzer": kf_datasets.BALZER_PARAMS}


def load(name: str, csv: Path | None):
    """(imu, gnss, truth or None, filter parameters) of a source, IMU in body FLU."""
    if name == "katwijk":
        # forward = -x: the axis choice the filter's evaluation picked by GPS NIS (src/ins_gps_kf/README.md)
        imu, gnss, ref, _ = rovers.load_katwijk("-x_fwd")
        return imu, gnss, ref, KF_OVERRIDES[name]
    if name == "canada":
        imu, gnss, truth, info = rovers.load_canada()
        return imu, gnss, truth, dict(KF_OVERRIDES[name], initial_yaw_deg=kf_datasets.canada_initial_yaw(info))
    # the axes and the GPS latency the filter's evaluation found in the data (src/ins_gps_kf/README.md)
    imu, gnss, _ = kf_datasets.load_balzer(csv or BALZER_CSV)
    return imu, gnss, None, KF_OVERRIDES[name]


def stationary_head_s(imu: ImuRecording) -> float:
    """Seconds of rest at the start (motion onset of the angular rate)."""
    return float(rovers.motion_onset(imu.t, np.linalg.norm(imu.gyro, axis=1), imu.rate_hz) - imu.t[0])


def noise_model(imu: ImuRecording, head_s: float) -> sensor_model.SensorModel:
    """The stationary head's Allan characterisation if it is long enough, else the MEMS default at this rate."""
    if head_s >= 10.0:
        from imu_calib.characterise import characterise

        head = imu.between(imu.t[0], imu.t[0] + head_s)
        model = characterise(head).model
        model.provenance["note"] = f"Allan characterisation of the first {head_s:.1f} s (at rest)"
        _fill_white_noise(model, head)
    else:
        model = sensor_model.load(DEFAULT_MODEL)
        model.gyro.bias[:] = model.accel.bias[:] = 0.0
        model.gyro.scale_factor[:] = model.accel.scale_factor[:] = 0.0
        model.gyro.misalignment[:] = model.accel.misalignment[:] = 0.0
        model.provenance = {"note": f"MEMS default noise (no stationary head: {head_s:.1f} s at rest); "
                                    "no deterministic calibration"}
    model.sample_rate_hz = imu.rate_hz
    return model


def _fill_white_noise(model: sensor_model.SensorModel, head: ImuRecording) -> None:
    """Where the fit dropped the white noise N of an axis (a short head), take it from successive differences:
    for white noise, std(diff(x)) / sqrt(2) is the per-sample sigma, and N = sigma * sqrt(dt)."""
    dt = 1.0 / head.rate_hz
    for triad, data in (("gyro", head.gyro), ("accel", head.accel)):
        tri = model.triad(triad)
        estimate = np.std(np.diff(data, axis=0), axis=0) / np.sqrt(2.0) * np.sqrt(dt)
        missing = tri.white_noise <= 0
        tri.white_noise[missing] = estimate[missing]
        if missing.any():
            tri.info["white_noise_from_differences_axes"] = [int(i) for i in np.flatnonzero(missing)]


def write_params(out: Path, name: str, imu_rate: float, gps_rate: float, kf_params: dict) -> Path:
    """The graph's params file with this recording's rates and the source's alignment settings."""
    params = yaml.safe_load(PARAMS_FILE.read_text())
    params["ins_gps_kf_node"]["ros__parameters"].update(
        {**kf_params, "imu_rate_hz": imu_rate, "gps_rate_hz": gps_rate, "imu_topic": "imu/data_corrected"})
    params["wmra_node"]["ros__parameters"]["sample_rate_hz"] = imu_rate
    params["allan_node"]["ros__parameters"]["duration_s"] = 5.0
    path = out / "navigation.yaml"
    path.write_text(f"# config/navigation.yaml with the settings of the {name} recording (nav-convert)\n"
                    + yaml.safe_dump(params, sort_keys=False))
    return path


def convert(name: str, out: Path, csv: Path | None = None) -> dict:
    """Write the bag, truth, model and params of a source into ``out``; return a summary."""
    imu, gnss, truth, kf_params = load(name, csv)
    for damage in dict.fromkeys(r.damage for r in (imu, gnss) if r.damage):  # read past it: say what was lost
        print(f"nav-convert: warning: {damage}", file=sys.stderr)
    out.mkdir(parents=True, exist_ok=True)
    shifted_imu = ImuRecording(imu.t + EPOCH_S, imu.gyro, imu.accel, imu.temp_c, source=imu.source)
    shifted_gnss = recording.GnssRecording(gnss.t + EPOCH_S, gnss.lat, gnss.lon, gnss.h, gnss.std_enu, gnss.status,
                                           source=gnss.source)
    recording.write_bag(out / "bag", shifted_imu, shifted_gnss, storage="mcap")
    if truth is not None:
        truth.t = truth.t + EPOCH_S
        recording.write_trajectory_csv(out / "truth.csv", truth)
    head = stationary_head_s(imu)
    sensor_model.save(noise_model(imu, head), out / "sensor_model.yaml")
    gps_rate = 1.0 / float(np.median(np.diff(gnss.t)))
    write_params(out, name, imu.rate_hz, gps_rate, kf_params)
    return {"imu_samples": len(imu), "imu_rate_hz": imu.rate_hz, "gps_fixes": len(gnss), "gps_rate_hz": gps_rate,
            "stationary_head_s": head, "truth": truth is not None}


def main(argv=None) -> int:
    """Command line."""
    purpose, detail = __doc__.split("\n", 1)
    p = argparse.ArgumentParser(prog="nav-convert", **about(
        purpose.replace("``nav-convert``: turn", "Turn") + "\n" + detail.rstrip(),
        "nav-convert katwijk --out out/katwijk", "nav-convert balzer --out out/balzer"))
    p.add_argument("source", choices=sorted(KF_OVERRIDES))
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--csv", type=Path, default=None, help="balzer: which car CSV")
    add_common(p, force=True)
    return run_cli("nav-convert", _run, parse_args(p, argv))


def _run(args) -> int:
    """Check --out, convert into a temporary folder, rename it into place."""
    check_out_dir(args.out, args.force, inputs=(args.csv,))  # before reading the source: a bad --out fails at once
    with staged_dir(args.out, args.force, inputs=(args.csv,)) as tmp:
        summary = convert(args.source, tmp, args.csv)
    print(f"nav-convert {args.source}: {summary}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
