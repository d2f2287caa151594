"""Closed-form test motions (stationary, straight line, circle) with their ideal IMU rates and noisy GPS.

An independent truth for the tests and the benchmark (the project simulator is
:mod:`imu_sim`): the vehicle stays level, speed ``s(t)`` and yaw ``psi(t)`` are
piecewise linear, and the IMU outputs follow from the navigation equation
``f_n = a_n - g_n + (2 w_ie + w_en) x v_n``, ``w_ib_b = C_bn (w_ie + w_en) + psi' z``,
evaluated at the middle of each sample interval (so ``rate * dt`` is the increment
to second order).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core import earth, frames
from nav_core.earth import LocalFrame
from nav_core.recording import GnssRecording, ImuRecording, Trajectory
from nav_core.units import DEG


@dataclass
class Motion:
    """Piecewise motion: segment durations (s), accelerations (m/s^2) and yaw rates (rad/s)."""

    durations: tuple
    accels: tuple
    yaw_rates: tuple
    yaw0: float = 0.0
    lat0_deg: float = 45.0
    lon0_deg: float = 10.0
    h0_m: float = 100.0

    def speed_yaw(self, t):
        """Speed (m/s), yaw (rad), acceleration (m/s^2), yaw rate (rad/s) at times ``t`` (s)."""
        t = np.asarray(t, dtype=float)
        edges = np.concatenate(([0.0], np.cumsum(self.durations)))
        seg = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(self.durations) - 1)
        s0 = np.concatenate(([0.0], np.cumsum(np.multiply(self.accels, self.durations))))
        y0 = self.yaw0 + np.concatenate(([0.0], np.cumsum(np.multiply(self.yaw_rates, self.durations))))
        tau = t - edges[seg]
        acc, rate = np.asarray(self.accels)[seg], np.asarray(self.yaw_rates)[seg]
        return s0[seg] + acc * tau, y0[seg] + rate * tau, acc, rate


def stationary(duration_s=600.0, yaw0=0.3, **kw) -> Motion:
    """Resting level vehicle."""
    return Motion((duration_s,), (0.0,), (0.0,), yaw0, **kw)


def straight(still_s=50.0, accel_s=10.0, cruise_s=300.0, accel=1.0, yaw0=0.5, **kw) -> Motion:
    """Rest, accelerate along yaw0, then constant velocity."""
    return Motion((still_s, accel_s, cruise_s), (0.0, accel, 0.0), (0.0, 0.0, 0.0), yaw0, **kw)


def circle(still_s=50.0, accel_s=10.0, straight_s=10.0, turn_s=600.0, accel=1.0, yaw_rate=0.05, **kw) -> Motion:
    """Rest, accelerate, a short straight (heading from course), then a constant-speed circle."""
    return Motion((still_s, accel_s, straight_s, turn_s), (0.0, accel, 0.0, 0.0), (0.0, 0.0, 0.0, yaw_rate),
                  kw.pop("yaw0", 0.2), **kw)


def _kinematics(motion: Motion, t):
    s, yaw, acc, rate = motion.speed_yaw(t)
    c, sn = np.cos(yaw), np.sin(yaw)
    v = np.column_stack([s * c, s * sn, np.zeros_like(s)])
    a = np.column_stack([acc * c - s * rate * sn, acc * sn + s * rate * c, np.zeros_like(s)])
    return v, a, yaw, rate


def truth(motion: Motion, rate_hz: float, oversample: int = 10):
    """Truth at the IMU stamps: t (n,), local ENU position (n, 3) m, velocity (n, 3) m/s, yaw (n,) rad."""
    n = int(round(sum(motion.durations) * rate_hz)) + 1
    t_fine = np.arange((n - 1) * oversample + 1) / (rate_hz * oversample)
    v_fine, _, _, _ = _kinematics(motion, t_fine)
    dt = t_fine[1] - t_fine[0]
    pos = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (v_fine[1:] + v_fine[:-1]) * dt, axis=0)])
    t = t_fine[::oversample]
    v, _, yaw, _ = _kinematics(motion, t)
    return t, pos[::oversample], v, yaw


def ideal_imu(motion: Motion, rate_hz: float, oversample: int = 10) -> ImuRecording:
    """Ideal gyro (rad/s) and accel (m/s^2) samples, stamped at the end of each interval (first at 1/rate)."""
    t, pos, _, _ = truth(motion, rate_hz, oversample)
    t_mid = t[1:] - 0.5 / rate_hz
    v, a, yaw, yaw_rate = _kinematics(motion, t_mid)
    pos_mid = 0.5 * (pos[1:] + pos[:-1])
    lat, h = _lat_h(motion, pos_mid)
    w_ie = earth.earth_rate_n(lat)
    w_en = earth.transport_rate_n(lat, h, v)
    f_n = a - earth.gravity_n(lat, h) + np.cross(2 * w_ie + w_en, v)
    mat_bn = np.transpose(frames.mat_nb_from_euler(np.zeros_like(yaw), np.zeros_like(yaw), yaw), (0, 2, 1))
    gyro = np.einsum("nij,nj->ni", mat_bn, w_ie + w_en) + np.column_stack(
        [np.zeros_like(yaw), np.zeros_like(yaw), np.broadcast_to(yaw_rate, yaw.shape)])
    accel = np.einsum("nij,nj->ni", mat_bn, f_n)
    return ImuRecording(t[1:], gyro, accel, source="synthetic")


def _lat_h(motion: Motion, pos_n):
    lat0 = motion.lat0_deg * DEG
    rm, _ = earth.radii(lat0)
    h = motion.h0_m + pos_n[:, 2]
    return lat0 + pos_n[:, 1] / (rm + h), h


def add_imu_errors(imu: ImuRecording, rng, gyro_bias=0.0, accel_bias=0.0, gyro_white=0.0, accel_white=0.0):
    """Copy of ``imu`` with constant biases (rad/s, m/s^2, scalar or (3,)) and white noise (rad/sqrt(s), m/s/sqrt(s))."""
    dt = 1.0 / imu.rate_hz
    gyro = imu.gyro + gyro_bias + rng.normal(0, 1, imu.gyro.shape) * np.asarray(gyro_white) / np.sqrt(dt)
    accel = imu.accel + accel_bias + rng.normal(0, 1, imu.accel.shape) * np.asarray(accel_white) / np.sqrt(dt)
    return ImuRecording(imu.t.copy(), gyro, accel, source=imu.source)


def gnss(motion: Motion, rate_hz: float, std_m: float, rng, gps_rate_hz: float = 1.0) -> GnssRecording:
    """Noisy GPS fixes (white, ``std_m`` per axis) at ``gps_rate_hz`` taken from the truth at ``rate_hz``."""
    t, pos, _, _ = truth(motion, rate_hz)
    step = int(round(rate_hz / gps_rate_hz))
    t, pos = t[::step], pos[::step]
    noisy = pos + rng.normal(0, std_m, pos.shape)
    frame = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m)
    lat, lon, h = frame.to_geodetic(noisy)
    return GnssRecording(t, lat * DEG, lon * DEG, h, np.full((len(t), 3), std_m), source="synthetic")


def truth_trajectory(motion: Motion, rate_hz: float) -> Trajectory:
    """The truth as a :class:`Trajectory` (geodetic), with ENU positions in ``extra`` (e_m, n_m, u_m)."""
    t, pos, v, yaw = truth(motion, rate_hz)
    frame = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m)
    lat, lon, h = frame.to_geodetic(pos)
    zeros = np.zeros_like(t)
    return Trajectory(t, lat * DEG, lon * DEG, h, zeros, zeros, yaw, v,
                      {"e_m": pos[:, 0], "n_m": pos[:, 1], "u_m": pos[:, 2]})
