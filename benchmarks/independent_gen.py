"""An independent IMU/GNSS recording generator for validating ``imu-sim diagnose`` on data it did not make.

It shares no code with ``imu_sim`` or ``nav_core`` (NumPy only): its own WGS-84 Earth model (geodetic <-> ECEF,
Somigliana normal gravity with the free-air height term), its own rotation convention (body x forward, y left, z up;
body-to-ENU = Rz(yaw) Ry(pitch) Rx(roll), the REP-103 order the truth CSV states), its own trajectories with
analytic derivatives (static poses, tumble, level rate table, figure-eight drive), and its own sensor effects.
Files are written the way a user writes them: CSV with 10 significant digits, truth at 100 Hz (or the IMU rate).

Kinematics from first principles, in ECEF: the position is an analytic curve p(t) in the tangent plane at the
origin, r_e = r0_e + C_e,enu0 p; the attitude is given relative to the *local* ENU at the current position. Then

    f^b   = C_b,e (a_e + 2 W x v_e - g_e(r_e))              g_e: normal gravity along minus the ellipsoid normal
    w_ib^b = C_b,n (W_n + w_en^n) + w_nb^b(Euler rates)      w_en^n = (-v_N/(M+h), v_E/(N+h), v_E tan(lat)/(N+h))

averaged over each sample interval (k-1) dt .. k dt by 3-point Gauss-Legendre quadrature (what an IMU that
integrates its increments reports), sample k stamped k dt.
"""
from __future__ import annotations

import numpy as np

A_WGS84 = 6378137.0
F_WGS84 = 1.0 / 298.257223563
E2 = F_WGS84 * (2.0 - F_WGS84)
B_WGS84 = A_WGS84 * (1.0 - F_WGS84)
GM = 3.986004418e14
OMEGA_E = 7.292115e-5
GAMMA_E, GAMMA_P = 9.7803253359, 9.8321849378
"""Normal gravity at the equator and the pole, m/s^2 (Somigliana)."""
G_STANDARD = 9.80665
GL_NODES = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
GL_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0


# ----------------------------------------------------------------------------- Earth


def ecef_from_geodetic(lat, lon, h):
    """ECEF (n, 3) m from geodetic latitude, longitude (rad) and ellipsoidal height (m)."""
    n = A_WGS84 / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
    return np.stack([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                     (n * (1.0 - E2) + h) * np.sin(lat)], axis=-1)


def geodetic_from_ecef(r):
    """(lat, lon, h) rad, rad, m from ECEF (n, 3), by fixed-point iteration on the latitude."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1.0 - E2))
    for _ in range(6):
        n = A_WGS84 / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1.0 - E2 * n / (n + h)))
    n = A_WGS84 / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
    return lat, lon, p / np.cos(lat) - n


def normal_gravity(lat, h):
    """Magnitude of normal gravity (m/s^2): Somigliana on the ellipsoid, second-order free-air term in h."""
    s2 = np.sin(lat) ** 2
    k = B_WGS84 * GAMMA_P / (A_WGS84 * GAMMA_E) - 1.0
    g0 = GAMMA_E * (1.0 + k * s2) / np.sqrt(1.0 - E2 * s2)
    m = OMEGA_E**2 * A_WGS84**2 * B_WGS84 / GM
    return g0 * (1.0 - 2.0 / A_WGS84 * (1.0 + F_WGS84 + m - 2.0 * F_WGS84 * s2) * h + 3.0 * h**2 / A_WGS84**2)


def enu_axes(lat, lon):
    """(n, 3, 3) matrices whose columns are the East, North, Up unit vectors in ECEF (C_e,enu)."""
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    east = np.stack([-so, co, np.zeros_like(so)], axis=-1)
    north = np.stack([-sl * co, -sl * so, cl], axis=-1)
    up = np.stack([cl * co, cl * so, sl], axis=-1)
    return np.stack([east, north, up], axis=-1)


def radii(lat):
    """Meridian (M) and prime-vertical (N) radii of curvature, m."""
    w = 1.0 - E2 * np.sin(lat) ** 2
    return A_WGS84 * (1.0 - E2) / w**1.5, A_WGS84 / np.sqrt(w)


# ----------------------------------------------------------------------------- rotations


def body_to_enu(roll, pitch, yaw):
    """(n, 3, 3) body-to-ENU matrices, Rz(yaw) Ry(pitch) Rx(roll), angles in rad."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    row0 = np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=-1)
    row1 = np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=-1)
    row2 = np.stack([-sp, cp * sr, cp * cr], axis=-1)
    return np.stack([row0, row1, row2], axis=-2)


