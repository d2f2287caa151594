"""``imu-calib``: Allan characterisation and deterministic calibrations from recordings.

Subcommands (degrees and deg/s only here, at the edge; SI in the files)::

    imu-calib allan REC --out DIR [--topic T] [--per-decade N]
    imu-calib two-position --up REC --down REC --axis x --lat-deg 51.08 --height-m 1100 --out MODEL.yaml
    imu-calib rate-table --rec1 REC --rate1-dps 100 --rec2 REC --rate2-dps -100 --axis z \
        --direction up --lat-deg 51.08 --out MODEL.yaml
    imu-calib multi-position REC --out MODEL.yaml --lat-deg 51.08 [--height-m H] [--no-gyro-scale]

REC is a rosbag2 bag or the recording CSV (``nav_core.recording.read_imu``);
``--format ucalgary`` / ``--format imutk`` / ``--format adis`` read the real
recordings of ``shared/data``. The calibration subcommands update MODEL.yaml if it exists.
"""
from __future__ import annotations

import argparse
import logging
import sys

import numpy as np

from imu_calib import model_io, multi_position, rate_table, screen, two_position
from nav_core import sensor_model
from nav_core.cli import about, add_common, number, parse_args, run_cli
from nav_core.outputs import check_out_dir, check_out_file, rebase, staged_dir
from nav_core.recording import IMU_TOPIC
from nav_core.units import DEG


def load_recording(path, topic: str | None = None, fmt: str = "auto", gyro_file=None):
    """A recording from a bag/CSV (auto) or one of the real formats (ucalgary, imutk, adis); what was lost
    reading it is said on stderr (:func:`imu_calib.screen.read`)."""
    rec, notes = screen.read(path, topic, fmt, gyro_file)
    for line in notes:
        warn(line)
    return rec


def warn(line: str) -> None:
    """One warning line on stderr."""
    print(f"imu-calib: warning: {line}", file=sys.stderr)


def load_screened(path, topic: str, fmt: str, columns=None, gyro_file=None):
    """A recording for a calibration that averages static samples (``columns`` of :data:`screen.COLUMNS`
    used) or, with ``columns=None``, steps through every sample: non-finite samples dropped and said
    (averages) or refused (stepping); exact duplicate rows dropped and said (both)."""
    rec = load_recording(path, topic, fmt, gyro_file)
    if columns is None:
        rec, notes = screen.refuse_non_finite(rec, "multi-position steps through every sample at one rate (static "
                                                   "detection, gyro integration): remove or repair those rows")
    else:
        rec, notes = screen.for_means(rec, columns)
    for line in notes:
        warn(line)
    return rec


def _add_format(p, imutk: bool = True) -> None:
    p.add_argument("--topic", help=f"IMU topic in a bag (default {IMU_TOPIC}; an error with a CSV or text file)")
    if not imutk:  # imutk needs a second (gyro) file per recording: only where one REC is read
        p.add_argument("--format", default="auto", choices=("auto", "ucalgary", "adis"),
                       help="recording format: auto (bag or CSV), ucalgary text, adis .npz")
        return
    p.add_argument("--format", default="auto", choices=("auto", "ucalgary", "imutk", "adis"),
                   help="recording format: auto (bag or CSV), ucalgary text, imutk text (raw counts; REC is the "
                        "accelerometer file, --gyro-file the gyro file), adis .npz")
    p.add_argument("--gyro-file", help="gyro file for --format imutk")


def _add_site(p, required: bool = True) -> None:
    p.add_argument("--lat-deg", type=number(-90.0, 90.0), required=required, help="site latitude, deg")
    p.add_argument("--height-m", type=number(-1.2e4, 1e5), default=0.0, help="site ellipsoidal height, m")


