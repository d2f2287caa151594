"""Readers for the public recordings in ``../shared/data`` that are not in the project's own formats.

The home of the external-format loaders several packages share; each returns nav_core recording
types in SI units (unless it says it keeps raw counts):

* UCalgary ADI two-position text, imu_tk multi-position text, ADIS16405 static ``.npz``;
* the balzer82/Kalman car CSV (IMU and its GPS columns).

The NaveGo planetary-rover readers live where they are used, in :mod:`nav_eval.rovers`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nav_core.recording import GnssRecording, ImuRecording, RecordingError
from nav_core.units import DEG, G0


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