def body_rate_from_euler_rates(roll, pitch, droll, dpitch, dyaw):
    """Body angular rate (n, 3) rad/s of the body relative to the ENU frame from Euler angles and their rates."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.stack([droll - dyaw * sp, dpitch * cr + dyaw * sr * cp, -dpitch * sr + dyaw * cr * cp], axis=-1)


# ----------------------------------------------------------------------------- motion


def smoothstep(u):
    """C1 step 0 -> 1 on u in [0, 1] (3u^2 - 2u^3) with its derivative and integral."""
    u = np.clip(u, 0.0, 1.0)
    return 3 * u**2 - 2 * u**3, 6 * u - 6 * u**2, u**3 - u**4 / 2


class Motion:
    """Analytic motion: plane position p, v, a (m, ENU at the origin) and Euler angles with their rates (rad)."""

    def __init__(self, duration_s: float):
        self.duration_s = duration_s

    def position(self, t):
        """p, v, a (n, 3) in the origin's tangent plane (static: zero)."""
        z = np.zeros((len(t), 3))
        return z, z.copy(), z.copy()

    def attitude(self, t):
        """(roll, pitch, yaw) and (droll, dpitch, dyaw), each a tuple of (n,) arrays."""
        raise NotImplementedError


class Poses(Motion):
    """Static poses held for ``hold_s`` (one for all, or one per pose) with smooth ``move_s`` transitions (Euler
    angles interpolated)."""

    def __init__(self, poses_deg, hold_s, move_s: float):
        self.poses = np.radians(np.asarray(poses_deg, float)).reshape(-1, 3)
        self.holds = np.broadcast_to(np.asarray(hold_s, float), (len(self.poses),)).copy()
        self.hold_s, self.move_s = hold_s, move_s
        self.starts = np.r_[0.0, np.cumsum(self.holds[:-1] + move_s)]
        super().__init__(float(self.holds.sum() + (len(self.poses) - 1) * move_s))

    def attitude(self, t):
        """Euler angles held, then smoothstep to the next pose."""
        i = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.poses) - 1)
        u = (t - self.starts[i] - self.holds[i]) / self.move_s
        s, ds, _ = smoothstep(u)
        j = np.minimum(i + 1, len(self.poses) - 1)
        ang = self.poses[i] + s[:, None] * (self.poses[j] - self.poses[i])
        rate = (ds / self.move_s)[:, None] * (self.poses[j] - self.poses[i])
        moving = (u > 0) & (u < 1)
        rate[~moving] = 0.0
        return tuple(ang.T), tuple(rate.T)


