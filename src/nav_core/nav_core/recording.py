"""Recording IO: rosbag2 bags (sqlite3, MCAP) and the project's CSV files to NumPy and back.

Longer than 500 lines because it is the one home of the recording types and of every reader and writer of them.

The one reader and writer every tool uses. Arrays are SI: time in s, angular
rate in rad/s, specific force in m/s^2, latitude/longitude in rad inside (the
CSV files and ``NavSatFix`` carry degrees; conversion happens here).

A damaged bag or CSV loses only what was damaged: the good part is returned and
``damage`` names the file, the position (byte range, row) and what was lost; pass
``strict=True`` to raise :class:`RecordingError` instead. MCAP files are read past
the damage (every intact message; see :mod:`nav_core.mcap_scan`), a cut sqlite file
up to it. A malformed CSV row is skipped and counted (``skipped_rows``, ``damage``);
a file with more than :data:`MAX_BAD_ROW_FRACTION` of its rows bad is refused.
:func:`check_timestamps` finds time going backwards, duplicate stamps and gaps for
any tool to act on.
"""
from __future__ import annotations

import csv
import logging
import math
from array import array
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nav_core import timestamps
from nav_core import table_rows, units
from nav_core.table_rows import numbers
from nav_core.timestamps import TimeCheck  # noqa: F401  (part of this module's API)
from nav_core.units import DEG

LOG = logging.getLogger(__name__)

IMU_TOPIC = "imu/data_raw"
GNSS_TOPIC = "gps/fix"
TEMP_TOPIC = "imu/temperature"
WHEEL_TOPIC = "odom/wheel"
WHEEL_CSV_COLUMNS = ("t", "speed_mps")
IMU_CSV_COLUMNS = ("t", "gx", "gy", "gz", "ax", "ay", "az")
GNSS_CSV_COLUMNS = ("t", "lat_deg", "lon_deg", "h_m", "std_e", "std_n", "std_u")
TRUTH_CSV_COLUMNS = ("t", "lat_deg", "lon_deg", "h_m", "roll_deg", "pitch_deg", "yaw_deg")
VELOCITY_COLUMNS = ("ve", "vn", "vu")


class RecordingError(ValueError):
    """A recording cannot be read; the message names the file and the position."""


def check_timestamps(t, source: str = "recording", max_gap_s: float | None = None,
                     gap_factor: float = timestamps.DEFAULT_GAP_FACTOR) -> TimeCheck:
    """Time going backwards, duplicate stamps, gaps (> ``max_gap_s`` s, default ``gap_factor`` x the median
    interval) and non-finite times of ``t`` (s), each named; ``raise_if`` raises :class:`RecordingError`."""
    return timestamps.check_timestamps(t, source, max_gap_s, gap_factor, error=RecordingError)


