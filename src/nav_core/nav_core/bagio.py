"""rosbag2 reading and writing with ``rosbags`` (sqlite3 and MCAP), in the format ``ros2 bag`` reads.

Message objects here are ``rosbags`` dataclasses (no rclpy needed). Topic
names are compared without the leading slash. Use :mod:`nav_core.recording`
for whole recordings; this module holds the bag plumbing.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore

from nav_core import units

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
IMU_TYPE = "sensor_msgs/msg/Imu"
NAVSATFIX_TYPE = "sensor_msgs/msg/NavSatFix"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"
SENSOR_TYPES = frozenset({IMU_TYPE, NAVSATFIX_TYPE, TEMPERATURE_TYPE})  # published with the sensor-data QoS
STORAGES = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}


class BagDamage(Exception):
    """Reading stopped at damage; the message names the file and where, ``count`` how many messages were good."""

    def __init__(self, message: str, count: int):
        super().__init__(message)
        self.count = count


def norm_topic(topic: str) -> str:
    """Topic name without its leading slash."""
    return topic.lstrip("/")


def is_bag(path) -> bool:
    """Whether ``path`` is a rosbag2 folder or a bare .db3/.mcap storage file."""
    p = Path(path)
    return (p.is_dir() and (p / "metadata.yaml").exists()) or (p.is_file() and p.suffix in (".db3", ".mcap"))


def stamp_to_s(stamp) -> float:
    """``builtin_interfaces/Time`` to float seconds."""
    return units.s_from_sec_nanosec(stamp.sec, stamp.nanosec)


def s_to_stamp(t_s: float):
    """Float seconds to a rosbags ``builtin_interfaces/Time``."""
    time_cls = TYPESTORE.types["builtin_interfaces/msg/Time"]
    sec, nanosec = units.sec_nanosec(units.ns_from_s(t_s))
    return time_cls(sec=sec, nanosec=nanosec)


def topics(path) -> dict:
    """Topic name (no slash) -> message type of a bag."""
    try:
        with Reader(Path(path)) as reader:
            return {norm_topic(c.topic): c.msgtype for c in reader.connections}
    except FileNotFoundError:
        raise
    except Exception:  # damaged: list the topics of the messages that can be read, else metadata.yaml's
        found = {}
        try:
            for topic, msgtype, _, _ in iter_raw(Path(path), None):
                found.setdefault(topic, msgtype)
        except BagDamage:
            pass
        return found or _metadata_topics(Path(path))


def offered_qos(path) -> dict:
    """Topic name (no slash) -> the QoS its publishers offered when recorded (rosbags ``Qos`` list; empty when
    the bag does not say, or its metadata cannot be read)."""
    try:
        with Reader(Path(path)) as reader:
            return {norm_topic(c.topic): list(c.ext.offered_qos_profiles) for c in reader.connections}
    except Exception:  # a damaged bag plays with the default QoS
        return {}


def _metadata_topics(path: Path) -> dict:
    """Topic -> type as listed in a bag folder's metadata.yaml (empty when there is none or it is unreadable)."""
    import yaml

    try:
        info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        return {norm_topic(t["topic_metadata"]["name"]): t["topic_metadata"]["type"]
                for t in info["topics_with_message_count"]}
    except Exception:  # any problem: no list rather than a second error
        return {}


def iter_raw(path, wanted_topics=None):
    """Yield ``(topic, msgtype, log_time_ns, cdr_bytes)`` for the wanted topics (all if None).

    MCAP files are read by :mod:`nav_core.mcap_scan` in storage order, past any damage
    (every intact message is yielded). A healthy sqlite3 bag is read with rosbags in
    log-time order; one rosbags cannot open (a cut file) is read row by row up to the
    damage. Either way, damage raises :class:`BagDamage` after everything good was
    yielded; its message names the file, the byte offsets or row and what was lost.
    """
    path = Path(path)
    wanted = None if wanted_topics is None else {norm_topic(t) for t in wanted_topics}
    if not path.exists():
        raise BagDamage(f"{path}: not found", 0)
    storages = _storage_files(path)
    if all(s.suffix == ".mcap" for s in storages):
        yield from _iter_mcap(storages, wanted)
        return
    count = 0
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:  # rosbags refuses damaged storage at open: recover what is there
        yield from _recover(path, wanted, err)
        return
    try:
        conns = [c for c in reader.connections if wanted is None or norm_topic(c.topic) in wanted]
        if not conns:
            return  # rosbags reads every connection when given none
        for conn, log_ns, raw in reader.messages(connections=conns):
            count += 1
            yield norm_topic(conn.topic), conn.msgtype, log_ns, raw
    except Exception as err:  # rosbags, sqlite3 and mcap raise many kinds on damage
        raise BagDamage(f"{path}: damaged after message {count}: {type(err).__name__}: {err}", count) from err
    finally:
        reader.close()


