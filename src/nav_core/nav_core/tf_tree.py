"""The transform tree of the navigation graph (REP-105), without ROS: poses, the odom chain, sensor mounts.

Frames::

    map ──> odom ──> base_link ──> imu_link   (static, identity: the IMU axes are the body axes)
                               └─> gps_link   (static, the GPS lever arm)

``map`` is the local ENU frame at the datum: the filter's GPS-corrected pose (``odometry/filtered``)
is in it and may jump (a GPS update, a reset to a fix, the heading taken from the GPS course).
``odom`` is continuous in the plane, as REP-105 asks: its x, y and yaw advance only by the INS's
own motion between filter epochs (the strapdown prediction, before the measurement updates), so
they drift but never jump; ``map -> odom`` carries every horizontal and heading correction, as
robot_localization's global instance does. ``odom`` is gravity-aligned: height, roll and pitch of
``odom -> base_link`` are the filter's (observed through gravity and the GPS height, corrected by
centimetres), so ``map -> odom`` is a translation in x, y and a rotation about z; a free-running
vertical channel and tilt would make it lean by degrees over a drive. ``odom`` starts at ``map``
at the first estimate.

A :class:`Pose` ``T_ab`` maps coordinates in frame ``b`` into frame ``a`` (ROS's transform from
``a`` = header.frame_id to ``b`` = child_frame_id). Positions in m, quaternions (x, y, z, w).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import frames

MAP, ODOM, BASE, IMU, GPS = "map", "odom", "base_link", "imu_link", "gps_link"


@dataclass(frozen=True)
class Pose:
    """A rigid transform: ``position`` (3,) m and ``rotation`` (scipy Rotation) of the child in the parent."""

    position: np.ndarray
    rotation: Rotation

    @staticmethod
    def from_xyzw(position, quat_xyzw) -> "Pose":
        """Pose from a position (3,) m and a quaternion (x, y, z, w)."""
        return Pose(np.asarray(position, dtype=float).copy(), Rotation.from_quat(quat_xyzw))

    @staticmethod
    def identity() -> "Pose":
        """The identity transform."""
        return Pose(np.zeros(3), Rotation.identity())

    @property
    def quat_xyzw(self) -> np.ndarray:
        """The rotation as a quaternion (x, y, z, w) with w >= 0."""
        q = self.rotation.as_quat()
        return -q if q[3] < 0 else q

    def compose(self, other: "Pose") -> "Pose":
        """``self * other``: T_ab * T_bc = T_ac."""
        return Pose(self.position + self.rotation.apply(other.position), self.rotation * other.rotation)

    def inverse(self) -> "Pose":
        """T_ba of T_ab."""
        inv = self.rotation.inv()
        return Pose(-inv.apply(self.position), inv)

    def between(self, other: "Pose") -> "Pose":
        """The motion from ``self`` to ``other`` in ``self``'s frame: ``self^-1 * other``."""
        return self.inverse().compose(other)


@dataclass(frozen=True)
class FrameTransforms:
    """The two dynamic transforms of one epoch: ``map -> odom`` and ``odom -> base_link``."""

    t: float
    map_odom: Pose
    odom_base: Pose


def _yaw(pose: Pose) -> float:
    """Yaw (rad, ENU, 0 = east) of a body-to-frame rotation."""
    return float(frames.euler_from_rotation(pose.rotation)[2])


class OdomChain:
    """Splits the filter's map pose into a continuous ``odom -> base_link`` and the ``map -> odom`` correction.

    At each epoch the odom x, y and yaw move by the INS's prediction since the previous epoch
    (previous map pose to predicted map pose, which contains no measurement update), turned into
    odom by the heading difference between the frames; height, roll and pitch are the filter's.
    ``map -> odom`` is whatever then makes ``map -> odom -> base_link`` equal the filter's pose.
    When the chain breaks (no prediction, a filter restart: a new ``segment``, or time going
    back) the odom x, y and yaw hold still and ``map -> odom`` takes the whole jump.
    """

    def __init__(self):
        self._xy_yaw: tuple | None = None  # odom x, y (m) and yaw (rad) of base_link
        self._last_map: Pose | None = None
        self._last_t = -np.inf
        self._segment = None

    def update(self, t: float, map_base: Pose, predicted_map_base: Pose | None = None,
               segment=None) -> FrameTransforms:
        """Transforms at stamp ``t`` s from the filter's pose and its pre-update prediction (both in map)."""
        if self._xy_yaw is None:
            self._xy_yaw = (*map_base.position[:2], _yaw(map_base))  # odom starts at map
        elif predicted_map_base is not None and segment == self._segment and t >= self._last_t:
            x, y, yaw = self._xy_yaw
            turn = yaw - _yaw(self._last_map)  # heading of map axes in odom
            dx, dy, _ = Rotation.from_euler("z", turn).apply(predicted_map_base.position - self._last_map.position)
            step_yaw = float(frames.wrap_angle(_yaw(predicted_map_base) - _yaw(self._last_map)))
            self._xy_yaw = (x + dx, y + dy, float(frames.wrap_angle(yaw + step_yaw)))
        self._last_map, self._last_t, self._segment = map_base, t, segment
        x, y, yaw = self._xy_yaw
        roll, pitch, _ = frames.euler_from_rotation(map_base.rotation)
        odom_base = Pose(np.array([x, y, map_base.position[2]]), frames.rotation_from_euler(roll, pitch, yaw))
        return FrameTransforms(t, map_base.compose(odom_base.inverse()), odom_base)


def static_mounts(lever_arm_b, base: str = BASE, imu: str = IMU, gps: str = GPS) -> list[tuple[str, str, Pose]]:
    """Static ``(parent, child, pose)`` transforms: the IMU (its axes are the body axes) and the GPS
    antenna at the lever arm ``lever_arm_b`` (3,) m in base_link (FLU), the one the filter uses."""
    return [(base, imu, Pose.identity()),
            (base, gps, Pose(np.asarray(lever_arm_b, dtype=float).copy(), Rotation.identity()))]
