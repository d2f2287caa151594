"""Attitude conventions in one tested place: Euler angles, rotation matrices, quaternions.

Body frame FLU, navigation frame ENU, body-to-ENU ``R = Rz(yaw) Ry(pitch) Rx(roll)``
(REP-103). Quaternions are ``(x, y, z, w)``. Angles in radians.
"""
import numpy as np
from scipy.spatial.transform import Rotation


def rotation_from_euler(roll_rad, pitch_rad, yaw_rad):
    """Body-to-ENU :class:`Rotation` from roll, pitch, yaw in rad (scalars or arrays of shape (n,))."""
    angles = np.column_stack(np.broadcast_arrays(yaw_rad, pitch_rad, roll_rad)).astype(float)
    if np.ndim(roll_rad) == 0 and np.ndim(pitch_rad) == 0 and np.ndim(yaw_rad) == 0:
        angles = angles[0]
    # Intrinsic z-y'-x'' equals R = Rz(yaw) Ry(pitch) Rx(roll).
    return Rotation.from_euler("ZYX", angles)


def euler_from_rotation(rot):
    """Roll, pitch, yaw in rad from a body-to-ENU :class:`Rotation` (each scalar or shape (n,))."""
    yaw, pitch, roll = np.moveaxis(rot.as_euler("ZYX"), -1, 0)
    return roll, pitch, yaw


def mat_nb_from_euler(roll_rad, pitch_rad, yaw_rad):
    """Body-to-ENU matrix, shape (3, 3) or (n, 3, 3), from roll, pitch, yaw in rad."""
    return rotation_from_euler(roll_rad, pitch_rad, yaw_rad).as_matrix()


def quat_xyzw_from_euler(roll_rad, pitch_rad, yaw_rad):
    """Body-to-ENU quaternion (x, y, z, w) from roll, pitch, yaw in rad."""
    return rotation_from_euler(roll_rad, pitch_rad, yaw_rad).as_quat()


def euler_from_quat_xyzw(quat_xyzw):
    """Roll, pitch, yaw in rad from a body-to-ENU quaternion (x, y, z, w)."""
    return euler_from_rotation(Rotation.from_quat(quat_xyzw))


def wrap_angle(angle_rad):
    """Wrap angles in rad to [-pi, pi)."""
    return (np.asarray(angle_rad, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def skew(vec):
    """Skew-symmetric cross-product matrix of a 3-vector, shape (3, 3); or of a stack (n, 3) -> (n, 3, 3)."""
    v = np.asarray(vec, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out