class RateTable(Motion):
    """Level table turning about the vertical: holds at ``rates_dps`` for ``hold_s``, ``ramp_s`` smooth ramps."""

    def __init__(self, rates_dps, hold_s: float, ramp_s: float, rest_s: float = 20.0):
        self.rates = np.radians(np.r_[0.0, np.asarray(rates_dps, float), 0.0])
        self.hold_s, self.ramp_s, self.rest_s = hold_s, ramp_s, rest_s
        # segment k: ramp from rates[k] to rates[k+1], then hold rates[k+1]
        self.seg = ramp_s + hold_s
        super().__init__(rest_s + (len(self.rates) - 1) * self.seg)

    def attitude(self, t):
        """Yaw is the integral of the rate profile (closed form per segment)."""
        tt = np.clip(t - self.rest_s, 0.0, None)
        k = np.minimum((tt // self.seg).astype(int), len(self.rates) - 2)
        tau = tt - k * self.seg
        r0, r1 = self.rates[k], self.rates[k + 1]
        s, _, s_int = smoothstep(tau / self.ramp_s)
        in_ramp = tau < self.ramp_s
        rate = np.where(in_ramp, r0 + (r1 - r0) * s, r1)
        # angle of each segment: ramp (r0 ramp_s + (r1 - r0) ramp_s * integral(smoothstep)) + r1 * hold
        seg_angle = self.rates[:-1] * self.ramp_s + (self.rates[1:] - self.rates[:-1]) * self.ramp_s * 0.5 \
            + self.rates[1:] * self.hold_s
        before = np.r_[0.0, np.cumsum(seg_angle)][k]
        within = np.where(in_ramp, r0 * tau + (r1 - r0) * self.ramp_s * s_int,
                          r0 * self.ramp_s + (r1 - r0) * self.ramp_s * 0.5 + r1 * (tau - self.ramp_s))
        yaw = np.where(t < self.rest_s, 0.0, before + within)
        rate = np.where(t < self.rest_s, 0.0, rate)
        z = np.zeros_like(t)
        return (z, z.copy(), yaw), (z.copy(), z.copy(), rate)


def ramp_step(u, shape: str):
    """Rate step 0 -> 1 on u in [0, 1] and its integral, for a table's ramp: ``linear`` (constant acceleration),
    ``smooth`` (cubic, C1) or ``quintic`` (C2); each integrates to 1/2 over the ramp."""
    u = np.clip(u, 0.0, 1.0)
    if shape == "linear":
        return u, u**2 / 2
    if shape == "smooth":
        s, _, s_int = smoothstep(u)
        return s, s_int
    return u**3 * (10 - 15 * u + 6 * u**2), u**4 * (2.5 - 3 * u + u**2)


class DwellTable(Motion):
    """Level table turning about the vertical: after a rest, dwells at ``rates_dps[k]`` for ``dwell_s[k]``, each
    reached by its own ramp (``ramp_s[k]`` long, shape ``shapes[k]`` of :func:`ramp_step`), then a ramp to rest
    and ``rest_s`` at rest. ``rates`` includes both rests (0)."""

    def __init__(self, rates_dps, dwell_s, ramp_s, shapes, rest_s: float = 20.0, mount_deg=(0.0, 0.0)):
        self.mount = np.radians(np.asarray(mount_deg, float))  # the unit's roll, pitch on the table (a mounting tilt)
        self.rates = np.radians(np.r_[0.0, np.asarray(rates_dps, float), 0.0])
        m = len(self.rates) - 1  # ramps
        self.ramps = np.broadcast_to(np.asarray(ramp_s, float), (m,)).copy()
        self.dwells = np.r_[np.broadcast_to(np.asarray(dwell_s, float), (m - 1,)), rest_s]
        self.shapes = list(shapes) if not isinstance(shapes, str) else [shapes] * m
        self.rest_s = rest_s
        self.starts = rest_s + np.r_[0.0, np.cumsum(self.ramps + self.dwells)[:-1]]
        seg_angle = self.rates[:-1] * self.ramps + 0.5 * (self.rates[1:] - self.rates[:-1]) * self.ramps \
            + self.rates[1:] * self.dwells
        self.before = np.r_[0.0, np.cumsum(seg_angle)]
        super().__init__(float(self.starts[-1] + self.ramps[-1] + self.dwells[-1]))

    def dwell_spans(self):
        """(t0, t1, rate rad/s) of each constant-rate dwell after a ramp (the last is the final rest)."""
        t0 = self.starts + self.ramps
        return [(float(a), float(a + d), float(r)) for a, d, r in zip(t0, self.dwells, self.rates[1:])]

    def attitude(self, t):
        """Yaw is the integral of the rate profile (closed form per ramp and dwell)."""
        t = np.asarray(t, float)
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.starts) - 1)
        tau = np.clip(t - self.starts[k], 0.0, None)
        r0, r1, ramp = self.rates[k], self.rates[k + 1], self.ramps[k]
        rate, within = np.empty_like(t), np.empty_like(t)
        for shape in set(self.shapes):
            m = np.array([self.shapes[j] == shape for j in k])
            s, s_int = ramp_step(tau[m] / ramp[m], shape)
            rate[m] = r0[m] + (r1[m] - r0[m]) * s
            within[m] = r0[m] * np.minimum(tau[m], ramp[m]) + (r1[m] - r0[m]) * ramp[m] * s_int
        after = tau > ramp
        rate[after] = r1[after]
        within[after] += r1[after] * (tau[after] - ramp[after])
        rest = t < self.rest_s
        yaw = np.where(rest, 0.0, self.before[k] + within)
        rate = np.where(rest, 0.0, rate)
        z = np.zeros_like(t)
        return (z + self.mount[0], z + self.mount[1], yaw), (z.copy(), z.copy(), rate)