def _iter_mcap(storages, wanted):
    """Messages of MCAP storage files, past damage; BagDamage at the end naming every damaged region."""
    count, problems = 0, []
    for storage in storages:
        for item in _scan_mcap(storage, wanted, problems):
            count += 1
            yield item
    if problems:
        raise BagDamage("; ".join(problems), count)


def iter_messages(path, wanted_topics):
    """Yield ``(topic, log_time_ns, msg)`` (rosbags message objects); damage as in :func:`iter_raw`.

    A message that does not deserialize (damaged bytes, an unknown type) is skipped and
    counted; :class:`BagDamage` at the end names how many.
    """
    bad, first, count = 0, None, 0
    try:
        for topic, msgtype, log_ns, raw in iter_raw(path, wanted_topics):
            try:
                msg = TYPESTORE.deserialize_cdr(raw, msgtype)
            except Exception as err:  # rosbags raises many kinds on bad CDR or an unknown type
                bad += 1
                first = first or f"{topic} at log time {log_ns * 1e-9:.3f} s: {type(err).__name__}: {err}"
                continue
            count += 1
            yield topic, log_ns, msg
    except BagDamage as err:
        if bad:
            raise BagDamage(f"{err}; {bad} message(s) could not be decoded (first: {first})", count) from err
        raise
    if bad:
        raise BagDamage(f"{path}: {bad} message(s) could not be decoded (first: {first})", count)


