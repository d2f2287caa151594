"""Truth motion on a fine time grid: geodetic position, ENU velocity and its rate, body-to-ENU attitude.

Two builders: piecewise attitude at a fixed point (fixtures, up/down, rate tables) and a road drive
from speed, course and grade profiles with analytic derivatives. Positions of the drive are integrated
on the ellipsoid (lat' = vn/(RM+h), lon' = ve/((RN+h) cos lat)), so the local-level velocity rate is
exact and the specific force follows from f = v' + (2 w_ie + w_en) x v + g_up.
"""
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from . import earth


@dataclass
class Motion:
    """Truth on a fine grid ``t`` (s): lat/lon (rad), h (m), v and its rate (ENU, m/s, m/s^2), rot (body->ENU)."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    v: np.ndarray
    vdot: np.ndarray
    rot: Rotation


def euler_rot(roll_deg, pitch_deg, yaw_deg) -> Rotation:
    """Body-to-ENU rotation Rz(yaw) Ry(pitch) Rx(roll) (REP-103 angles in degrees)."""
    return Rotation.from_euler("ZYX", np.stack(np.broadcast_arrays(yaw_deg, pitch_deg, roll_deg), -1),
                               degrees=True)


def rpy_deg(rot: Rotation) -> np.ndarray:
    """(roll, pitch, yaw) in degrees, shape (n, 3), of body-to-ENU rotations."""
    with warnings.catch_warnings():  # faces at pitch +-90 deg: any split of roll/yaw is the same rotation
        warnings.simplefilter("ignore", UserWarning)
        ypr = rot.as_euler("ZYX", degrees=True)
    return np.asarray(ypr)[..., ::-1]


def smoothstep5(s):
    """Quintic smoothstep and its derivative on s in [0, 1] (clipped)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2


# ---------------------------------------------------------------- attitude pieces at a fixed point
@dataclass
class Hold:
    """The body held at ``rot`` for ``duration_s``."""

    rot: Rotation
    duration_s: float

    def at(self, tau):
        return Rotation.from_quat(np.repeat(self.rot.as_quat()[None], len(tau), 0))

    def end(self) -> Rotation:
        return self.rot


@dataclass
class Move:
    """A hand/fixture move from ``start`` to ``stop``: quintic smoothstep of the body-frame rotation vector."""

    start: Rotation
    stop: Rotation
    duration_s: float

    def at(self, tau):
        rv = (self.start.inv() * self.stop).as_rotvec()
        s, _ = smoothstep5(tau / self.duration_s)
        return self.start * Rotation.from_rotvec(s[:, None] * rv[None])

    def end(self) -> Rotation:
        return self.stop


@dataclass
class Spin:
    """A rate-table run about body axis ``axis`` from ``start``: cosine ramps of ``ramp_s`` to ``rate`` rad/s,
    a dwell of ``dwell_s``, a cosine ramp back to rest. Angle of a ramp: rate * ramp_s / 2."""

    start: Rotation
    axis: np.ndarray
    rate: float
    ramp_s: float
    dwell_s: float

    @property
    def duration_s(self):
        return 2 * self.ramp_s + self.dwell_s

    def angle(self, tau):
        """Table angle (rad) after ``tau`` s."""
        tau = np.asarray(tau, float)
        r, w, d = self.ramp_s, self.rate, self.dwell_s
        up = w / 2 * (tau - r / np.pi * np.sin(np.pi * tau / r))
        a_up = w * r / 2
        mid = a_up + w * (tau - r)
        u = tau - r - d
        down = a_up + w * d + w / 2 * (u + r / np.pi * np.sin(np.pi * u / r))
        return np.where(tau < r, up, np.where(tau < r + d, mid, down))

    def at(self, tau):
        ang = self.angle(np.clip(tau, 0, self.duration_s))
        return self.start * Rotation.from_rotvec(ang[:, None] * np.asarray(self.axis)[None])

    def end(self) -> Rotation:
        return self.at(np.array([self.duration_s]))[0]


def fixed_point(pieces, lat_deg, lon_deg, h_m, t) -> Motion:
    """Motion of a body at a fixed geodetic point whose attitude follows ``pieces`` back to back from t=0."""
    quats = np.empty((len(t), 4))
    t0 = 0.0
    done = np.zeros(len(t), bool)
    for piece in pieces:
        sel = (~done) & (t <= t0 + piece.duration_s + 1e-12)
        if sel.any():
            quats[sel] = piece.at(t[sel] - t0).as_quat()
        done |= sel
        t0 += piece.duration_s
    if not done.all():
        quats[~done] = pieces[-1].end().as_quat()
    n = len(t)
    zeros = np.zeros((n, 3))
    return Motion(t=t, lat=np.full(n, np.radians(lat_deg)), lon=np.full(n, np.radians(lon_deg)),
                  h=np.full(n, float(h_m)), v=zeros, vdot=zeros.copy(), rot=Rotation.from_quat(quats))


def piece_starts(pieces):
    """Start time (s) of each piece."""
    return np.concatenate([[0.0], np.cumsum([p.duration_s for p in pieces])])[:-1]