def euler_of(c):
    """(roll, pitch, yaw) rad of one body-to-ENU matrix Rz(yaw) Ry(pitch) Rx(roll)."""
    return (float(np.arctan2(c[2, 1], c[2, 2])), float(-np.arcsin(np.clip(c[2, 0], -1.0, 1.0))),
            float(np.arctan2(c[1, 0], c[0, 0])))


def small_rotation(d):
    """Rotation matrix (3, 3) of the rotation vector d (rad), Rodrigues."""
    d = np.asarray(d, float)
    a = np.linalg.norm(d)
    if a == 0.0:
        return np.eye(3)
    k = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]]) / a
    return np.eye(3) + np.sin(a) * k + (1.0 - np.cos(a)) * k @ k


class MountedTable(Motion):
    """A level one-axis table turned with the unit in several mountings (each a :class:`DwellTable` run), the unit
    remounted by hand in ``move_s`` between them. Mounting k is the nominal ``(roll, pitch)`` of
    ``mounts_deg[k]`` (which body axis is up) times a small tilt ``tilts_rad[k]`` (rotation vector in body axes):
    the body-to-ENU attitude is Rz(table angle) R_nominal R(tilt)."""

    def __init__(self, tables, mounts_deg, tilts_rad, move_s: float = 5.0):
        self.tables, self.move_s, self.tilts = list(tables), move_s, np.asarray(tilts_rad, float)
        self.euler = []  # (roll, pitch, yaw offset) of R_nominal R(tilt) per mounting
        for (r, p), d in zip(mounts_deg, tilts_rad):
            nominal = body_to_enu(np.radians(r), np.radians(p), 0.0)
            self.euler.append(euler_of(nominal @ small_rotation(d)))
        self.starts = np.r_[0.0, np.cumsum([tb.duration_s + move_s for tb in self.tables[:-1]])]
        self.mounts_deg = [tuple(m) for m in mounts_deg]
        super().__init__(float(self.starts[-1] + self.tables[-1].duration_s))

    def _piece(self, k, t):
        """Angles and rates of mounting k's run at record times t (within it)."""
        (_, _, yaw), (_, _, rate) = self.tables[k].attitude(t - self.starts[k])
        r, p, y0 = self.euler[k]
        z = np.zeros_like(t)
        return (z + r, z + p, yaw + y0 + self.yaw0(k)), (z.copy(), z.copy(), rate)

    def yaw0(self, k):
        """The table angle (rad) at the start of mounting k: where the previous runs left it."""
        return float(sum(self.tables[j].attitude(np.array([self.tables[j].duration_s]))[0][2][0] for j in range(k)))

    def attitude(self, t):
        """Each run's own attitude; across a remount the Euler angles blend smoothly (table at rest)."""
        t = np.asarray(t, float)
        ang, rate = [np.zeros_like(t) for _ in range(3)], [np.zeros_like(t) for _ in range(3)]
        for k, t0 in enumerate(self.starts):
            end = t0 + self.tables[k].duration_s
            m = (t >= t0) & (t <= end) if k == 0 else (t > t0) & (t <= end)
            if m.any():
                a, w = self._piece(k, t[m])
                for i in range(3):
                    ang[i][m], rate[i][m] = a[i], w[i]
            if k + 1 < len(self.starts):
                mv = (t > end) & (t <= self.starts[k + 1])
                if mv.any():
                    a0 = np.array(self._piece(k, np.array([end]))[0])[:, 0]
                    a1 = np.array(self._piece(k + 1, np.array([self.starts[k + 1]]))[0])[:, 0]
                    a1[2] = a0[2] + (a1[2] - a0[2] + np.pi) % (2 * np.pi) - np.pi
                    s, ds, _ = smoothstep((t[mv] - end) / self.move_s)
                    for i in range(3):
                        ang[i][mv] = a0[i] + s * (a1[i] - a0[i])
                        rate[i][mv] = ds / self.move_s * (a1[i] - a0[i])
        if t.size and t[-1] > self.starts[-1] + self.tables[-1].duration_s:
            m = t > self.starts[-1] + self.tables[-1].duration_s
            a, w = self._piece(len(self.tables) - 1, np.full(m.sum(), self.starts[-1] + self.tables[-1].duration_s))
            for i in range(3):
                ang[i][m], rate[i][m] = a[i], 0.0 * w[i]
        return tuple(ang), tuple(rate)