def _storage_files(path: Path) -> list:
    if path.is_file():
        return [path]
    files = sorted(p for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
    if not files:
        raise BagDamage(f"{path}: no .db3 or .mcap storage file in the bag folder", 0)
    return files


def _recover(path: Path, wanted, open_error):
    count = 0
    for storage in _storage_files(path):
        try:
            for item in _recover_sqlite(storage, wanted):
                count += 1
                yield item
        except BagDamage as err:
            raise BagDamage(f"{err} (rosbags could not open it: {open_error})", count) from err


def _readable_sqlite_copy(storage: Path, tmpdir: str) -> Path:
    """A copy of a cut sqlite file that SQLite will open: whole pages only, header page count cleared.

    SQLite trusts the page count in the header and calls a shorter file
    malformed; with the count zeroed it uses the file size. The user's file is
    never modified.
    """
    import shutil
    import struct

    copy = Path(tmpdir) / storage.name
    shutil.copyfile(storage, copy)
    with open(copy, "r+b") as fh:
        header = fh.read(100)
        if len(header) < 100 or not header.startswith(b"SQLite format 3"):
            raise BagDamage(f"{storage}: not an sqlite3 file (bad header)", 0)
        page = struct.unpack(">H", header[16:18])[0]
        page = 65536 if page == 1 else page
        fh.truncate(copy.stat().st_size // page * page)
        fh.seek(28)
        fh.write(b"\0\0\0\0")
    return copy


def _recover_sqlite(storage: Path, wanted):
    """Rows of a rosbag2 sqlite3 file in insertion order, up to the first unreadable page."""
    import sqlite3
    import tempfile

    count, last_id = 0, None
    with tempfile.TemporaryDirectory() as tmpdir:
        try:
            con = sqlite3.connect(_readable_sqlite_copy(storage, tmpdir))
            types = {tid: (norm_topic(name), mtype) for tid, name, mtype in
                     con.execute("SELECT id, name, type FROM topics")}
            rows = con.execute("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")
            for row_id, tid, log_ns, data in rows:
                topic, mtype = types[tid]
                last_id = row_id
                if wanted is None or topic in wanted:
                    count += 1
                    yield topic, mtype, log_ns, bytes(data)
            con.close()
        except sqlite3.DatabaseError as err:
            where = f"after row id {last_id}" if last_id is not None else "before the first message"
            raise BagDamage(f"{storage}: sqlite damaged {where} ({count} messages read): {err}", count) from err
        raise BagDamage(f"{storage}: sqlite file is cut short but every row it holds was read "
                        f"({count} messages)", count)


def _scan_mcap(storage: Path, wanted, problems: list):
    """Intact messages of one MCAP file (:mod:`nav_core.mcap_scan`); any damage is described in ``problems``."""
    from nav_core.mcap_scan import MAGIC, Scanner

    data = storage.read_bytes()
    if len(data) < 2 * len(MAGIC):
        problems.append(f"{storage}: {len(data)} bytes, too short to be an MCAP file")
        return
    scanner = Scanner(data)
    read = {}
    for channel, log_ns, raw in scanner.messages():
        topic, mtype = scanner.channels[channel]
        topic = norm_topic(topic)
        read[channel] = read.get(channel, 0) + 1
        if wanted is None or topic in wanted:
            yield topic, mtype, log_ns, raw
    text = _describe_damage(storage, scanner, read, wanted)
    if text:
        problems.append(text)


def _describe_damage(storage: Path, scanner, read: dict, wanted) -> str:
    """One line naming the file, the damaged byte ranges, the log-time spans and message counts lost."""
    res = scanner.result
    parts = []
    for r in res.regions:
        when = ""
        if r["before_ns"] is not None or r["after_ns"] is not None:
            t0 = "the start" if r["before_ns"] is None else f"{r['before_ns'] * 1e-9:.3f} s"
            t1 = "the end" if r["after_ns"] is None else f"{r['after_ns'] * 1e-9:.3f} s"
            when = f" (messages logged between {t0} and {t1} lost)"
        parts.append(f"bytes {r['start']}-{r['end']} unreadable{when}")
    if res.dropped:
        parts.append(f"{res.dropped} message(s) ending where damage begins dropped")
    if res.truncated:
        parts.append(f"the file is cut short at byte {scanner.end}")
    parts += res.problems
    if res.expected is not None:
        for cid, n in sorted(res.expected.items()):
            topic = norm_topic(scanner.channels.get(cid, (f"channel {cid}", ""))[0])
            if read.get(cid, 0) != n and (wanted is None or topic in wanted):
                parts.append(f"read {read.get(cid, 0)} of {n} messages on {topic}")
    if not parts:
        return ""
    return f"{storage}: MCAP damaged: " + "; ".join(parts)


def imu_message(t_s: float, gyro, accel, frame_id: str = "imu_link",
                gyro_var: float = 0.0, accel_var: float = 0.0):
    """A rosbags ``sensor_msgs/Imu`` with rate (rad/s), specific force (m/s^2), no orientation."""
    types = TYPESTORE.types
    header = types["std_msgs/msg/Header"](stamp=s_to_stamp(t_s), frame_id=frame_id)
    vec = types["geometry_msgs/msg/Vector3"]
    quat = types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    ocov = np.zeros(9)
    ocov[0] = -1.0
    return types[IMU_TYPE](header=header, orientation=quat, orientation_covariance=ocov,
                           angular_velocity=vec(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
                           angular_velocity_covariance=np.eye(3).ravel() * gyro_var,
                           linear_acceleration=vec(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
                           linear_acceleration_covariance=np.eye(3).ravel() * accel_var)


def navsatfix_message(t_s: float, lat_deg: float, lon_deg: float, h_m: float, std_enu, status: int = 0,
                      frame_id: str = "gps_link"):
    """A rosbags ``sensor_msgs/NavSatFix`` (degrees at this edge) with a diagonal ENU covariance."""
    types = TYPESTORE.types
    header = types["std_msgs/msg/Header"](stamp=s_to_stamp(t_s), frame_id=frame_id)
    st = types["sensor_msgs/msg/NavSatStatus"](status=int(status), service=1)
    cov = np.diag(np.asarray(std_enu, dtype=float) ** 2).ravel()
    return types[NAVSATFIX_TYPE](header=header, status=st, latitude=float(lat_deg), longitude=float(lon_deg),
                                 altitude=float(h_m), position_covariance=cov,
                                 position_covariance_type=2)  # COVARIANCE_TYPE_DIAGONAL_KNOWN


def temperature_message(t_s: float, temp_c: float, frame_id: str = "imu_link"):
    """A rosbags ``sensor_msgs/Temperature`` in degrees Celsius."""
    types = TYPESTORE.types
    header = types["std_msgs/msg/Header"](stamp=s_to_stamp(t_s), frame_id=frame_id)
    return types[TEMPERATURE_TYPE](header=header, temperature=float(temp_c), variance=0.0)


ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
TWIST_STAMPED_TYPE = "geometry_msgs/msg/TwistStamped"
WHEEL_TYPES = (ODOMETRY_TYPE, TWIST_STAMPED_TYPE)  # what a wheel odometer publishes its forward speed in


class NotWheelSpeed(ValueError):
    """A message that carries no forward speed (not one of :data:`WHEEL_TYPES`)."""


def wheel_speed_message(t_s: float, speed_mps: float, msgtype: str = ODOMETRY_TYPE, frame_id: str = "base_link"):
    """A rosbags wheel-odometer message: forward speed (m/s) in ``twist.twist.linear.x`` of an Odometry or
    ``twist.linear.x`` of a TwistStamped (``msgtype``, one of :data:`WHEEL_TYPES`)."""
    types = TYPESTORE.types
    header = types["std_msgs/msg/Header"](stamp=s_to_stamp(t_s), frame_id=frame_id)
    vec = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](linear=vec(x=float(speed_mps), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0,
                                                                                                        z=0.0))
    if msgtype == TWIST_STAMPED_TYPE:
        return types[TWIST_STAMPED_TYPE](header=header, twist=twist)
    if msgtype != ODOMETRY_TYPE:
        raise NotWheelSpeed(f"{msgtype}: a wheel speed is one of {list(WHEEL_TYPES)}")
    pose = types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                           orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                             w=1.0))
    return types[ODOMETRY_TYPE](
        header=header, child_frame_id=frame_id,
        pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)))