UPDOWN = "../shared/data/ucalgary_adi_updown"
"""The real x-up/x-down recordings the help's examples use (relative to the repository)."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with its four subcommands."""
    parser = argparse.ArgumentParser(prog="imu-calib", **about(
        "Characterise an IMU's noise (Allan deviation) and calibrate its biases and scale factors from recordings.",
        "imu-calib allan static_bag --topic imu/data_raw --out out/my_imu"))
    add_common(parser)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("allan", help="Allan deviation, 5-term noise fit -> sensor_model.yaml, imu.yaml, allan.png",
                       **about("Fit the five Allan noise terms of a static recording: sensor_model.yaml, imu.yaml, "
                               "allan.png.",
                               "imu-calib allan static_bag --topic imu/data_raw --out out/my_imu",
                               f"imu-calib allan {UPDOWN}/x_adi_up.txt --format ucalgary --out out/adi"))
    p.add_argument("recording", help="rosbag2 bag or recording CSV of a static IMU")
    p.add_argument("--out", required=True, help="output folder (new or empty; --force replaces it)")
    add_common(p, force=True, sub=True)
    p.add_argument("--per-decade", type=number(0, 100, integer=True), default=0,
                   help="log-spaced cluster times per decade (default 0: octave grid)")
    p.add_argument("--base-model", help="sensor model whose deterministic terms are kept")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--split-at-gaps", action="store_true",
                   help="where the stamps go back or have a gap, analyse the longest unbroken segment (what was "
                        "skipped is recorded in the YAML) instead of refusing the recording; a NaN or infinite "
                        "sample and a stamp repeated with other values break the record the same way")
    _add_format(p)
    p.set_defaults(func=cmd_allan)

    p = sub.add_parser("two-position", help="accelerometer bias and scale of one axis (paper eqs. 1-4)",
                       **about("Calibrate one accelerometer axis's bias and scale from two static positions (axis up, "
                               "then down).",
                               f"imu-calib two-position --up {UPDOWN}/x_adi_up.txt --down {UPDOWN}/x_adi_down.txt "
                               "--format ucalgary --axis x --lat-deg 51.0784 --height-m 1100 --out model.yaml"))
    p.add_argument("--up", required=True, help="recording with the axis pointing up")
    p.add_argument("--down", required=True, help="recording with the axis pointing down")
    p.add_argument("--axis", required=True, choices=("x", "y", "z"))
    p.add_argument("--out", required=True, help="sensor-model YAML to create or update")
    add_common(p, sub=True)
    _add_site(p)
    _add_format(p, imutk=False)
    p.set_defaults(func=cmd_two_position)

    p = sub.add_parser("rate-table", help="gyro scale and bias of one axis at two table rates (eqs. 5-7)",
                       **about("Calibrate one gyro axis's bias and scale from two rate-table recordings.",
                               "imu-calib rate-table --rec1 cw_bag --rate1-dps 100 --rec2 ccw_bag --rate2-dps -100 "
                               "--axis z --direction up --lat-deg 51.08 --out model.yaml"))
    p.add_argument("--rec1", required=True)
    p.add_argument("--rate1-dps", type=number(), required=True, help="table rate of rec1, deg/s")
    p.add_argument("--rec2", required=True)
    p.add_argument("--rate2-dps", type=number(), required=True, help="table rate of rec2, deg/s")
    add_common(p, sub=True)
    p.add_argument("--axis", required=True, choices=("x", "y", "z"))
    p.add_argument("--direction", default="up", choices=sorted(rate_table.DIRECTIONS),
                   help="direction (ENU) the gyro axis points along on the table")
    p.add_argument("--out", required=True)
    _add_site(p)
    _add_format(p, imutk=False)
    p.set_defaults(func=cmd_rate_table)

    p = sub.add_parser("multi-position", help="accel bias, scale, misalignment, gyro bias, scale and misalignment "
                                              "from many orientations",
                       **about("Calibrate both triads (bias, scale, misalignment) from one recording in many static "
                               "orientations.",
                               "imu-calib multi-position ../shared/data/imutk_multiposition/xsens_acc.mat "
                               "--gyro-file ../shared/data/imutk_multiposition/xsens_gyro.mat --format imutk "
                               "--gravity 9.81 --out model.yaml"))
    p.add_argument("recording")
    p.add_argument("--out", required=True, help="sensor-model YAML to create or update")
    add_common(p, sub=True)
    p.add_argument("--gravity", type=number(0.0, low_open=True), help="gravity magnitude in the data's units (default: WGS-84 at site)")
    p.add_argument("--init-static-s", type=number(0.0, low_open=True), default=30.0, help="initial static interval, s")
    p.add_argument("--threshold-factor", type=number(0.0, low_open=True), default=4.0,
                   help="static if window variance < factor x initial level")
    p.add_argument("--min-static-s", type=number(0.0), default=2.0, help="shortest static segment kept, s")
    p.add_argument("--no-gyro-scale", action="store_true",
                   help="skip the gyro scale/misalignment fit from the moves (gyro bias only)")
    _add_site(p, required=False)
    _add_format(p)
    p.set_defaults(func=cmd_multi_position)
    return parser