class FigureEight(Motion):
    """Level figure-eight (Lissajous 1:2), body x along the velocity: x = A sin(w t), y = B sin(2 w t)."""

    def __init__(self, duration_s: float, period_s: float = 240.0, a_m: float = 600.0, b_m: float = 300.0):
        self.w, self.a, self.b = 2 * np.pi / period_s, a_m, b_m
        super().__init__(duration_s)

    def position(self, t):
        """Plane position, velocity and acceleration (n, 3)."""
        w, a, b = self.w, self.a, self.b
        z = np.zeros_like(t)
        p = np.stack([a * np.sin(w * t), b * np.sin(2 * w * t), z], axis=-1)
        v = np.stack([a * w * np.cos(w * t), 2 * b * w * np.cos(2 * w * t), z], axis=-1)
        acc = np.stack([-a * w**2 * np.sin(w * t), -4 * b * w**2 * np.sin(2 * w * t), z], axis=-1)
        return p, v, acc

    def attitude(self, t):
        """Heading along the plane velocity, its rate (x'y'' - y'x'') / |v|^2; level."""
        _, v, acc = self.position(t)
        yaw = np.arctan2(v[:, 1], v[:, 0])
        dyaw = (v[:, 0] * acc[:, 1] - v[:, 1] * acc[:, 0]) / (v[:, 0] ** 2 + v[:, 1] ** 2)
        z = np.zeros_like(t)
        return (z, z.copy(), yaw), (z.copy(), z.copy(), dyaw)


def _quintic(u):
    """Quintic step 0 -> 1 on u in [0, 1] with its first two derivatives (zero at both ends)."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u**2), 30 * u**2 * (1 - u) ** 2, 60 * u * (1 - u) * (1 - 2 * u)


STOP_AND_GO = [("stand", 8, 0), ("speed", 12, 12), ("cruise", 12, 0), ("turn", 15, 90), ("cruise", 8, 0),
               ("speed", 12, 0), ("stand", 6, 0), ("speed", 15, 15), ("cruise", 10, 0), ("turn", 24, -120),
               ("cruise", 6, 0), ("speed", 9, 6), ("turn", 6, 60), ("speed", 8, 14), ("cruise", 10, 0),
               ("speed", 14, 0), ("stand", 5, 0)]
"""A town drive's legs: (kind, duration s, target speed m/s or turn angle deg); quintic speed and heading steps."""


