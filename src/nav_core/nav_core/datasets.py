"""Readers for the public recordings in ``../shared/data`` that are not in the project's own formats.

The one home of every external-format loader; each returns nav_core recording
types in SI units (unless it says it keeps raw counts):

* UCalgary ADI two-position text, imu_tk multi-position text, ADIS16405 static ``.npz``;
* the balzer82/Kalman car CSV (IMU and its GPS columns);
* the NaveGo planetary-rover runs:
  Loaders for the real rover recordings in ``../shared/data/navego_rover`` (NaveGo, LGPL-3 code) to nav_core types.

  Katwijk beach (ESA): IMU 125 Hz (``katwijk_imu_planetary.mat``), RTK fixes every 3 s
  (``katwijk_gps-latlong.txt``), and the source's 20 Hz reference interpolated from the
  same fixes (``katwijk_gnss_planetary_r.mat``: position and NED velocity). The IMU time
  was rebased by the source, so the IMU is aligned to the GPS by the start of motion.
  The body axes are not documented (z reads +g at rest); the forward axis is chosen by
  the data (smallest mean GPS NIS among the four level axis choices) and reported.
"""
from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np

from nav_core.recording import GnssRecording, ImuRecording, RecordingError, Trajectory
from nav_core.units import DEG, G0
from nav_core.workspace import shared_data

NAVEGO = shared_data("navego_rover")


# ---------------------------------------------------------------- calibration recordings

def _load_text(path, n_cols: int):
    """(rows (n, n_cols), damage text or None, skipped line numbers) of a whitespace table.

    A row without ``n_cols`` numbers (a bad cell, a cut last line) is skipped and counted, as the CSV reader
    does (``nav_core.recording``); more than 1 % bad rows, or none good, is a RecordingError naming the file.
    """
    from nav_core.recording import MAX_BAD_ROW_FRACTION, _csv_damage
    from nav_core.table_rows import numbers

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: file not found")
    rows, bad = [], []
    with open(path, errors="replace") as fh:  # undecodable bytes fail as numbers: a bad row
        for line_no, line in enumerate(fh, start=1):
            fields = line.split("#", 1)[0].split()
            if not fields:
                continue
            try:
                if len(fields) != n_cols:
                    raise ValueError(f"{len(fields)} fields, expected {n_cols}")
                rows.append(numbers(fields, [str(k) for k in range(1, n_cols + 1)]))  # names column k (1-based)
            except ValueError as err:
                bad.append((line_no, str(err)))
    if not rows:
        first = f" (line {bad[0][0]}: {bad[0][1]})" if bad else ""
        raise RecordingError(f"{path}: no rows of {n_cols} whitespace-separated numbers{first}")
    damage = _csv_damage(path, bad, len(rows), MAX_BAD_ROW_FRACTION)
    return np.array(rows, dtype=float), damage, tuple(n for n, _ in bad)


def load_ucalgary_updown(path) -> ImuRecording:
    """``x_adi_{up,down}.txt``: GPS seconds of week, gyro x y z (deg/s), accel x y z (m/s^2)."""
    data, damage, skipped = _load_text(path, 7)
    return ImuRecording(data[:, 0], data[:, 1:4] * DEG, data[:, 4:7], source=str(path), damage=damage,
                        skipped_rows=skipped)


def load_imutk(acc_path, gyro_path) -> ImuRecording:
    """imu_tk's ``xsens_{acc,gyro}.mat`` text files: time (s), raw counts x y z. Keeps raw counts."""
    (acc, acc_damage, _), (gyro, gyro_damage, _) = _load_text(acc_path, 4), _load_text(gyro_path, 4)
    damage = "; ".join(d for d in (acc_damage, gyro_damage) if d) or None
    if damage:  # a row skipped in one file: pair the rest by their common stamps
        _, ia, ig = np.intersect1d(acc[:, 0], gyro[:, 0], assume_unique=False, return_indices=True)
        acc, gyro = acc[np.sort(ia)], gyro[np.sort(ig)]
    if len(acc) != len(gyro) or not np.allclose(acc[:, 0], gyro[:, 0]):
        raise RecordingError(f"{acc_path} and {gyro_path}: time columns differ")
    return ImuRecording(acc[:, 0], gyro[:, 1:4], acc[:, 1:4], source=f"{acc_path} (raw counts)", damage=damage)