def cmd_allan(args) -> int:
    """Characterise a static recording and write the three outputs."""
    from tqdm import tqdm

    from imu_calib.characterise import characterise, warnings_of, write_outputs

    inputs = (args.recording, args.base_model)
    check_out_dir(args.out, args.force, inputs=inputs)  # before the work: a bad --out fails now, not after it
    base = sensor_model.load(args.base_model) if args.base_model else None
    rec = load_recording(args.recording, args.topic, args.format, args.gyro_file)
    t = rec.t[np.isfinite(rec.t)]
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    rate = 1.0 / np.median(np.diff(t)) if len(t) > 1 else float("nan")
    print(f"{args.recording}: {len(rec)} samples, stamps span {span:.1f} s, median rate {rate:.3g} Hz", flush=True)
    bar = tqdm(total=6, desc="Allan deviation", unit="axis", disable=args.no_progress)

    def progress(label):
        bar.set_postfix_str(label)
        bar.update(1)

    result = characterise(rec, per_decade=args.per_decade or None, progress=progress, base_model=base,
                          split=args.split_at_gaps)
    bar.close()
    prov = result.model.provenance
    print(f"analysed {prov['n_samples']} samples, {prov['duration_s']:.1f} s", flush=True)
    with staged_dir(args.out, args.force, inputs) as tmp:  # the three files appear together, or none
        paths = rebase(write_outputs(result, tmp, rostopic="/" + (args.topic or IMU_TOPIC).lstrip("/")), tmp, args.out)
    _print_noise(result)
    for line in warnings_of(result):
        print(f"imu-calib allan: warning: {line}", file=sys.stderr)
    for path in paths.values():
        print(f"wrote {path}")
    return 0


def _print_noise(result) -> None:
    for triad in ("gyro", "accel"):
        for i, fit in enumerate(result.fits[triad]):
            terms = ", ".join(f"{t}={fit.values[t]:.3g} [{fit.intervals[t][0]:.3g}, {fit.intervals[t][1]:.3g}]"
                              for t in fit.kept)
            bounds = ", ".join(f"{t}<={b:.3g}" for t, b in fit.upper_bounds.items() if b > 0)
            bounds = f"; not identifiable from this record: {bounds}" if bounds else ""
            gm = f", GM tau_c={fit.bias_correlation_time:.3g} s" if fit.bias_correlation_time else ""
            q = fit.fit_quality
            reduced = q["chi2"] / max(q["points"] - q["terms"], 1)  # without the model-error floor
            print(f"{triad} {'xyz'[i]}: {terms}{gm}{bounds} (SI; fit {q['verdict']}, reduced chi2 {reduced:.3g}, "
                  f"p = {q['p_value']:.2g})")


def cmd_two_position(args) -> int:
    """Eqs. 1-4 for one axis; update the model."""
    check_out_file(args.out, update=True)
    i = two_position.axis_index(args.axis)
    up = load_screened(args.up, args.topic, args.format, columns=(i, 3 + i))
    down = load_screened(args.down, args.topic, args.format, columns=(i, 3 + i))
    model = model_io.load_or_new(args.out, up.rate_hz)  # a bad existing MODEL.yaml fails before the work
    res = two_position.two_position_from_recordings(up, down, args.axis, args.lat_deg * DEG, args.height_m)
    two_position.apply_to_model(model, res)
    model.accel.info.setdefault("two_position", {})[args.axis] = {"gravity_mps2": res.gravity,
                                                                  "mean_up": res.mean_up, "mean_down": res.mean_down}
    sensor_model.stamp_provenance(model, "imu_calib two-position", f"{args.up} + {args.down}",
                                  lat_deg=args.lat_deg, height_m=args.height_m)
    sensor_model.save(model, args.out)
    print(f"local gravity {res.gravity:.5f} m/s^2 at {args.lat_deg} deg, {args.height_m} m")
    print(f"accel {args.axis}: bias {res.bias:.5f} m/s^2 [{res.bias_interval[0]:.5f}, {res.bias_interval[1]:.5f}], "
          f"scale factor {res.scale_factor:.5f} [{res.scale_interval[0]:.5f}, {res.scale_interval[1]:.5f}]")
    print(f"gyro {args.axis}: bias {res.gyro_bias / DEG:.5f} deg/s")
    print(f"wrote {args.out}")
    return 0


