"""Unit conversions: the one place where degrees, g, deg/h and friends become SI."""
import numpy as np

G0 = 9.80665
"""Standard gravity in m/s^2 (conventional, not local gravity)."""

DEG = np.pi / 180.0
"""Radians per degree."""

DEG_PER_H = DEG / 3600.0
"""rad/s per deg/h."""

DEG_PER_SQRT_H = DEG / 60.0
"""rad/sqrt(s) per deg/sqrt(h) (angle random walk)."""

MG = 1e-3 * G0
"""m/s^2 per milli-g."""

UG = 1e-6 * G0
"""m/s^2 per micro-g."""

PPM = 1e-6
"""Dimensionless per part-per-million."""


def deg2rad(value_deg):
    """Degrees (scalar or array) to radians."""
    return np.asarray(value_deg, dtype=float) * DEG


def rad2deg(value_rad):
    """Radians (scalar or array) to degrees."""
    return np.asarray(value_rad, dtype=float) / DEG


def g2mps2(value_g):
    """Multiples of standard gravity to m/s^2."""
    return np.asarray(value_g, dtype=float) * G0


def mps22g(value_mps2):
    """m/s^2 to multiples of standard gravity."""
    return np.asarray(value_mps2, dtype=float) / G0


def dph2rps(value_deg_per_h):
    """deg/h to rad/s."""
    return np.asarray(value_deg_per_h, dtype=float) * DEG_PER_H


def rps2dph(value_rad_per_s):
    """rad/s to deg/h."""
    return np.asarray(value_rad_per_s, dtype=float) / DEG_PER_H


def imu_unit_problem(gyro, accel, gyro_name: str = "gyro", accel_name: str = "accel") -> str | None:
    """Why ``gyro`` (n, 3) and ``accel`` (n, 3) cannot be rad/s and m/s^2 of an IMU on Earth, or None;
    the text names the fields as ``gyro_name`` / ``accel_name`` (columns, message fields).

    A resting or driving IMU reads about 1 g of specific force most of the time, so a median
    |f| outside [0.5 g, 2 g] means another unit (g, mg, ft/s^2...); a vehicle turns faster than
    1 rad/s (57 deg/s) only briefly, so a median |rate| above it means deg/s. Non-finite rows are
    ignored. Only what no real recording in SI can show is flagged: a gyro in deg/s with a
    median rate below 1 deg/s passes.
    """
    gyro, accel = np.asarray(gyro, dtype=float), np.asarray(accel, dtype=float)
    ok = np.all(np.isfinite(gyro), axis=1) & np.all(np.isfinite(accel), axis=1)
    if not ok.any():
        return None
    f = float(np.median(np.linalg.norm(accel[ok], axis=1)))
    w = float(np.median(np.linalg.norm(gyro[ok], axis=1)))
    if not 0.5 * G0 <= f <= 2.0 * G0:
        hint = " (in g? multiply by 9.80665)" if 0.5 <= f <= 2.0 else " (in mg?)" if 500 <= f <= 2000 else ""
        return f"{accel_name}: median |specific force| {f:.4g}, expected about 9.8 m/s^2 on Earth{hint}"
    if w > 1.0:
        return f"{gyro_name}: median |angular rate| {w:.4g}, expected well below 1 rad/s for a vehicle (in deg/s?)"
    return None


NS_PER_S = 1_000_000_000
"""Nanoseconds per second (ROS stamps: int32 sec, uint32 nanosec)."""


def ns_from_s(t_s):
    """Float seconds (scalar or array) to integer nanoseconds, rounded (int, or an int64 array)."""
    if np.ndim(t_s) == 0 and not isinstance(t_s, np.ndarray):
        return int(round(float(t_s) * 1e9))
    return np.round(np.asarray(t_s, dtype=float) * 1e9).astype(np.int64)


def sec_nanosec(ns):
    """Integer nanoseconds (scalar or int64 array) to a stamp's (sec, nanosec)."""
    return ns // NS_PER_S, ns % NS_PER_S


def s_from_sec_nanosec(sec, nanosec):
    """A stamp's (sec, nanosec) (scalars or arrays) to float seconds."""
    return sec + 1e-9 * nanosec