def load_adis_npz(path) -> ImuRecording:
    """``adis16405_static/imuN.npz``: counts x LSB (deg/s, g) converted to rad/s and m/s^2."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    import zipfile

    try:
        with np.load(path) as data:
            rate = float(data["rate_hz"])
            gyro = data["gyro_counts"] * float(data["gyro_lsb_dps"]) * DEG
            accel = data["accel_counts"] * float(data["accel_lsb_g"]) * G0
    except KeyError as err:
        raise RecordingError(f"{path}: missing field {err}") from err
    except (zipfile.BadZipFile, EOFError, ValueError, OSError, AttributeError) as err:  # cut, empty or not .npz
        raise RecordingError(f"{path}: not a readable .npz archive (cut or another format?): {err}") from err
    return ImuRecording(np.arange(len(gyro)) / rate, gyro, accel, source=str(path))


# ---------------------------------------------------------------- balzer82 car


BALZER_IMU_COLUMNS = ("millis", "ax", "ay", "az", "rollrate", "pitchrate", "yawrate")
BALZER_GNSS_COLUMNS = ("millis", "time", "latitude", "longitude", "altitude", "epe", "fix")


def _read_balzer_table(path, need, finite):
    """Columns of the balzer82 CSV (the project's CSV reader: malformed rows skipped and counted) with the rows
    whose ``finite`` columns are not all finite, or whose ``millis`` is not after every earlier row's, dropped;
    time ``t`` (s from the first row) added. Returns (columns, damage text or None).

    A repeated ``millis`` is the logger's habit (dropped without a word); a stamp before an earlier one, a
    NaN or a text field is damage, named by its line; more than 1 % of the rows bad is a RecordingError.
    """
    from nav_core.recording import MAX_BAD_ROW_FRACTION, _read_csv_table

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: file not found")
    cols, damage, skipped, lines = _read_csv_table(path, need, strict=False)
    n = len(cols["millis"])
    values = np.column_stack([cols[c] for c in finite])
    bad = ~np.all(np.isfinite(values), axis=1)
    millis = np.where(bad, -np.inf, cols["millis"])
    latest = np.maximum.accumulate(np.concatenate(([-np.inf], millis[:-1])))
    back = ~bad & (millis < latest)
    repeated = ~bad & (millis == latest)
    notes = []
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        column = finite[int(np.flatnonzero(~np.isfinite(values[k]))[0])]
        notes.append(f"{int(bad.sum())} row(s) with a value that is not a finite number dropped "
                     f"(line {lines[k]}: column {column!r})")
    if back.any():
        k = int(np.flatnonzero(back)[0])
        notes.append(f"{int(back.sum())} row(s) stamped before an earlier row dropped (line {lines[k]}: millis "
                     f"{cols['millis'][k]:.12g} after {latest[k]:.12g})")
    n_bad = int(bad.sum() + back.sum()) + len(skipped)
    if notes:
        text = f"{path}: " + "; ".join(notes)
        if n_bad > 1 and n_bad > MAX_BAD_ROW_FRACTION * (n + len(skipped)):
            raise RecordingError(f"{text}: {n_bad} bad row(s) of {n + len(skipped)}, more than "
                                 f"{MAX_BAD_ROW_FRACTION:.0%}, so the file is not used")
        damage = "; ".join(d for d in (damage, text) if d)
    keep = ~(bad | back | repeated)
    if keep.sum() < 2:
        raise RecordingError(f"{path}: {int(keep.sum())} usable row(s), a recording needs at least 2")
    out = {c: v[keep] for c, v in cols.items()}
    out["t"] = (out["millis"] - cols["millis"][np.isfinite(cols["millis"])][0]) / 1e3  # one base for IMU and GNSS
    return out, damage


def read_balzer_csv(path, sample_rate_hz: float = 50.0) -> ImuRecording:
    """The balzer82/Kalman car CSV (deg/s, m/s^2, millis) as an ImuRecording in SI on a uniform time grid.

    Axes as logged; ``nav_eval.datasets.load_balzer`` turns them into FLU (found from the data).

    The logger's sample interval jitters (11-36 ms for 1-99 %), so the channels are
    linearly interpolated onto ``sample_rate_hz``; the WMRA assumes uniform samples. Damaged rows
    are dropped (the interpolation bridges them) and named in ``damage``.
    """
    cols, damage = _read_balzer_table(path, BALZER_IMU_COLUMNS, BALZER_IMU_COLUMNS)
    t_raw = cols["t"]
    t = np.arange(0.0, t_raw[-1], 1.0 / sample_rate_hz)
    gyro = np.column_stack([np.interp(t, t_raw, cols[c]) for c in ("rollrate", "pitchrate", "yawrate")]) * DEG
    accel = np.column_stack([np.interp(t, t_raw, cols[c]) for c in ("ax", "ay", "az")])
    temp = np.interp(t, t_raw, cols["temp"]) if "temp" in cols else None
    return ImuRecording(t, gyro, accel, temp, source=str(path), damage=damage)


def read_balzer_gnss(path) -> GnssRecording:
    """The GPS columns of the balzer82/Kalman car CSV: one fix per change of the GPS ``time`` column.

    Time is on the same base as :func:`read_balzer_csv` (s from the first row). The
    logger reports EPE (m); it is used as the horizontal 1-sigma and twice it as the
    vertical one. ``fix`` below 2 is published as NO_FIX.
    """
    cols, damage = _read_balzer_table(path, BALZER_GNSS_COLUMNS, ("millis", "time"))
    new_fix = np.concatenate([[True], np.diff(cols["time"]) != 0])
    d = {c: v[new_fix] for c, v in cols.items()}
    std = np.column_stack([d["epe"], d["epe"], 2.0 * d["epe"]])
    status = np.where(d["fix"] >= 2, 0, -1)
    return GnssRecording(d["t"], d["latitude"] * DEG, d["longitude"] * DEG, d["altitude"], std, status,
                         source=str(path), damage=damage)


# ---------------------------------------------------------------- NaveGo rovers

# body FLU from the file's axes, z kept up: forward = +x, +y, -x or -y of the file
AXIS_CHOICES = {"x_fwd": np.eye(3), "y_fwd": np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]]),
                "-x_fwd": np.diag([-1.0, -1.0, 1.0]), "-y_fwd": np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])}


def _loadmat(path, key):
    import scipy.io as sio
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: not found")
    try:
        return sio.loadmat(path, squeeze_me=True, struct_as_record=False)[key]
    except (KeyError, ValueError, OSError) as err:
        raise RecordingError(f"{path}: cannot read '{key}': {err}") from err


def read_navego_imu(path, key="imu_planetary", axes=np.eye(3)) -> ImuRecording:
    """NaveGo ``imu_planetary`` struct: ``t`` (s), ``wb`` (rad/s), ``fb`` (m/s^2), rows rotated by ``axes``."""
    m = _loadmat(path, key)
    return ImuRecording(np.asarray(m.t, float), np.asarray(m.wb, float) @ axes.T, np.asarray(m.fb, float) @ axes.T,
                        source=str(path))


def read_katwijk_gps(path) -> GnssRecording:
    """RTK fixes ``YYYY_MM_DD_hh_mm_ss_mmm TYPE lat lon h std_e std_n std_u``; t from the first fix (s)."""
    path = Path(path)
    rows, status = [], []
    for line_no, line in enumerate(path.read_text().splitlines(), start=1):
        parts = line.split()
        if not parts:
            continue
        try:
            stamp = _dt.datetime.strptime(parts[0], "%Y_%m_%d_%H_%M_%S_%f").timestamp()
            rows.append([stamp, *map(float, parts[2:8])])
        except (ValueError, IndexError) as err:
            raise RecordingError(f"{path}: line {line_no}: {err}") from err
        status.append(2 if parts[1].startswith("RTK") else 0)  # NavSatStatus GBAS_FIX for RTK
    a = np.asarray(rows)
    return GnssRecording(a[:, 0] - a[0, 0], a[:, 1] * DEG, a[:, 2] * DEG, a[:, 3], a[:, 4:7], status,
                         source=str(path))


def read_navego_reference(path, key="gnss_planetary_r") -> Trajectory:
    """The source's reference: lat/lon (rad), h (m), NED velocity -> ENU; no attitude (NaN)."""
    r = _loadmat(path, key)
    vel_ned = np.asarray(r.vel, float)
    nan = np.full(len(r.t), np.nan)
    return Trajectory(np.asarray(r.t, float), np.asarray(r.lat, float), np.asarray(r.lon, float),
                      np.asarray(r.h, float), nan, nan, nan, vel_ned[:, [1, 0, 2]] * [1, 1, -1])


def motion_onset(t, values, rate_hz, factor=2.0, block_s=1.0):
    """Start (s) of the first ``block_s`` block whose mean ``values`` exceeds ``factor`` x the first 10 blocks' median."""
    n = max(int(round(rate_hz * block_s)), 1)
    k = len(values) // n
    blocks = np.asarray(values[:k * n]).reshape(k, n).mean(axis=1)
    base = np.median(blocks[:10])
    idx = int(np.argmax(blocks > factor * base))
    return float(t[idx * n])


def load_katwijk(axes_name="x_fwd", data=NAVEGO):
    """(imu, gnss, reference, info): the IMU re-timed so its motion onset meets the reference's."""
    imu = read_navego_imu(data / "katwijk_imu_planetary.mat", axes=AXIS_CHOICES[axes_name])
    gnss = read_katwijk_gps(data / "katwijk_gps-latlong.txt")
    ref = read_navego_reference(data / "katwijk_gnss_planetary_r.mat")
    imu_on = motion_onset(imu.t, np.linalg.norm(imu.gyro, axis=1), imu.rate_hz)
    speed = np.hypot(ref.velocity_n[:, 0], ref.velocity_n[:, 1])
    ref_on = float(ref.t[np.argmax(speed > 0.02)])
    imu.t = imu.t - imu_on + ref_on
    return imu, gnss, ref, {"imu_onset_s": imu_on, "reference_onset_s": ref_on, "axes": axes_name}


Z_DOWN = np.diag([1.0, -1.0, -1.0])  # a 180 deg turn about x: z-down file axes to z up


def read_canada_gps(path) -> GnssRecording:
    """UTIAS GPS text: unix time (s), lat (deg), lon (deg), altitude (m); no std (configure gps_std_m)."""
    path = Path(path)
    try:
        a = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except ValueError as err:
        raise RecordingError(f"{path}: {err}") from err
    return GnssRecording(a[:, 0], a[:, 1] * DEG, a[:, 2] * DEG, a[:, 3], np.zeros((len(a), 3)), source=str(path))


def read_canada_truth_utm(path):
    """UTIAS reference ``frame;child;seq;sec;nanosec;E;N;U;qx;qy;qz;qw`` (UTM 18T, m): (t unix s, (n, 3) ENU m)."""
    return _read_canada_truth(path, slice(5, 8))


def read_canada_truth_attitude(path):
    """UTIAS reference attitude: (t unix s, (n, 4) quaternion x y z w of base_link in the UTM 'world' frame)."""
    return _read_canada_truth(path, slice(8, 12))


def _read_canada_truth(path, columns: slice):
    """(t unix s, the float ``columns`` of each row) of the UTIAS reference file."""
    path = Path(path)
    rows = []
    for line_no, line in enumerate(path.read_text().splitlines(), start=1):
        parts = line.strip().split(";")
        if len(parts) < 12:
            continue
        try:
            rows.append([int(parts[3]) + 1e-9 * int(parts[4]), *map(float, parts[columns])])
        except ValueError as err:
            raise RecordingError(f"{path}: line {line_no}: {err}") from err
    a = np.asarray(rows)
    return a[:, 0], a[:, 1:]


def _fit_plane_transform(src_xy, dst_xy):
    """Rotation + translation (2-D least squares, Kabsch) mapping ``src_xy`` onto ``dst_xy``."""
    sc, dc = src_xy.mean(axis=0), dst_xy.mean(axis=0)
    u, _, vt = np.linalg.svd((src_xy - sc).T @ (dst_xy - dc))
    rot = (u @ vt).T
    if np.linalg.det(rot) < 0:
        vt[-1] *= -1
        rot = (u @ vt).T
    return rot, dc - rot @ sc


def load_canada(axes_name="x_fwd", data=NAVEGO):
    """(imu, gnss, truth, info): times from the first GPS fix; the UTM truth mapped to geodetic through a
    rotation + translation fitted to the GPS (so its datum inherits the GPS bias; relative errors only)."""
    from nav_core.earth import LocalFrame

    imu = read_navego_imu(data / "canada_imu_planetary.mat", axes=AXIS_CHOICES[axes_name] @ Z_DOWN)
    gnss = read_canada_gps(data / "canada_gps-latlong.txt")
    t_truth, utm = read_canada_truth_utm(data / "canada_posecov_gt_data.csv")
    t0 = gnss.t[0]
    gnss.t = gnss.t - t0
    t_truth = t_truth - t0
    frame = LocalFrame(gnss.lat[0] / DEG, gnss.lon[0] / DEG, float(gnss.h[0]))
    g_enu = frame.to_enu(gnss.lat / DEG, gnss.lon / DEG, gnss.h)
    inside = (gnss.t >= t_truth[0]) & (gnss.t <= t_truth[-1])
    utm_at_g = np.column_stack([np.interp(gnss.t[inside], t_truth, utm[:, i]) for i in range(3)])
    rot, shift = _fit_plane_transform(utm_at_g[:, :2], g_enu[inside, :2])
    enu = np.column_stack([utm[:, :2] @ rot.T + shift, utm[:, 2] - np.mean(utm_at_g[:, 2] - g_enu[inside, 2])])
    lat, lon, h = frame.to_geodetic(enu)
    vel = np.gradient(enu, t_truth, axis=0)
    nan = np.full(len(t_truth), np.nan)
    truth = Trajectory(t_truth, lat * DEG, lon * DEG, h, nan, nan, nan, vel)
    # the truth starts moving; the GPS shows the start of motion: align the IMU onset to the GPS onset
    imu_on = motion_onset(imu.t, np.abs(imu.gyro[:, 2]), imu.rate_hz, factor=5.0)
    g_speed = np.hypot(*np.gradient(g_enu[:, :2], gnss.t, axis=0).T)
    k = max(int(round(gnss.t.size / (gnss.t[-1] - gnss.t[0]))), 1)  # fixes per second
    smooth = np.convolve(g_speed, np.ones(k) / k, mode="same")
    ref_on = float(gnss.t[np.argmax(smooth > 0.1)])
    imu.t = imu.t - imu_on + ref_on
    return imu, gnss, truth, {"imu_onset_s": imu_on, "reference_onset_s": ref_on, "axes": axes_name,
                              "utm_to_enu_rotation_deg": float(np.degrees(np.arctan2(rot[1, 0], rot[0, 0])))}