@dataclass
class ImuRecording:
    """IMU samples: ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2, optional ``temp_c`` (n,)."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    temp_c: np.ndarray | None = None
    source: str = ""
    frame_id: str = "imu_link"
    damage: str | None = None
    """What was lost reading the file (file, byte offset or lines), None when nothing was."""
    skipped_rows: tuple = ()
    """Line numbers of CSV rows that were skipped as malformed (counted in ``damage``)."""

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float).reshape(-1)
        self.gyro = np.asarray(self.gyro, dtype=float).reshape(-1, 3)
        self.accel = np.asarray(self.accel, dtype=float).reshape(-1, 3)
        n = len(self.t)
        if self.gyro.shape[0] != n or self.accel.shape[0] != n:
            raise RecordingError(f"{self.source or 'recording'}: t, gyro and accel lengths differ "
                                 f"({n}, {self.gyro.shape[0]}, {self.accel.shape[0]})")
        if self.temp_c is not None:
            self.temp_c = np.asarray(self.temp_c, dtype=float).reshape(-1)
            if len(self.temp_c) != n:
                raise RecordingError(f"{self.source or 'recording'}: temp_c length {len(self.temp_c)} != {n}")

    def __len__(self):
        return len(self.t)

    @property
    def rate_hz(self) -> float:
        """Nominal sample rate from the median sample interval, Hz."""
        if len(self.t) < 2:
            raise RecordingError(f"{self.source or 'recording'}: fewer than 2 samples, no rate")
        return float(1.0 / np.median(np.diff(self.t)))

    def select(self, mask_or_slice) -> ImuRecording:
        """A new recording with the samples picked by a boolean mask or slice."""
        return ImuRecording(self.t[mask_or_slice], self.gyro[mask_or_slice], self.accel[mask_or_slice],
                            None if self.temp_c is None else self.temp_c[mask_or_slice],
                            self.source, self.frame_id, self.damage, self.skipped_rows)

    def between(self, t0: float, t1: float) -> ImuRecording:
        """Samples with ``t0 <= t < t1`` (s)."""
        return self.select((self.t >= t0) & (self.t < t1))


@dataclass
class GnssRecording:
    """GNSS fixes: ``t`` (n,) s, ``lat``/``lon`` (n,) rad, ``h`` (n,) m, ``std_enu`` (n, 3) m, ``status`` (n,).

    ``status`` follows ``sensor_msgs/NavSatStatus`` (-1 no fix, 0 fix, 1 SBAS, 2 GBAS).
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    std_enu: np.ndarray
    status: np.ndarray = None
    source: str = ""
    damage: str | None = None
    """What was lost reading the file (file, byte offset or lines), None when nothing was."""
    skipped_rows: tuple = ()
    """Line numbers of CSV rows that were skipped as malformed (counted in ``damage``)."""

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float).reshape(-1)
        self.lat = np.asarray(self.lat, dtype=float).reshape(-1)
        self.lon = np.asarray(self.lon, dtype=float).reshape(-1)
        self.h = np.asarray(self.h, dtype=float).reshape(-1)
        self.std_enu = np.asarray(self.std_enu, dtype=float).reshape(-1, 3)
        if self.status is None:
            self.status = np.zeros(len(self.t), dtype=int)
        self.status = np.asarray(self.status, dtype=int).reshape(-1)

    def __len__(self):
        return len(self.t)

    def select(self, mask_or_slice) -> GnssRecording:
        """A new recording with the fixes picked by a boolean mask, index array or slice."""
        m = mask_or_slice
        return GnssRecording(self.t[m], self.lat[m], self.lon[m], self.h[m], self.std_enu[m], self.status[m],
                             self.source, self.damage, self.skipped_rows)