def forward_speed(msg) -> float:
    """The forward speed (m/s) a wheel-odometer message carries (see :func:`wheel_speed_message`)."""
    twist = getattr(msg, "twist", None)
    inner = getattr(twist, "twist", twist)  # Odometry: twist.twist; TwistStamped: twist
    linear = getattr(inner, "linear", None)
    if linear is None:
        raise NotWheelSpeed(f"{getattr(msg, '__msgtype__', type(msg).__name__)} carries no forward speed: expected "
                            f"one of {list(WHEEL_TYPES)}")
    return float(linear.x)


def default_qos(topic: str, msgtype: str, sensor: bool | None = None) -> list:
    """The QoS (rosbags ``Qos`` list, as ``offered_qos_profiles``) our publishers offer on ``topic``: sensor messages
    the sensor-data QoS (best effort, keep last 5), ``/tf_static`` reliable and transient local (latched), the rest
    reliable, keep last 10 (rclpy's default). What a bag written without a live publisher records. ``sensor``:
    whether the topic is a sensor's (None: by ``msgtype``; a wheel odometer's Odometry is, the filter's is not)."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)  # rclpy's default deadline, lifespan and lease: none
    sensor = msgtype in SENSOR_TYPES if sensor is None else sensor
    latched = norm_topic(topic) == "tf_static"
    return [Qos(QosHistory.KEEP_LAST, 5 if sensor else 1 if latched else 10,
                QosReliability.BEST_EFFORT if sensor else QosReliability.RELIABLE,
                QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE, zero, zero,
                QosLiveliness.AUTOMATIC, zero, False)]


class BagWriter:
    """Write messages to a new rosbag2 bag; use as a context manager.

    ``write`` takes a rosbags message object; ``write_cdr`` takes already
    serialized CDR bytes (for example from ``rclpy.serialization``).
    """

    def __init__(self, path, storage: str = "sqlite3"):
        if storage not in STORAGES:
            raise ValueError(f"storage must be one of {sorted(STORAGES)}, got {storage!r}")
        self.path = Path(path)
        self._writer = Writer(self.path, version=8, storage_plugin=STORAGES[storage])
        self._conns = {}

    def __enter__(self):
        self._writer.open()
        return self

    def __exit__(self, *exc):
        self._writer.close()

    def _conn(self, topic: str, msgtype: str):
        key = "/" + norm_topic(topic)
        if key not in self._conns:
            self.add_topic(topic, msgtype)
        return self._conns[key]

    def add_topic(self, topic: str, msgtype: str, offered_qos_profiles=()) -> None:
        """Declare ``topic`` before its first message, with the QoS its publishers offered (rosbags ``Qos``),
        which ``ros2 bag play`` offers again (metadata ``offered_qos_profiles``); none given (a bag written
        offline, a publisher gone): :func:`default_qos`, so every bag says its QoS."""
        key = "/" + norm_topic(topic)
        if key not in self._conns:
            qos = tuple(offered_qos_profiles) or tuple(default_qos(topic, msgtype))
            self._conns[key] = self._writer.add_connection(key, msgtype, typestore=TYPESTORE,
                                                           offered_qos_profiles=qos)

    def write(self, topic: str, log_ns: int, msg) -> None:
        """Serialize a rosbags message and write it at log time ``log_ns``."""
        msgtype = msg.__msgtype__
        self._writer.write(self._conn(topic, msgtype), int(log_ns), TYPESTORE.serialize_cdr(msg, msgtype))

    def write_cdr(self, topic: str, msgtype: str, log_ns: int, data: bytes) -> None:
        """Write CDR bytes of type ``msgtype`` (``pkg/msg/Name``) at log time ``log_ns``."""
        self._writer.write(self._conn(topic, msgtype), int(log_ns), data)
