"""Attitude as smooth functions of time: body-to-ENU rotation and body rate relative to ENU.

Two kinds: :class:`QuatSplineAttitude` (a quintic spline through quaternion
samples, for vehicles) and :class:`PiecewiseAttitude` (holds, constant-rate
spins and smooth moves between them, for static multi-position and rate-table
sequences; no gimbal lock, exact body rates). Both provide ``rotation(t)``
(:class:`scipy.spatial.transform.Rotation`, body to ENU) and ``rate_b(t)``
(omega_nb^b, rad/s, shape (n, 3)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BPoly, make_interp_spline
from scipy.spatial.transform import Rotation

from nav_core.frames import skew


def interp_degree(n_samples: int) -> int:
    """Spline degree for an interpolating spline through n samples: quintic when possible."""
    if n_samples < 2:
        raise ValueError("need at least 2 samples for a spline")
    return 5 if n_samples >= 6 else (3 if n_samples >= 4 else 1)


def align_quat_signs(quat_xyzw: np.ndarray) -> np.ndarray:
    """Flip quaternion signs so consecutive samples lie in the same hemisphere (continuous spline)."""
    q = np.array(quat_xyzw, dtype=float)
    flips = np.concatenate([[False], np.einsum("ij,ij->i", q[1:], q[:-1]) < 0])
    sign = np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)
    return q * sign[:, None]


def body_rate_from_quat(quat_xyzw: np.ndarray, quat_dot: np.ndarray) -> np.ndarray:
    """Body rate omega_b = 2 vec(q* (x) q_dot) in rad/s for unit q (x, y, z, w) and its derivative."""
    v, w = quat_xyzw[:, :3], quat_xyzw[:, 3:]
    vd, wd = quat_dot[:, :3], quat_dot[:, 3:]
    return 2.0 * (w * vd - wd * v - np.cross(v, vd))


class QuatSplineAttitude:
    """Quintic interpolating spline through quaternion samples, renormalised; exact body rate of that curve."""

    def __init__(self, t: np.ndarray, rotation: Rotation):
        t = np.asarray(t, dtype=float)
        q = align_quat_signs(rotation.as_quat())
        self.t0, self.t1 = float(t[0]), float(t[-1])
        self._spline = make_interp_spline(t, q, k=interp_degree(len(t)))

    def _s(self, t, nu=0):
        return self._spline(np.clip(np.asarray(t, float), self.t0, self.t1), nu)

    def rotation(self, t) -> Rotation:
        """Body-to-ENU rotation at times t (s)."""
        return Rotation.from_quat(self._s(t))

    def rate_b(self, t) -> np.ndarray:
        """omega_nb^b in rad/s, shape (n, 3); zero outside the spline's time span."""
        return self.rotation_and_rate(t)[1]

    def rotation_and_rate(self, t):
        """(body-to-ENU Rotation, omega_nb^b rad/s (n, 3)) with one spline evaluation."""
        t = np.atleast_1d(np.asarray(t, float))
        s, sd = self._s(t), self._s(t, 1)
        norm = np.linalg.norm(s, axis=1, keepdims=True)
        q = s / norm
        qd = (sd - q * np.einsum("ij,ij->i", q, sd)[:, None]) / norm
        out = body_rate_from_quat(q, qd)
        out[(t < self.t0) | (t > self.t1)] = 0.0
        return Rotation.from_quat(q), out


def right_jacobian(phi: np.ndarray) -> np.ndarray:
    """SO(3) right Jacobian J_r(phi), shape (n, 3, 3): body rate = J_r(phi) phi_dot for R = R_a exp(phi)."""
    phi = np.atleast_2d(phi)
    theta = np.linalg.norm(phi, axis=1)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    c1 = np.where(small, 0.5 - theta**2 / 24, (1 - np.cos(th)) / th**2)
    c2 = np.where(small, 1.0 / 6 - theta**2 / 120, (th - np.sin(th)) / th**3)
    k = skew(phi)
    return np.eye(3) - c1[:, None, None] * k + c2[:, None, None] * (k @ k)