@dataclass
class Trajectory:
    """Truth trajectory: ``t`` s, ``lat``/``lon`` rad, ``h`` m, ``roll``/``pitch``/``yaw`` rad (body-to-ENU),
    optional ``velocity_n`` (n, 3) m/s in ENU."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    velocity_n: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    """Extra named columns (n,) written after the standard ones."""
    damage: str | None = None
    """Rows skipped reading the file, None when none were."""

    def __len__(self):
        return len(self.t)


# ----------------------------------------------------------------------------- CSV


MAX_BAD_ROW_FRACTION = 0.01
"""A CSV with more bad rows than this fraction is refused: its data cannot be trusted."""


def _read_csv_table(path: Path, required, strict: bool, max_bad_fraction: float = MAX_BAD_ROW_FRACTION):
    """Columns by header name as float arrays, the damage text, the skipped line numbers and the line number
    of each kept row (blank lines are neither).

    A malformed row (wrong field count, a field that is not a number, a non-finite time)
    is skipped and counted; ``strict`` raises at the first, and more than
    ``max_bad_fraction`` of the rows bad raises too.
    """
    bad = []  # (line number, reason)
    with open(path, newline="", errors="replace") as fh:  # undecodable bytes fail as numbers: a bad row
        reader = csv.reader(fh)
        try:
            header = table_rows.header_names(next(reader))
        except StopIteration:
            raise RecordingError(f"{path}: empty file, expected a header row") from None
        except (csv.Error, UnicodeDecodeError) as err:
            raise RecordingError(f"{path}: line 1: unreadable header ({err})") from None
        missing = [c for c in required if c not in header]
        if missing:
            raise RecordingError(f"{path}: missing column(s) {missing}{table_rows.missing_hint(missing, header)}; "
                                 f"header is {header}")
        rows, lines = array("d"), array("q")  # flat: a 2-h 64-Hz IMU CSV held as lists of floats took 213 MB
        line_no = 1
        while True:
            try:
                row = next(reader)
            except StopIteration:
                break
            except csv.Error as err:
                line_no = reader.line_num
                bad.append((line_no, str(err)))
                if strict:
                    raise RecordingError(f"{path}: line {line_no}: {err}") from None
                continue
            line_no = reader.line_num
            if not row or all(not c.strip() for c in row):
                continue
            try:
                if len(row) != len(header):
                    raise ValueError(f"{len(row)} fields, header has {len(header)}")
                values = numbers(row, header)  # a bad field is named by its column
                if not math.isfinite(values[header.index("t")] if "t" in header else 0.0):
                    raise ValueError("time t is not finite")
                rows.extend(values)
                lines.append(line_no)
            except ValueError as err:
                if strict:
                    raise RecordingError(f"{path}: line {line_no}: {err}") from err
                bad.append((line_no, str(err)))
    damage = _csv_damage(path, bad, len(lines), max_bad_fraction)
    data = np.frombuffer(rows, dtype=float).reshape(-1, len(header))
    # one contiguous copy per column: a view of the whole table would keep every column alive (a 2-h 64-Hz
    # IMU CSV held 45 MB for its 26 MB of t, gyro and accel)
    return ({name: data[:, i].copy() for i, name in enumerate(header)}, damage, tuple(n for n, _ in bad),
            np.frombuffer(lines, dtype=np.int64).copy())


def _csv_damage(path: Path, bad: list, good: int, max_bad_fraction: float):
    """The damage text for skipped rows (None without); RecordingError when too many rows are bad."""
    if not bad:
        return None
    shown = ", ".join(f"line {n}: {why}" for n, why in bad[:3]) + (" ..." if len(bad) > 3 else "")
    text = f"{path}: skipped {len(bad)} bad row(s) of {len(bad) + good} ({shown})"
    if len(bad) > 1 and len(bad) > max_bad_fraction * (len(bad) + good):
        raise RecordingError(f"{text}: more than {max_bad_fraction:.0%} of the rows are bad, "
                             f"so the file is not used")
    LOG.warning("%s", text)
    return text


def _write_csv(path: Path, columns: dict) -> Path:
    import os
    import tempfile

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.partial-", dir=path.parent)  # never a half-written file
    try:
        with os.fdopen(fd, "w") as fh:
            np.savetxt(fh, data, delimiter=",", header=",".join(names), comments="", fmt="%.15g")  # 15 digits: sub-mm
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_imu_csv(path, strict: bool = False) -> ImuRecording:
    """Read the recording CSV (``t, gx, gy, gz, ax, ay, az[, temp_c]``, SI units)."""
    path = Path(path)
    cols, damage, skipped, _ = _read_csv_table(path, IMU_CSV_COLUMNS, strict)
    return ImuRecording(cols["t"], np.column_stack([cols["gx"], cols["gy"], cols["gz"]]),
                        np.column_stack([cols["ax"], cols["ay"], cols["az"]]), cols.get("temp_c"),
                        source=str(path), damage=damage, skipped_rows=skipped)


def write_imu_csv(path, rec: ImuRecording) -> Path:
    """Write the recording CSV (SI units), with ``temp_c`` when present."""
    cols = {"t": rec.t}
    cols.update({k: rec.gyro[:, i] for i, k in enumerate(("gx", "gy", "gz"))})
    cols.update({k: rec.accel[:, i] for i, k in enumerate(("ax", "ay", "az"))})
    if rec.temp_c is not None:
        cols["temp_c"] = rec.temp_c
    return _write_csv(path, cols)


def read_gnss_csv(path, strict: bool = False) -> GnssRecording:
    """Read the GNSS CSV (``t, lat_deg, lon_deg, h_m, std_e, std_n, std_u[, status]``)."""
    path = Path(path)
    cols, damage, skipped, _ = _read_csv_table(path, GNSS_CSV_COLUMNS, strict)
    status, bad_status = table_rows.status_column(cols.get("status"), cols["t"], str(path))
    return GnssRecording(cols["t"], cols["lat_deg"] * DEG, cols["lon_deg"] * DEG, cols["h_m"],
                         np.column_stack([cols["std_e"], cols["std_n"], cols["std_u"]]), status, source=str(path),
                         damage="; ".join(d for d in (damage, bad_status) if d) or None, skipped_rows=skipped)


def write_gnss_csv(path, gnss: GnssRecording) -> Path:
    """Write the GNSS CSV (degrees at this edge) with a ``status`` column."""
    return _write_csv(path, {"t": gnss.t, "lat_deg": gnss.lat / DEG, "lon_deg": gnss.lon / DEG, "h_m": gnss.h,
                             "std_e": gnss.std_enu[:, 0], "std_n": gnss.std_enu[:, 1],
                             "std_u": gnss.std_enu[:, 2], "status": gnss.status})


def read_trajectory_csv(path, strict: bool = False) -> Trajectory:
    """Read the truth trajectory CSV (degrees in the file, rad in the result)."""
    path = Path(path)
    cols, damage, _, _ = _read_csv_table(path, TRUTH_CSV_COLUMNS, strict)
    vel = None
    if all(c in cols for c in VELOCITY_COLUMNS):
        vel = np.column_stack([cols[c] for c in VELOCITY_COLUMNS])
    known = set(TRUTH_CSV_COLUMNS) | set(VELOCITY_COLUMNS)
    return Trajectory(cols["t"], cols["lat_deg"] * DEG, cols["lon_deg"] * DEG, cols["h_m"],
                      cols["roll_deg"] * DEG, cols["pitch_deg"] * DEG, cols["yaw_deg"] * DEG, vel,
                      {k: v for k, v in cols.items() if k not in known}, damage)


def write_trajectory_csv(path, traj: Trajectory) -> Path:
    """Write the truth trajectory CSV (degrees at this edge), velocity and extra columns when present."""
    cols = {"t": traj.t, "lat_deg": traj.lat / DEG, "lon_deg": traj.lon / DEG, "h_m": traj.h,
            "roll_deg": traj.roll / DEG, "pitch_deg": traj.pitch / DEG, "yaw_deg": traj.yaw / DEG}
    if traj.velocity_n is not None:
        cols.update({k: traj.velocity_n[:, i] for i, k in enumerate(VELOCITY_COLUMNS)})
    cols.update(traj.extra)
    return _write_csv(path, cols)


# ----------------------------------------------------------------------------- rosbag2


def _no_topic(path, topic: str, damage) -> RecordingError:
    """The error for a bag without messages on ``topic``: names the topics it has, and its damage."""
    from nav_core import bagio

    present = sorted(bagio.topics(path))
    where = f"; the bag is damaged: {damage}" if damage else ""
    return RecordingError(f"{path}: no messages on topic {topic!r}; topics present: {present or 'none'}{where}")


def _damage_or_raise(err, strict: bool):
    if strict:
        raise RecordingError(str(err)) from err
    LOG.warning("%s", err)
    return str(err)


def read_imu_bag(path, topic: str = IMU_TOPIC, temp_topic: str = TEMP_TOPIC, strict: bool = False) -> ImuRecording:
    """IMU samples of ``topic`` (header stamps) and temperature of ``temp_topic`` (interpolated) from a bag.

    The Imu messages are decoded as one batch (:mod:`nav_core.imu_cdr`) rather than one message
    object each (1 h at 64 Hz: 2.0 s instead of 5-6 s at load 13); one that does not decode is
    skipped and counted in ``damage``.
    """
    from nav_core import bagio

    path, want = Path(path), bagio.norm_topic(topic)
    blobs, temp_t, temp, damage = [], [], [], None
    try:
        for top, mtype, _, raw in bagio.iter_raw(path, [topic, temp_topic]):
            if top == want:
                blobs.append(raw)
                continue
            try:
                msg = bagio.TYPESTORE.deserialize_cdr(raw, mtype)
                temp_t.append(bagio.stamp_to_s(msg.header.stamp))
                temp.append(float(msg.temperature))
            except Exception:  # a damaged temperature message: the others interpolate over it
                continue
    except bagio.BagDamage as err:
        damage = _damage_or_raise(err, strict)
    batch, bad = _decode_imu_blobs(blobs)
    if bad:
        text = f"{path}: {bad} of {len(blobs)} message(s) on {want} could not be decoded as sensor_msgs/Imu"
        damage = _damage_or_raise(RecordingError(text), strict) if damage is None else f"{damage}; {text}"
    if not len(batch):
        raise _no_topic(path, topic, damage)
    t = batch.t_s
    temp_c = np.interp(t, temp_t, temp) if temp_t else None
    return ImuRecording(t, batch.gyro, batch.accel, temp_c, source=str(path), frame_id=batch.frame_ids[-1],
                        damage=damage)


def _decode_imu_blobs(blobs: list):
    """(ImuBatch of the decodable messages, count of those that are not)."""
    from nav_core.imu_cdr import ImuCdrError, decode_imu

    try:
        return decode_imu(blobs), 0
    except ImuCdrError:  # find the bad ones one by one (only on damage or a wrong message type)
        good = []
        for blob in blobs:
            try:
                decode_imu([blob])
                good.append(blob)
            except ImuCdrError:
                continue
        return decode_imu(good), len(blobs) - len(good)


def read_gnss_bag(path, topic: str = GNSS_TOPIC, strict: bool = False) -> GnssRecording:
    """``NavSatFix`` messages of ``topic`` from a bag (NaN fixes kept, status as published)."""
    from nav_core import bagio

    path = Path(path)
    rows, status, damage = [], [], None
    try:
        for _, _, msg in bagio.iter_messages(path, [topic]):
            cov = np.asarray(msg.position_covariance, dtype=float).reshape(3, 3)
            rows.append((bagio.stamp_to_s(msg.header.stamp), msg.latitude, msg.longitude, msg.altitude,
                         *np.sqrt(np.clip(np.diag(cov), 0.0, None))))
            status.append(msg.status.status)
    except bagio.BagDamage as err:
        damage = _damage_or_raise(err, strict)
    if not rows:
        raise _no_topic(path, topic, damage)
    a = np.asarray(rows, dtype=float).reshape(-1, 7)
    return GnssRecording(a[:, 0], a[:, 1] * DEG, a[:, 2] * DEG, a[:, 3], a[:, 4:7], np.asarray(status, int),
                         source=str(path), damage=damage)


def write_bag(path, imu: ImuRecording | None = None, gnss: GnssRecording | None = None, storage: str = "sqlite3",
              imu_topic: str = IMU_TOPIC, gnss_topic: str = GNSS_TOPIC, temp_topic: str = TEMP_TOPIC,
              gyro_std: float = 0.0, accel_std: float = 0.0, wheel: WheelSpeedRecording | None = None,
              wheel_topic: str = WHEEL_TOPIC, wheel_type: str = "nav_msgs/msg/Odometry") -> Path:
    """Write IMU (and temperature), GNSS and wheel-speed recordings to a new rosbag2 bag, messages in stamp order
    (wheel speeds in their recorded order: one stamped back stays where it was, as a live odometer sends it);
    ``wheel_type`` is ``nav_msgs/msg/Odometry`` or ``geometry_msgs/msg/TwistStamped`` (the speed in
    ``twist.linear.x``)."""
    from nav_core import bagio

    events = []
    for rec, kind in ((imu, 0), (gnss, 1)):
        if rec is not None:
            events += [(float(rec.t[i]), kind, i) for i in range(len(rec))]
    if wheel is not None and len(wheel):
        place = np.maximum.accumulate(np.where(np.isfinite(wheel.t), wheel.t, -np.inf))
        events += [(float(place[i]), 2, i) for i in range(len(wheel))]
    events.sort()
    with bagio.BagWriter(path, storage) as bag:
        if wheel is not None:
            bag.add_topic(wheel_topic, wheel_type, bagio.default_qos(wheel_topic, wheel_type, sensor=True))
        for place, kind, i in events:
            ns = units.ns_from_s(place)
            if kind == 0:
                bag.write(imu_topic, ns, bagio.imu_message(imu.t[i], imu.gyro[i], imu.accel[i], imu.frame_id,
                                                           gyro_std**2, accel_std**2))
                if imu.temp_c is not None:
                    bag.write(temp_topic, ns, bagio.temperature_message(imu.t[i], imu.temp_c[i], imu.frame_id))
            elif kind == 1:
                bag.write(gnss_topic, ns, bagio.navsatfix_message(
                    gnss.t[i], gnss.lat[i] / DEG, gnss.lon[i] / DEG, gnss.h[i], gnss.std_enu[i], gnss.status[i]))
            else:
                bag.write(wheel_topic, ns, bagio.wheel_speed_message(wheel.t[i], wheel.speed_mps[i], wheel_type))
    return Path(path)


@dataclass
class WheelSpeedRecording:
    """Wheel odometer: ``t`` (n,) s, forward speed ``speed_mps`` (n,) m/s, in the order recorded. A stamp or speed
    that was not a number is kept as NaN (the filter names and counts it), ``damage`` says where the first was."""

    t: np.ndarray
    speed_mps: np.ndarray
    source: str = ""
    damage: str | None = None

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float).reshape(-1)
        self.speed_mps = np.asarray(self.speed_mps, dtype=float).reshape(-1)

    def __len__(self):
        return len(self.t)


def read_wheel_speed_csv(path, strict: bool = False) -> WheelSpeedRecording:
    """Wheel speeds from a CSV with columns ``t,speed_mps`` (s, m/s forward). Unlike the other CSVs, a field that
    is not a number is read as NaN rather than its row skipped, so the filter counts it (``odometer_nonfinite``);
    ``damage`` names the first such line and column (``strict``: RecordingError instead)."""
    path = Path(path)
    with open(path, newline="", errors="replace") as fh:
        reader = csv.reader(fh)
        header = [h.strip() for h in next(reader, [])]
        if any(c not in header for c in WHEEL_CSV_COLUMNS):
            raise RecordingError(f"{path}: header {header}: expected columns t,speed_mps (s, m/s)")
        cols = [header.index(c) for c in WHEEL_CSV_COLUMNS]
        rows, damage = [], None
        for line, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            vals = []
            for i, name in zip(cols, WHEEL_CSV_COLUMNS):
                try:
                    vals.append(float(row[i]))
                except (ValueError, IndexError):
                    vals.append(np.nan)
                    damage = damage or (f"{path}: line {line}, column {name}: {row[i] if i < len(row) else ''!r} "
                                        "is not a number (read as NaN, counted as odometer_nonfinite)")
                    if strict:
                        raise RecordingError(damage)
            rows.append(vals)
    a = np.asarray(rows, dtype=float).reshape(-1, 2)
    return WheelSpeedRecording(a[:, 0], a[:, 1], str(path), damage)


def write_wheel_speed_csv(path, wheel: WheelSpeedRecording) -> Path:
    """Write the wheel-speed CSV (``t,speed_mps``)."""
    return _write_csv(path, {"t": wheel.t, "speed_mps": wheel.speed_mps})


def read_wheel_speed_bag(path, topic: str = WHEEL_TOPIC, strict: bool = False) -> WheelSpeedRecording:
    """Forward speeds (``twist.twist.linear.x`` of ``nav_msgs/Odometry``, ``twist.linear.x`` of
    ``geometry_msgs/TwistStamped``) and header stamps of ``topic`` in a bag, in the order recorded."""
    from nav_core import bagio

    path = Path(path)
    rows, damage = [], None
    try:
        for _, _, msg in bagio.iter_messages(path, [topic]):
            rows.append((bagio.stamp_to_s(msg.header.stamp), bagio.forward_speed(msg)))
    except bagio.BagDamage as err:
        damage = _damage_or_raise(err, strict)
    except bagio.NotWheelSpeed as err:
        raise RecordingError(f"{path}: topic {topic!r}: {err}") from None
    if not rows:
        raise _no_topic(path, topic, damage)
    a = np.asarray(rows, dtype=float).reshape(-1, 2)
    return WheelSpeedRecording(a[:, 0], a[:, 1], str(path), damage)


@dataclass
class OdometryRecording:
    """``nav_msgs/Odometry``: ``t`` s, ``position`` (n, 3) m in the pose frame, ``quat_xyzw`` (n, 4),
    ``velocity_body`` (n, 3) m/s in the child frame, ``pose_std`` (n, 6) and ``twist_std`` (n, 6)
    (sqrt of the covariance diagonals: m and rad, m/s and rad/s)."""

    t: np.ndarray
    position: np.ndarray
    quat_xyzw: np.ndarray
    velocity_body: np.ndarray
    pose_std: np.ndarray
    twist_std: np.ndarray
    frame_id: str = "odom"
    child_frame_id: str = "base_link"
    source: str = ""
    damage: str | None = None

    def __len__(self):
        return len(self.t)


def read_odometry(path, topic: str = "odometry/filtered", strict: bool = False) -> OdometryRecording:
    """``nav_msgs/Odometry`` messages of ``topic`` from a bag."""
    from nav_core import bagio

    path = Path(path)
    rows, frames, damage = [], ("odom", "base_link"), None
    try:
        for _, _, msg in bagio.iter_messages(path, [topic]):
            pose, twist = msg.pose.pose, msg.twist.twist
            rows.append([bagio.stamp_to_s(msg.header.stamp), pose.position.x, pose.position.y, pose.position.z,
                         pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w,
                         twist.linear.x, twist.linear.y, twist.linear.z,
                         *np.sqrt(np.clip(np.diag(np.reshape(msg.pose.covariance, (6, 6))), 0, None)),
                         *np.sqrt(np.clip(np.diag(np.reshape(msg.twist.covariance, (6, 6))), 0, None))])
            frames = (msg.header.frame_id, msg.child_frame_id)
    except bagio.BagDamage as err:
        damage = _damage_or_raise(err, strict)
    if not rows:
        raise _no_topic(path, topic, damage)
    a = np.asarray(rows, dtype=float).reshape(-1, 23)
    return OdometryRecording(a[:, 0], a[:, 1:4], a[:, 4:8], a[:, 8:11], a[:, 11:17], a[:, 17:23],
                             frames[0], frames[1], str(path), damage)


# ----------------------------------------------------------------------------- dispatch


def _read_any(path, what: str, bag_reader, csv_reader, **kwargs):
    """Dispatch on the kind of file: a rosbag2 bag (folder, .db3, .mcap) or a .csv."""
    from nav_core import bagio

    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: {what} not found")
    if bagio.is_bag(path):
        return bag_reader(path, **kwargs)
    if path.suffix.lower() == ".csv":
        return csv_reader(path, strict=kwargs["strict"])
    raise RecordingError(f"{path}: not a rosbag2 bag (folder with metadata.yaml, .db3, .mcap) or a .csv")


def refuse_topic_without_bag(path, option: str, topic) -> None:
    """RecordingError when ``option`` (a topic given on the command line, None if not given) names a topic for a
    ``path`` that is not a rosbag2 bag: a CSV or text file has no topics, so the option would be silently ignored."""
    from nav_core import bagio

    if topic is not None and Path(path).exists() and not bagio.is_bag(path):
        raise RecordingError(f"{path}: {option} {topic}: not a rosbag2 bag, so it has no topics (the option selects "
                             "a topic in a bag); drop the option, or give the bag")


def read_imu(path, topic: str = IMU_TOPIC, strict: bool = False) -> ImuRecording:
    """Read IMU samples from a rosbag2 bag (folder, .db3, .mcap) or the recording CSV."""
    return _read_any(path, "recording", read_imu_bag, read_imu_csv, topic=topic, strict=strict)


def read_gnss(path, topic: str = GNSS_TOPIC, strict: bool = False) -> GnssRecording:
    """Read GNSS fixes from a rosbag2 bag or the GNSS CSV."""
    return _read_any(path, "GNSS recording", read_gnss_bag, read_gnss_csv, topic=topic, strict=strict)


def read_wheel_speed(path, topic: str = WHEEL_TOPIC, strict: bool = False) -> WheelSpeedRecording:
    """Read wheel speeds from a rosbag2 bag (``topic``) or the wheel-speed CSV (``t,speed_mps``)."""
    return _read_any(path, "wheel-speed recording", read_wheel_speed_bag, read_wheel_speed_csv, topic=topic,
                     strict=strict)