def cmd_rate_table(args) -> int:
    """Eqs. 5-7 for one axis; update the model."""
    i = two_position.axis_index(args.axis)
    check_out_file(args.out, update=True)
    rec1 = load_screened(args.rec1, args.topic, args.format, columns=(i,))
    rec2 = load_screened(args.rec2, args.topic, args.format, columns=(i,))
    model = model_io.load_or_new(args.out, rec1.rate_hz)  # a bad existing MODEL.yaml fails before the work
    res = rate_table.rate_table(rec1.gyro[:, i], args.rate1_dps * DEG, rec2.gyro[:, i], args.rate2_dps * DEG,
                                args.lat_deg * DEG, args.direction, i)
    rate_table.apply_to_model(model, res)
    sensor_model.stamp_provenance(model, "imu_calib rate-table", f"{args.rec1} + {args.rec2}",
                                  lat_deg=args.lat_deg, axis_direction=args.direction)
    sensor_model.save(model, args.out)
    print(f"Earth rate along the axis ({args.direction}): {res.earth_rate_component / DEG * 3600:.4f} deg/h")
    print(f"gyro {args.axis}: scale factor {res.scale_factor:.5f} "
          f"[{res.scale_interval[0]:.5f}, {res.scale_interval[1]:.5f}], bias {res.bias / DEG:.5f} deg/s "
          f"[{res.bias_interval[0] / DEG:.5f}, {res.bias_interval[1] / DEG:.5f}]")
    print(f"wrote {args.out}")
    return 0


def cmd_multi_position(args) -> int:
    """Static detection, least-squares accel fit, gyro scale/misalignment from the moves; update the model."""
    check_out_file(args.out, update=True)
    rec = load_screened(args.recording, args.topic, args.format, gyro_file=args.gyro_file)
    model = model_io.load_or_new(args.out, rec.rate_hz)  # a bad existing MODEL.yaml fails before the fit
    lat = None if args.lat_deg is None else args.lat_deg * DEG
    res = multi_position.multi_position(rec, lat, args.height_m, args.gravity, init_static_s=args.init_static_s,
                                        threshold_factor=args.threshold_factor, min_static_s=args.min_static_s,
                                        with_gyro=not args.no_gyro_scale)
    multi_position.apply_to_model(model, res)
    sensor_model.stamp_provenance(model, "imu_calib multi-position", args.recording, lat_deg=args.lat_deg,
                                  gravity=res.gravity, static_segments=len(res.segments))
    sensor_model.save(model, args.out)
    print(f"{len(res.segments)} static segments; |g| residual RMS {res.rms_residual:.4g} after, "
          f"{np.sqrt(np.mean(res.residuals_before ** 2)):.4g} before (data units)")
    print(f"accel bias {np.round(res.bias, 5)}, scale factor {np.round(res.scale_factor, 5)}")
    print(f"misalignment (upper triangle) {np.round(res.misalignment[[0, 0, 1], [1, 2, 2]], 6)}")
    print(f"gyro bias {np.round(res.gyro_bias, 6)}")
    if res.moves_skipped:
        k, i, t = res.moves_skipped[0]
        warn(f"{args.recording}: {len(res.moves_skipped)} move(s) left out of the gyro fit because their stamps go "
             f"back, repeat or leave a gap, the first move {k} at {screen.where(rec, i)}")
    if res.gyro is not None:
        gyro = res.gyro
        print(f"gyro from {gyro.n_moves} moves: gravity direction error RMS "
              f"{np.degrees(np.sqrt(np.mean(gyro.residuals ** 2))):.3g} deg after, "
              f"{np.degrees(np.sqrt(np.mean(gyro.residuals_before ** 2))):.3g} deg with one common scale")
        print(f"gyro scale factor {np.round(gyro.scale_factor, 6)}")
        print(f"gyro misalignment (rows x, y, z) {np.round(gyro.misalignment, 6).tolist()}")
    print(f"wrote {args.out}")
    return 0


def parse(argv=None) -> argparse.Namespace:
    """The arguments; an unknown option is a usage error of its subcommand naming the closest known one."""
    return parse_args(build_parser(), argv)


def main(argv=None) -> int:
    """Console-script entry point."""
    args = parse(argv)
    # the reader logs what it skipped and load_recording says it once on stderr: not twice
    logging.getLogger("nav_core.recording").addHandler(logging.NullHandler())
    return run_cli(f"imu-calib {args.command}", args.func, args)  # AllanError etc. are ValueErrors: exit 2


if __name__ == "__main__":
    sys.exit(main())