class StopAndGo(Motion):
    """A town drive: stops, quintic speed changes (<= 2 m/s^2) and turns (lateral <= 2.5 m/s^2), hills (grade
    +-3 %, periods 90 and 37 s, only while moving), body roll 0.5 deg per m/s^2 of lateral acceleration, nose on
    the course and the grade. The legs repeat to fill ``duration_s``. Speed, heading, grade, their derivatives and
    the attitude are closed form; position is their velocity integrated by 8-node Gauss-Legendre per 10 ms."""

    ROLL_PER_MPS2 = np.radians(0.5)

    def __init__(self, duration_s: float, legs=STOP_AND_GO):
        super().__init__(duration_s)
        starts, t0, v, yaw = [], 0.0, 0.0, 0.0
        while t0 < duration_s + 1.0:
            for kind, dur, val in legs:
                v_end = float(val) if kind == "speed" else v
                d_yaw = np.radians(val) if kind == "turn" else 0.0
                starts.append((t0, float(dur), v, v_end, yaw, d_yaw))
                t0, v, yaw = t0 + dur, v_end, yaw + d_yaw
        self.legs = starts
        self.grid = np.arange(0.0, duration_s + 1.0, 0.01)
        x, w = np.polynomial.legendre.leggauss(8)
        mid, half = (self.grid[1:] + self.grid[:-1]) / 2, 0.005
        nodes = (mid[:, None] + half * x[None, :]).ravel()
        vel = self._vel_acc(nodes)[0].reshape(len(mid), 8, 3)
        steps = half * np.einsum("nkj,k->nj", vel, w)
        self.p_grid = np.vstack([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
        self._gl = (x, w)

    def _profiles(self, t):
        """Speed, heading, grade and their first two time derivatives, each (n,)."""
        sp, ds, dds = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        yaw, dy, ddy = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        for t0, dur, v0, v1, y0, dyaw in self.legs:
            m = (t >= t0) & (t < t0 + dur)
            if not np.any(m):
                continue
            f, f1, f2 = _quintic((t[m] - t0) / dur)
            sp[m], ds[m], dds[m] = v0 + (v1 - v0) * f, (v1 - v0) * f1 / dur, (v1 - v0) * f2 / dur**2
            yaw[m], dy[m], ddy[m] = y0 + dyaw * f, dyaw * f1 / dur, dyaw * f2 / dur**2
        w1, w2 = 2 * np.pi / 90.0, 2 * np.pi / 37.0
        g = 0.02 * np.sin(w1 * t) + 0.01 * np.sin(w2 * t + 1.0)
        dg = 0.02 * w1 * np.cos(w1 * t) + 0.01 * w2 * np.cos(w2 * t + 1.0)
        return sp, ds, dds, yaw, dy, ddy, g, dg

    def _vel_acc(self, t):
        sp, ds, _, yaw, dy, _, g, dg = self._profiles(t)
        c, s = np.cos(yaw), np.sin(yaw)
        v = np.stack([sp * c, sp * s, sp * g], axis=-1)
        a = np.stack([ds * c - sp * s * dy, ds * s + sp * c * dy, ds * g + sp * dg], axis=-1)
        return v, a

    def position(self, t):
        """Plane position, velocity and acceleration (n, 3)."""
        t = np.asarray(t, float)
        k = np.clip(np.searchsorted(self.grid, t, side="right") - 1, 0, len(self.grid) - 2)
        lo = self.grid[k]
        x, w = self._gl
        half = (t - lo) / 2
        nodes = (lo + half)[:, None] + half[:, None] * x[None, :]
        vel = self._vel_acc(nodes.ravel())[0].reshape(len(t), len(x), 3)
        p = self.p_grid[k] + half[:, None] * np.einsum("nkj,k->nj", vel, w)
        v, a = self._vel_acc(t)
        return p, v, a

    def attitude(self, t):
        """Yaw on the heading, pitch on the grade (nose up: negative about body y in Rz Ry Rx), roll from the
        lateral acceleration; with their rates."""
        t = np.asarray(t, float)
        sp, ds, _, yaw, dy, ddy, g, dg = self._profiles(t)
        lat = sp * dy
        dlat = ds * dy + sp * ddy
        roll, droll = -self.ROLL_PER_MPS2 * lat, -self.ROLL_PER_MPS2 * dlat
        pitch, dpitch = -np.arctan(g), -dg / (1 + g**2)
        return (roll, pitch, yaw), (droll, dpitch, dy)


# ----------------------------------------------------------------------------- truth and ideal IMU


class Site:
    """The origin: geodetic latitude, longitude (deg), height (m)."""

    def __init__(self, lat_deg: float, lon_deg: float, h_m: float):
        self.lat, self.lon, self.h = np.radians(lat_deg), np.radians(lon_deg), h_m
        self.r0 = ecef_from_geodetic(self.lat, self.lon, self.h)
        self.c_e_enu0 = enu_axes(np.array(self.lat), np.array(self.lon))

    def state(self, motion: Motion, t):
        """Geodetic position, ECEF velocity/acceleration, local-ENU velocity, body-to-ECEF rotation, Euler."""
        p, v, acc = motion.position(t)
        r = self.r0 + p @ self.c_e_enu0.T
        v_e, a_e = v @ self.c_e_enu0.T, acc @ self.c_e_enu0.T
        lat, lon, h = geodetic_from_ecef(r)
        c_e_n = enu_axes(lat, lon)
        v_n = np.einsum("nji,nj->ni", c_e_n, v_e)
        ang, rates = motion.attitude(t)
        c_n_b = body_to_enu(*ang)
        return dict(r=r, lat=lat, lon=lon, h=h, v_e=v_e, a_e=a_e, v_n=v_n, c_e_n=c_e_n, c_n_b=c_n_b,
                    ang=ang, rates=rates)

    def true_imu_at(self, motion: Motion, t):
        """True body rate w_ib^b (rad/s) and specific force f^b (m/s^2), each (n, 3), at instants t."""
        s = self.state(motion, t)
        c_e_b = np.einsum("nij,njk->nik", s["c_e_n"], s["c_n_b"])
        w_e = np.array([0.0, 0.0, OMEGA_E])
        g_e = -normal_gravity(s["lat"], s["h"])[:, None] * s["c_e_n"][:, :, 2]
        f_e = s["a_e"] + 2.0 * np.cross(w_e, s["v_e"]) - g_e
        f_b = np.einsum("nji,nj->ni", c_e_b, f_e)
        m, n = radii(s["lat"])
        ve, vn = s["v_n"][:, 0], s["v_n"][:, 1]
        w_en = np.stack([-vn / (m + s["h"]), ve / (n + s["h"]), ve * np.tan(s["lat"]) / (n + s["h"])], axis=-1)
        w_ie_n = np.einsum("nji,j->ni", s["c_e_n"], w_e)
        roll, pitch, _ = s["ang"]
        w_nb = body_rate_from_euler_rates(roll, pitch, *s["rates"])
        w_b = np.einsum("nji,nj->ni", s["c_n_b"], w_ie_n + w_en) + w_nb
        return w_b, f_b

    def true_imu(self, motion: Motion, rate_hz: float):
        """Interval means of (w_ib^b, f^b) for samples k = 1..N stamped k dt; returns t, gyro, accel."""
        dt = 1.0 / rate_hz
        n = int(np.floor(motion.duration_s * rate_hz + 1e-9))
        t = dt * np.arange(1, n + 1)
        gyro, accel = np.zeros((n, 3)), np.zeros((n, 3))
        for node, weight in zip(GL_NODES, GL_WEIGHTS):
            w, f = self.true_imu_at(motion, t - dt / 2 + node * dt / 2)
            gyro += weight * w
            accel += weight * f
        return t, gyro, accel

    def truth_rows(self, motion: Motion, rate_hz: float, lever_arm_m=None, t=None):
        """Truth table at t = 0, 1/rate, ...: t, lat_deg, lon_deg, h_m, roll/pitch/yaw_deg, ve, vn, vu."""
        if t is None:
            t = np.arange(0, int(np.floor(motion.duration_s * rate_hz + 1e-9)) + 1) / rate_hz
        s = self.state(motion, t)
        r = s["r"]
        if lever_arm_m is not None:
            r = r + np.einsum("nij,njk,k->ni", s["c_e_n"], s["c_n_b"], np.asarray(lever_arm_m, float))
        lat, lon, h = geodetic_from_ecef(r)
        yaw = (np.degrees(s["ang"][2]) + 180.0) % 360.0 - 180.0
        return {"t": t, "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon), "h_m": h,
                "roll_deg": np.degrees(s["ang"][0]), "pitch_deg": np.degrees(s["ang"][1]), "yaw_deg": yaw,
                "ve": s["v_n"][:, 0], "vn": s["v_n"][:, 1], "vu": s["v_n"][:, 2]}

    def enu_offset(self, lat, lon, h):
        """ENU (n, 3) m of geodetic points relative to the origin (for GNSS noise in metres)."""
        return (ecef_from_geodetic(lat, lon, h) - self.r0) @ self.c_e_enu0


# ----------------------------------------------------------------------------- sensor errors


def gauss_markov(rng, n: int, dt: float, sigma, tau_s):
    """First-order Gauss-Markov (n, k): stationary std sigma, correlation time tau (exact AR(1) steps)."""
    sigma, tau_s = np.atleast_1d(np.asarray(sigma, float)), np.atleast_1d(np.asarray(tau_s, float))
    phi = np.exp(-dt / tau_s)
    x = np.zeros((n, len(sigma)))
    x[0] = rng.normal(0, sigma)
    step = sigma * np.sqrt(1 - phi**2)
    e = rng.normal(size=(n, len(sigma))) * step
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


def flicker(rng, n: int, dt: float, b) -> np.ndarray:
    """Flicker (1/f) noise (n, k) with two-sided PSD b^2 / (2 pi |f|) (one-sided b^2 / (pi f)), by shaping white
    noise in the frequency domain over 8 n samples (so the record holds power below 1/(n dt)) and keeping n."""
    b = np.atleast_1d(np.asarray(b, float))
    m = 8 * n
    spec = np.fft.rfft(rng.normal(size=(m, len(b))), axis=0)
    f = np.fft.rfftfreq(m, dt)
    gain = np.zeros_like(f)
    gain[1:] = np.sqrt(1.0 / (2 * np.pi * f[1:] * dt))  # white N(0, 1) samples have two-sided PSD dt
    x = np.fft.irfft(spec * gain[:, None], n=m, axis=0)[:n]
    return x * b


def slow_wander(rng, t, amp_range, period_range, k: int = 3) -> np.ndarray:
    """Sum of ``k`` sinusoids per column (3 columns): amplitudes and periods drawn uniformly in the ranges, random
    phases; returns the value and its first two derivatives, each (n, 3)."""
    out = np.zeros((3, len(t), 3))
    for col in range(3):
        for _ in range(k):
            a, p, ph = rng.uniform(*amp_range) / np.sqrt(k), rng.uniform(*period_range), rng.uniform(0, 2 * np.pi)
            w = 2 * np.pi / p
            out[0, :, col] += a * np.sin(w * t + ph)
            out[1, :, col] += a * w * np.cos(w * t + ph)
            out[2, :, col] -= a * w**2 * np.sin(w * t + ph)
    return out


def interval_mean_sin(t_end, dt, freq_hz, phase):
    """Mean of sin(2 pi f t + phase) over each (t - dt, t]."""
    w = 2 * np.pi * freq_hz
    return (np.cos(w * (t_end - dt) + phase) - np.cos(w * t_end + phase)) / (w * dt)


def quantize_increments(x, dt, lsb):
    """Output of a sensor that counts increments in steps of ``lsb`` (rad or m/s) and carries the remainder."""
    counts = np.round(np.cumsum(x * dt, axis=0) / lsb)
    return np.diff(np.vstack([np.zeros((1, x.shape[1])), counts]), axis=0) * lsb / dt


def write_csv(path, columns: dict, digits: int = 10):
    """Write a CSV with a header row, every value with ``digits`` significant digits (as a user would)."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[k], float) for k in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=f"%.{digits}g")
    return path


class HandTurns(Motion):
    """Static poses (Euler angles, rad) held for ``holds`` s each, turned by hand between them: each move has its
    own duration, a monotone but uneven profile (a smoothstep of u^p or of 1 - (1 - u)^p, p in [1, 2.5]) and a
    sideways wobble (amplitude in rad per Euler angle, sin^2 in u, zero rate at both ends), none of which a
    scenario of static segments states."""

    def __init__(self, poses_rad, holds, moves, shapes, wobbles):
        self.poses = np.asarray(poses_rad, float).reshape(-1, 3)
        self.holds, self.moves = np.asarray(holds, float), np.asarray(moves, float)
        self.shapes, self.wobbles = list(shapes), np.asarray(wobbles, float).reshape(-1, 3)
        self.starts = np.r_[0.0, np.cumsum(self.holds[:-1] + self.moves)]
        super().__init__(float(self.holds.sum() + self.moves.sum()))

    def hold_spans(self):
        """[(t0, t1)] of each hold, s."""
        return [(float(a), float(a + h)) for a, h in zip(self.starts, self.holds)]

    def attitude(self, t):
        """Held pose, or the move's uneven profile plus its wobble, with the Euler rates."""
        t = np.asarray(t, float)
        i = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.poses) - 1)
        ang, rate = self.poses[i].copy(), np.zeros((len(t), 3))
        mv = np.minimum(i, len(self.moves) - 1)
        u = (t - self.starts[i] - self.holds[i]) / self.moves[mv]
        moving = (u > 0) & (u < 1) & (i < len(self.poses) - 1)
        for k in np.unique(i[moving]):
            m = moving & (i == k)
            uu, (p, flip), dur = u[m], self.shapes[k], self.moves[k]
            v, dv = (1 - (1 - uu) ** p, p * (1 - uu) ** (p - 1)) if flip else (uu**p, p * uu ** (p - 1))
            s, ds, _ = smoothstep(v)
            delta = self.poses[k + 1] - self.poses[k]
            wob, dwob = np.sin(np.pi * uu) ** 2, np.pi * np.sin(2 * np.pi * uu)
            ang[m] = self.poses[k] + s[:, None] * delta + wob[:, None] * self.wobbles[k]
            rate[m] = ((ds * dv)[:, None] * delta + dwob[:, None] * self.wobbles[k]) / dur
        return tuple(ang.T), tuple(rate.T)