# ---------------------------------------------------------------- road drive
def _smooth_profile(t, knots, values):
    """A piecewise-constant command smoothed by quintic steps: value and rate at times ``t``.

    ``knots`` are (start, duration) of each change, ``values`` the levels before and after each."""
    val = np.full_like(t, values[0], dtype=float)
    rate = np.zeros_like(t, dtype=float)
    for (start, dur), (a, b) in zip(knots, zip(values[:-1], values[1:])):
        s, ds = smoothstep5((t - start) / dur)
        val += (b - a) * s
        rate += (b - a) * ds / dur
    return val, rate


def road_drive(rng, lat_deg, lon_deg, h_m, t, roll_per_lat_accel_deg=0.5):
    """A drive with stops, straights, left/right turns and rolling hills; returns (Motion, description)."""
    duration = t[-1]
    # speed: stand still 20 s, then accelerate/cruise/brake phases
    sp_knots, sp_vals, t_now, speed = [], [0.0], 20.0, 0.0
    while t_now < duration - 40:
        target = 0.0 if (speed > 0 and rng.random() < 0.2) else rng.uniform(5, 17)
        dur = max(3.0, 1.875 * abs(target - speed) / rng.uniform(0.8, 2.0))  # peak accel 0.8-2 m/s^2
        sp_knots.append((t_now, dur))
        sp_vals.append(target)
        speed = target
        t_now += dur + rng.uniform(10, 35)
    sp_knots.append((max(t_now, duration - 30), 12.0))
    sp_vals.append(0.0)
    s, sdot = _smooth_profile(t, sp_knots, sp_vals)
    # course: turns of +-20..100 deg, slow enough for at most 2.5 m/s^2 of lateral acceleration at 17 m/s
    hd_knots, hd_vals, heading = [], [rng.uniform(-np.pi, np.pi)], 0.0
    heading = hd_vals[0]
    t_now = 35.0
    while t_now < duration - 45:
        turn = np.radians(rng.uniform(20, 100)) * rng.choice([-1, 1])
        dur = max(4.0, 1.875 * abs(turn) * 17.0 / 2.5) * rng.uniform(1.0, 1.5)
        hd_knots.append((t_now, dur))
        heading += turn
        hd_vals.append(heading)
        t_now += dur + rng.uniform(12, 40)
    psi, psidot = _smooth_profile(t, hd_knots, hd_vals)
    # grade: gentle hills, +-(0.5..3) deg with 60..200 s period (moving only: scaled by speed fraction)
    amp, period, ph = np.radians(rng.uniform(0.5, 3.0)), rng.uniform(60, 200), rng.uniform(0, 2 * np.pi)
    gam = amp * np.sin(2 * np.pi * t / period + ph)
    gamdot = amp * 2 * np.pi / period * np.cos(2 * np.pi * t / period + ph)
    cg, sg, cp, spsi = np.cos(gam), np.sin(gam), np.cos(psi), np.sin(psi)
    u = np.stack([cg * cp, cg * spsi, sg], -1)
    udot = np.stack([-sg * gamdot * cp - cg * spsi * psidot, -sg * gamdot * spsi + cg * cp * psidot,
                     cg * gamdot], -1)
    v = s[:, None] * u
    vdot = sdot[:, None] * u + s[:, None] * udot
    lat, lon, h = _integrate_geodetic(t, v, np.radians(lat_deg), np.radians(lon_deg), h_m)
    lat_accel = s * psidot * cg  # leftward (centripetal) acceleration of a left turn, m/s^2
    roll = roll_per_lat_accel_deg * lat_accel
    # the body stays level while parked (no course change when standing)
    rot = euler_rot(roll, -np.degrees(gam), np.degrees(psi))
    desc = {"speed_knots": len(sp_knots), "turns": len(hd_knots), "grade_amp_deg": float(np.degrees(amp)),
            "roll_per_lat_accel_deg": float(roll_per_lat_accel_deg),
            "distance_m": float(np.trapezoid(s, t))}
    return Motion(t=t, lat=lat, lon=lon, h=h, v=v, vdot=vdot, rot=rot), desc


def _integrate_geodetic(t, v, lat0, lon0, h0):
    """Trapezoid integration of ENU velocity into geodetic coordinates (two passes for the radii)."""
    dt = np.diff(t)
    lat = np.full(len(t), lat0)
    h = h0 + np.concatenate([[0], np.cumsum(0.5 * (v[1:, 2] + v[:-1, 2]) * dt)])
    for _ in range(3):
        rm, rn = earth.radii(lat)
        latdot = v[:, 1] / (rm + h)
        lat = lat0 + np.concatenate([[0], np.cumsum(0.5 * (latdot[1:] + latdot[:-1]) * dt)])
    rm, rn = earth.radii(lat)
    londot = v[:, 0] / ((rn + h) * np.cos(lat))
    lon = lon0 + np.concatenate([[0], np.cumsum(0.5 * (londot[1:] + londot[:-1]) * dt)])
    return lat, lon, h
