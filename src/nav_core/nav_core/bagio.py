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

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
IMU_TYPE = "sensor_msgs/msg/Imu"
NAVSATFIX_TYPE = "sensor_msgs/msg/NavSatFix"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"
STORAGES = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}


class BagDamage(Exception):
    """Reading stopped at damage; ``position`` says where, ``count`` how many messages were good."""

    def __init__(self, message: str, count: int):
        super().__init__(message)
        self.count = count


def norm_topic(topic: str) -> str:
    """Topic name without its leading slash."""
    return topic.lstrip("/")


def is_bag(path) -> bool:
    """Whether ``path`` is a rosbag2 folder or a bare .db3/.mcap storage file."""
    p = Path(path)
    return (p.is_dir() and (p / "metadata.yaml").exists()) or p.suffix in (".db3", ".mcap")


def stamp_to_s(stamp) -> float:
    """``builtin_interfaces/Time`` to float seconds."""
    return stamp.sec + 1e-9 * stamp.nanosec


def s_to_stamp(t_s: float):
    """Float seconds to a rosbags ``builtin_interfaces/Time``."""
    time_cls = TYPESTORE.types["builtin_interfaces/msg/Time"]
    ns = int(round(t_s * 1e9))
    return time_cls(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def topics(path) -> dict:
    """Topic name (no slash) -> message type of a bag."""
    with Reader(Path(path)) as reader:
        return {norm_topic(c.topic): c.msgtype for c in reader.connections}


def iter_messages(path, wanted_topics):
    """Yield ``(topic, log_time_ns, msg)`` for the wanted topics in log-time order.

    Raises :class:`BagDamage` where the bag is damaged, after yielding everything before it.
    """
    path = Path(path)
    wanted = {norm_topic(t) for t in wanted_topics}
    count = 0
    last_ns = None
    try:
        with Reader(path) as reader:
            conns = [c for c in reader.connections if norm_topic(c.topic) in wanted]
            for conn, log_ns, raw in reader.messages(connections=conns):
                msg = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
                count += 1
                last_ns = log_ns
                yield norm_topic(conn.topic), log_ns, msg
    except BagDamage:
        raise
    except FileNotFoundError as err:
        raise BagDamage(f"{path}: {err}", 0) from err
    except Exception as err:  # rosbags, sqlite3 and mcap raise many kinds on damage
        where = f"after message {count}" + (f" (log time {last_ns * 1e-9:.6f} s)" if last_ns else "")
        raise BagDamage(f"{path}: damaged or unreadable {where}: {type(err).__name__}: {err}", count) from err


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
            self._conns[key] = self._writer.add_connection(key, msgtype, typestore=TYPESTORE)
        return self._conns[key]

    def write(self, topic: str, log_ns: int, msg) -> None:
        """Serialize a rosbags message and write it at log time ``log_ns``."""
        msgtype = msg.__msgtype__
        self._writer.write(self._conn(topic, msgtype), int(log_ns), TYPESTORE.serialize_cdr(msg, msgtype))

    def write_cdr(self, topic: str, msgtype: str, log_ns: int, data: bytes) -> None:
        """Write CDR bytes of type ``msgtype`` (``pkg/msg/Name``) at log time ``log_ns``."""
        self._writer.write(self._conn(topic, msgtype), int(log_ns), data)