@dataclass
class AttitudePiece:
    """One piece on [ta, tb]: a spin ``R0 exp((t-ta) rate_b)`` or a move ``R0 exp(phi(t))`` (phi a BPoly list)."""

    ta: float
    tb: float
    rot0: Rotation
    rate_b: np.ndarray
    phi: tuple | None = None


class PiecewiseAttitude:
    """Holds/constant-rate spins on given spans, joined by C2 moves (quintic in rotation-vector space)."""

    def __init__(self, spans):
        """``spans``: list of (t0 s, t1 s, start Rotation, body rate rad/s (3,)), sorted, not overlapping."""
        self.pieces = []
        prev = None
        for t0, t1, rot0, rate in spans:
            rate = np.asarray(rate, float)
            if prev is not None:
                if t0 < prev.tb:
                    raise ValueError(f"attitude spans overlap or are unsorted at t={t0}")
                if t0 > prev.tb:
                    self.pieces.append(self._move(prev, t0, rot0, rate))
            piece = AttitudePiece(float(t0), float(t1), rot0, rate)
            self.pieces.append(piece)
            prev = piece
        self.t0, self.t1 = self.pieces[0].ta, self.pieces[-1].tb

    @staticmethod
    def _move(prev: AttitudePiece, tb: float, rot_b: Rotation, rate_b: np.ndarray) -> AttitudePiece:
        rot_a = prev.rot0 * Rotation.from_rotvec(prev.rate_b * (prev.tb - prev.ta))
        phi_end = (rot_a.inv() * rot_b).as_rotvec()
        phi_dot_end = np.linalg.solve(right_jacobian(phi_end)[0], rate_b)
        span = tb - prev.tb
        polys = tuple(BPoly.from_derivatives([0.0, span], [[0.0, prev.rate_b[i], 0.0],
                                                           [phi_end[i], phi_dot_end[i], 0.0]])
                      for i in range(3))
        return AttitudePiece(prev.tb, tb, rot_a, np.zeros(3), polys)

    def _each(self, t):
        t = np.clip(np.atleast_1d(np.asarray(t, float)), self.t0, self.t1)
        idx = np.clip(np.searchsorted([p.tb for p in self.pieces], t, side="left"), 0, len(self.pieces) - 1)
        return t, idx

    def rotation(self, t) -> Rotation:
        """Body-to-ENU rotation at times t (s) (held before the first and after the last span)."""
        t, idx = self._each(t)
        quat = np.empty((len(t), 4))
        for i in np.unique(idx):
            p, m = self.pieces[i], idx == i
            tau = t[m] - p.ta
            if p.phi is None:
                quat[m] = (p.rot0 * Rotation.from_rotvec(np.outer(tau, p.rate_b))).as_quat()
            else:
                phi = np.column_stack([poly(tau) for poly in p.phi])
                quat[m] = (p.rot0 * Rotation.from_rotvec(phi)).as_quat()
        return Rotation.from_quat(quat)

    def rotation_and_rate(self, t):
        """(body-to-ENU Rotation, omega_nb^b rad/s (n, 3))."""
        return self.rotation(t), self.rate_b(t)

    def rate_b(self, t) -> np.ndarray:
        """omega_nb^b in rad/s, shape (n, 3)."""
        t_raw = np.atleast_1d(np.asarray(t, float))
        t, idx = self._each(t_raw)
        out = np.empty((len(t), 3))
        for i in np.unique(idx):
            p, m = self.pieces[i], idx == i
            if p.phi is None:
                out[m] = p.rate_b
            else:
                tau = t[m] - p.ta
                phi = np.column_stack([poly(tau) for poly in p.phi])
                phi_dot = np.column_stack([poly(tau, 1) for poly in p.phi])
                out[m] = np.einsum("nij,nj->ni", right_jacobian(phi), phi_dot)
        out[(t_raw < self.t0) | (t_raw > self.t1)] = 0.0
        return out
