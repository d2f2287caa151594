"""Screening a recording's samples before a calibration: non-finite values and exact duplicate rows.

Each finding is named by file, column, sample (index as read), line (CSV and text
files) and stamp (s). The Allan analysis (:mod:`imu_calib.timeline`) treats a
non-finite sample as a break in the record; the calibrations that average static
samples (two-position, rate table) drop it and say so; multi-position refuses it
(its static detection and gyro integration step through every sample at one rate).

An exact duplicate row (same stamp and same six values as the row before) is a
logging artefact, not a second measurement: it is dropped and counted. A repeated
stamp with different values is a real ambiguity and stays a break.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from nav_core import datasets
from nav_core.recording import IMU_TOPIC, ImuRecording, RecordingError, read_imu, refuse_topic_without_bag

COLUMNS = ("gx", "gy", "gz", "ax", "ay", "az")
"""Value columns of the recording CSV (rad/s, m/s^2)."""
ROS_FIELDS = ("angular_velocity.x", "angular_velocity.y", "angular_velocity.z",
              "linear_acceleration.x", "linear_acceleration.y", "linear_acceleration.z")
"""The same columns as fields of ``sensor_msgs/Imu`` (bags and live topics)."""
TEXT_SUFFIXES = (".txt", ".mat", ".dat")
"""Whitespace tables read by ``nav_core.datasets`` (no header row)."""


def read(path, topic: str | None = None, fmt: str = "auto", gyro_file=None) -> tuple:
    """(recording, warning lines) from a bag/CSV (``auto``) or a real text format (ucalgary, imutk, adis).

    The reader's damage (rows skipped) is a warning; so is a last line without a line end (that row is
    dropped: :func:`cut_last_line`). Fewer than 2 samples left is a RecordingError naming the file.
    """
    refuse_topic_without_bag(path, "--topic", topic)
    if gyro_file is not None and fmt != "imutk":
        raise RecordingError(f"--gyro-file {gyro_file}: only --format imutk reads a separate gyro file "
                             f"(format here: {fmt})")
    if fmt == "ucalgary":
        rec = datasets.load_ucalgary_updown(path)
    elif fmt == "adis":
        rec = datasets.load_adis_npz(path)
    elif fmt == "imutk":
        if gyro_file is None:
            raise RecordingError("--format imutk needs --gyro-file (REC is the accelerometer file)")
        rec = datasets.load_imutk(path, gyro_file)
    else:
        rec = read_imu(path, topic=topic or IMU_TOPIC)
    notes = [rec.damage] if rec.damage else []  # read on past the damage: say what was lost
    cut = cut_last_line(rec)
    if cut is not None:
        rec = rec.select(slice(0, -1))
        notes.append(f"{path}: line {cut}, the last, has no line end: the file looks cut there, so its row was "
                     f"not used (a value in it may be cut short)")
    if len(rec) < 2:
        raise RecordingError(f"{path}: {len(rec)} sample(s) (header only, or every row bad): nothing to calibrate")
    return rec, notes


def values(rec: ImuRecording) -> np.ndarray:
    """The six value columns (n, 6): gyro rad/s, then accel m/s^2."""
    return np.column_stack([rec.gyro, rec.accel])


def non_finite_rows(rec: ImuRecording, columns=range(6)) -> np.ndarray:
    """Mask (n,) of samples whose stamp or one of ``columns`` (indices into :data:`COLUMNS`) is NaN or inf."""
    cols = list(columns)
    bad = ~np.isfinite(rec.t)
    if cols:
        bad |= ~np.all(np.isfinite(values(rec)[:, cols]), axis=1)
    return bad


def exact_duplicates(rec: ImuRecording) -> np.ndarray:
    """Mask (n,) of rows equal to the row before in stamp and all six values (NaN never equals)."""
    v = values(rec)
    dup = np.zeros(len(rec), dtype=bool)
    if len(rec) > 1:
        dup[1:] = (rec.t[1:] == rec.t[:-1]) & np.all(v[1:] == v[:-1], axis=1)
    return dup


def is_bag_source(source: str) -> bool:
    """Whether ``source`` is a bag or a live topic (fields named as in sensor_msgs/Imu)."""
    path = Path(source)
    return source.startswith("live ") or path.is_dir() or path.suffix.lower() in (".db3", ".mcap")


def column_name(source: str, j: int) -> str:
    """Name of value column ``j`` as the user sees it in ``source``."""
    return f"{COLUMNS[j]} ({ROS_FIELDS[j]})" if is_bag_source(source) else COLUMNS[j]


def file_lines(rec: ImuRecording, indices) -> dict:
    """Line number (1-based) of each sample index in ``indices`` for a CSV or text source, {} otherwise.

    Scans the file as its reader did (blank lines and the rows it skipped are not samples): call it for
    a message, not per sample.
    """
    path = Path(rec.source or "")
    suffix = path.suffix.lower()
    if suffix not in (".csv", *TEXT_SUFFIXES) or not path.is_file():
        return {}
    wanted, skipped, out = set(int(i) for i in indices), set(rec.skipped_rows), {}
    sample = -1
    try:
        with open(path, newline="", errors="replace") as fh:
            rows = _csv_rows(fh) if suffix == ".csv" else _text_rows(fh)
            for line_no, blank in rows:
                if blank or line_no in skipped:
                    continue
                sample += 1
                if sample in wanted:
                    out[sample] = line_no
                    if len(out) == len(wanted):
                        break
    except OSError:
        return {}
    return out


def _csv_rows(fh):
    reader = csv.reader(fh)
    next(reader, None)  # header
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error:
            yield reader.line_num, False  # the reader counted it as skipped
            continue
        yield reader.line_num, not row or all(not c.strip() for c in row)


def _text_rows(fh):
    for line_no, line in enumerate(fh, start=1):
        yield line_no, not line.split("#", 1)[0].strip()


def cut_last_line(rec: ImuRecording) -> int | None:
    """Line number of a CSV or text source's last line when it has no line end yet gave the last sample.

    Writers end every line; a last line without one is where the file was cut, and a number cut short
    there ("9.81" -> "9.") still parses: that sample cannot be trusted. None when the file ends cleanly.
    """
    path = Path(rec.source or "")
    if path.suffix.lower() not in (".csv", *TEXT_SUFFIXES) or not path.is_file() or not len(rec):
        return None
    with open(path, "rb") as fh:
        size = fh.seek(0, 2)
        fh.seek(max(0, size - 65536))
        tail = fh.read()
        if not tail or tail[-1:] in (b"\n", b"\r"):
            return None
        last = tail.rsplit(b"\n", 1)[-1].split(b"#", 1)[0]
        fh.seek(0)
        line_no = 1 + sum(chunk.count(b"\n") for chunk in iter(lambda: fh.read(1 << 20), b""))
    if not last.strip() or line_no in rec.skipped_rows or (path.suffix.lower() == ".csv" and line_no == 1):
        return None  # blank, already skipped by the reader, or the header
    return line_no


def stamp_text(t: float) -> str:
    """A stamp (s) for a message: 6 significant digits, or ms resolution for epoch stamps."""
    return f"{t:.3f}" if np.isfinite(t) and abs(t) >= 1e5 else f"{t:.6g}"


def where(rec: ImuRecording, i: int, lines: dict | None = None) -> str:
    """``sample i (line L, t = x s)`` for sample ``i`` of ``rec`` (the line when the file has lines)."""
    lines = file_lines(rec, [i]) if lines is None else lines
    line = f"line {lines[i]}, " if i in lines else ""
    t = rec.t[i]
    if not np.isfinite(t):
        before = rec.t[:i][np.isfinite(rec.t[:i])]
        when = f"t = {t}" + (f" after {stamp_text(before[-1])} s" if len(before) else "")
    else:
        when = f"t = {stamp_text(t)} s"
    return f"sample {i} ({line}{when})"


def describe_non_finite(rec: ImuRecording, bad: np.ndarray, columns=range(6), named: bool = True) -> str:
    """``file: N sample(s) with a NaN or infinite value (column counts), first at sample i (line, t)``
    (without ``file: `` when not ``named``)."""
    source = rec.source or "recording"
    idx = np.flatnonzero(bad)
    counts = []
    n_t = int(np.sum(~np.isfinite(rec.t[idx])))
    if n_t:
        counts.append(f"t {n_t}")
    v = values(rec)[idx]
    for j in columns:
        k = int(np.sum(~np.isfinite(v[:, j])))
        if k:
            counts.append(f"{column_name(source, j)} {k}")
    return (f"{source}: " if named else "") + (f"{len(idx)} sample(s) with a NaN or infinite value (by column: "
                                               f"{', '.join(counts)}), first at {where(rec, int(idx[0]))}")


def describe_duplicates(rec: ImuRecording, dup: np.ndarray) -> str:
    """``file: dropped N exact duplicate row(s) ..., first at sample i (line, t)``."""
    idx = np.flatnonzero(dup)
    return (f"{rec.source or 'recording'}: dropped {len(idx)} exact duplicate row(s) (same stamp and values as "
            f"the row before: a logging artefact, not a second measurement), first at {where(rec, int(idx[0]))}")


def for_means(rec: ImuRecording, columns) -> tuple:
    """(recording without non-finite samples in ``columns`` nor exact duplicates, warning lines) for the
    calibrations that average static samples; RecordingError naming the file if nothing is left."""
    bad = non_finite_rows(rec, columns)
    dup = exact_duplicates(rec)
    notes = []
    if bad.any():
        notes.append(describe_non_finite(rec, bad, columns) + "; those samples were left out of the means")
    if dup.any():
        notes.append(describe_duplicates(rec, dup))
    if not notes:
        return rec, notes
    keep = ~bad & ~dup
    if keep.sum() < 2:
        raise RecordingError(f"{rec.source or 'recording'}: fewer than 2 usable samples "
                             f"({int(bad.sum())} of {len(rec)} have a NaN or infinite value)")
    return drop(rec, ~keep), notes


def drop(rec: ImuRecording, gone: np.ndarray) -> ImuRecording:
    """``rec`` without the samples of mask ``gone``; their lines join ``skipped_rows``, so later messages
    still name the file's lines."""
    out = rec.select(~gone)
    lines = file_lines(rec, np.flatnonzero(gone))
    if lines:
        out.skipped_rows = tuple(sorted(set(rec.skipped_rows) | set(lines.values())))
    return out


def refuse_non_finite(rec: ImuRecording, why: str) -> tuple:
    """(recording without exact duplicates, warning lines); RecordingError naming the first non-finite sample."""
    bad = non_finite_rows(rec)
    if bad.any():
        raise RecordingError(describe_non_finite(rec, bad) + f"; {why}")
    dup = exact_duplicates(rec)
    if not dup.any():
        return rec, []
    return drop(rec, dup), [describe_duplicates(rec, dup)]
