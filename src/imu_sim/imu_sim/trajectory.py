"""Truth trajectories: smooth position and attitude you can evaluate (with derivatives) at any time.

Position is a spline in the tangent-plane ENU frame at the datum (``LocalFrame``),
which maps to ECEF affinely, so ECEF velocity and acceleration are exact spline
derivatives. Attitude is an :mod:`imu_sim.attitude` object. Builders: road
segments and the paper's default drive, a fit through a real GNSS track, a
truth CSV, and static multi-position / rate-table sequences.
"""
from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import UnivariateSpline, make_interp_spline

from nav_core import earth
from nav_core.earth import LocalFrame
from nav_core.frames import euler_from_rotation, rotation_from_euler
from nav_core.recording import Trajectory
from nav_core.units import DEG

LOG = logging.getLogger(__name__)

from imu_sim.attitude import PiecewiseAttitude, QuatSplineAttitude, interp_degree

ROLL_PER_LATERAL_ACCEL = 0.6 * DEG / 1.0
"""Vehicle body roll, rad per m/s^2 of leftward (centripetal) acceleration: a soft car suspension."""
MIN_COURSE_SPEED = 1.0
"""Below this ground speed (m/s) the course is undefined and yaw/pitch are held."""
KNOT_SPACING_S = 0.1
"""Sample spacing (s) of the dense points the position and attitude splines interpolate."""


class EnuSplinePosition:
    """Tangent-plane ENU position (m) at the datum as a vector spline; ``enu(t, nu)`` is its nu-th derivative."""

    def __init__(self, t: np.ndarray, enu_m: np.ndarray):
        self.t0, self.t1 = float(t[0]), float(t[-1])
        self._spline = make_interp_spline(np.asarray(t, float), np.asarray(enu_m, float), k=interp_degree(len(t)))

    def enu(self, t, nu: int = 0) -> np.ndarray:
        """nu-th time derivative of the ENU position in m/s^nu, shape (n, 3); held outside the span."""
        t = np.atleast_1d(np.asarray(t, float))
        out = self._spline(np.clip(t, self.t0, self.t1), nu)
        if nu > 0:
            out[(t < self.t0) | (t > self.t1)] = 0.0
        return out


class ComponentSplinePosition:
    """Tangent-plane ENU position from three scalar splines (e.g. smoothing splines through GNSS fixes)."""

    def __init__(self, splines, t0: float, t1: float):
        self.splines, self.t0, self.t1 = splines, float(t0), float(t1)

    def enu(self, t, nu: int = 0) -> np.ndarray:
        """nu-th time derivative of the ENU position, shape (n, 3)."""
        t = np.atleast_1d(np.asarray(t, float))
        tc = np.clip(t, self.t0, self.t1)
        out = np.column_stack([s(tc, nu) if nu else s(tc) for s in self.splines])
        if nu > 0:
            out[(t < self.t0) | (t > self.t1)] = 0.0
        return out


@dataclass
class TruthTrajectory:
    """A truth trajectory: datum, position model, attitude model, time span (s)."""

    frame: LocalFrame
    position: object
    attitude: object
    t0: float
    t1: float

    @property
    def duration(self) -> float:
        """Length in s."""
        return self.t1 - self.t0

    def geodetic(self, t):
        """(lat rad, lon rad, h m) at times t."""
        lat_deg, lon_deg, h = self.frame.to_geodetic(self.position.enu(t))
        return lat_deg * DEG, lon_deg * DEG, h

    def mat_e_enu0(self) -> np.ndarray:
        """Rotation tangent-plane ENU at the datum -> ECEF."""
        return earth.mat_ne(self.frame.lat0_deg * DEG, self.frame.lon0_deg * DEG).T

    def velocity_n(self, t, lat=None, lon=None) -> np.ndarray:
        """Ground velocity in the local-level ENU frame at the current point, m/s, shape (n, 3)."""
        if lat is None:
            lat, lon, _ = self.geodetic(t)
        v_e = self.position.enu(t, 1) @ self.mat_e_enu0().T
        return np.einsum("nij,nj->ni", earth.mat_ne(lat, lon), v_e)

    def sample(self, t) -> Trajectory:
        """The truth at times t (s) as a nav_core :class:`Trajectory` (for the truth CSV)."""
        t = np.atleast_1d(np.asarray(t, float))
        lat, lon, h = self.geodetic(t)
        with warnings.catch_warnings():  # pitch +-90 deg (multi-position) has no unique roll/yaw split
            warnings.filterwarnings("ignore", message="Gimbal lock detected")
            roll, pitch, yaw = euler_from_rotation(self.attitude.rotation(t))
        return Trajectory(t, lat, lon, h, roll, pitch, yaw, self.velocity_n(t, lat, lon))


# ----------------------------------------------------------------------------- vehicle attitude


def vehicle_euler(velocity_n: np.ndarray, accel_n: np.ndarray, yaw_hint=None):
    """Roll, pitch, yaw (rad) of a car: yaw from course, pitch from grade, roll from lateral acceleration.

    Where the ground speed is below :data:`MIN_COURSE_SPEED` yaw and pitch are held
    (``yaw_hint`` (n,) replaces the course when given).
    """
    speed_h = np.hypot(velocity_n[:, 0], velocity_n[:, 1])
    moving = speed_h > MIN_COURSE_SPEED
    if yaw_hint is None:
        yaw = _hold(np.arctan2(velocity_n[:, 1], velocity_n[:, 0]), moving, unwrap=True)
    else:
        yaw = np.asarray(yaw_hint, float)
    pitch = _hold(np.arctan2(velocity_n[:, 2], np.maximum(speed_h, 1e-9)), moving)
    left = np.column_stack([-np.sin(yaw), np.cos(yaw)])
    roll = ROLL_PER_LATERAL_ACCEL * np.einsum("ij,ij->i", accel_n[:, :2], left)
    return roll, pitch, yaw


def _hold(values: np.ndarray, valid: np.ndarray, unwrap: bool = False) -> np.ndarray:
    """Forward-fill (then back-fill) values where ``valid`` is False; optional angle unwrap."""
    if not np.any(valid):
        return np.zeros_like(values)
    idx = np.where(valid, np.arange(len(values)), 0)
    np.maximum.accumulate(idx, out=idx)
    first = np.argmax(valid)
    idx[:first] = first
    out = values[idx]
    return np.unwrap(out) if unwrap else out


def trajectory_from_enu(frame: LocalFrame, t: np.ndarray, enu_m: np.ndarray, yaw_hint=None,
                        position=None) -> TruthTrajectory:
    """A car trajectory through ENU points (m) at times t (s), attitude from the vehicle model."""
    position = position or EnuSplinePosition(t, enu_m)
    traj = TruthTrajectory(frame, position, None, float(t[0]), float(t[-1]))
    lat, lon, _ = traj.geodetic(t)
    c_ne = earth.mat_ne(lat, lon)
    m = traj.mat_e_enu0()
    v_n = np.einsum("nij,nj->ni", c_ne, position.enu(t, 1) @ m.T)
    a_n = np.einsum("nij,nj->ni", c_ne, position.enu(t, 2) @ m.T)
    roll, pitch, yaw = vehicle_euler(v_n, a_n, yaw_hint)
    traj.attitude = QuatSplineAttitude(t, rotation_from_euler(roll, pitch, yaw))
    return traj


# ----------------------------------------------------------------------------- road segments


def _smoothstep(tau):
    """Quintic smoothstep on [0, 1]: zero first and second derivatives at both ends."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


SEGMENT_TYPES = ("stand", "accelerate", "cruise", "turn", "stop")


def _segment_profiles(segments, t: np.ndarray, yaw0: float):
    """Speed (m/s) and yaw (rad) on grid t for a list of segment mappings."""
    speed = np.zeros_like(t)
    yaw = np.full_like(t, yaw0)
    t_start, v_now, yaw_now = 0.0, 0.0, yaw0
    for i, seg in enumerate(segments):
        kind, dur = seg.get("type"), float(seg.get("duration_s", 0.0))
        if kind not in SEGMENT_TYPES:
            raise ValueError(f"segments[{i}].type: {kind!r} is not one of {SEGMENT_TYPES}")
        if not dur > 0:
            raise ValueError(f"segments[{i}].duration_s: must be > 0, got {dur}")
        m = slice(np.searchsorted(t, t_start), np.searchsorted(t, t_start + dur))
        tau = (t[m] - t_start) / dur
        v_end = {"accelerate": float(seg.get("speed_mps", v_now)), "stop": 0.0}.get(kind, v_now)
        speed[m] = v_now + (v_end - v_now) * _smoothstep(tau)
        d_yaw = float(seg.get("angle_deg", 0.0)) * DEG if kind == "turn" else 0.0
        yaw[m] = yaw_now + d_yaw * _smoothstep(tau)
        t_start, v_now, yaw_now = t_start + dur, v_end, yaw_now + d_yaw
    after = t >= t_start
    speed[after], yaw[after] = v_now, yaw_now
    return speed, yaw, t_start


def segments_trajectory(segments, lat0_deg: float, lon0_deg: float, h0_m: float = 0.0,
                        yaw0_deg: float = 0.0) -> TruthTrajectory:
    """A level road drive from segments (stand/accelerate/cruise/turn/stop), starting at the datum.

    Each segment: ``type``, ``duration_s``; ``speed_mps`` for accelerate; ``angle_deg``
    (REP-103, + = left) for turn. Transitions are quintic smoothsteps, so acceleration
    and yaw rate are continuous. The car stays at height ``h0_m`` above the ellipsoid.
    """
    fine = 0.01
    total = sum(float(s.get("duration_s", 0.0)) for s in segments)
    t_fine = np.arange(0.0, total + fine / 2, fine)
    speed, yaw, _ = _segment_profiles(segments, t_fine, yaw0_deg * DEG)
    ve, vn = speed * np.cos(yaw), speed * np.sin(yaw)
    east = np.concatenate([[0.0], np.cumsum(0.5 * (ve[1:] + ve[:-1]) * fine)])
    north = np.concatenate([[0.0], np.cumsum(0.5 * (vn[1:] + vn[:-1]) * fine)])
    step = int(round(KNOT_SPACING_S / fine))
    t = t_fine[::step]
    lat0 = lat0_deg * DEG
    rm, rn = earth.radii(lat0)
    # Curvilinear road on the ellipsoid (not the tangent plane), so the car stays level.
    lat_deg = lat0_deg + north[::step] / (rm + h0_m) / DEG
    lon_deg = lon0_deg + east[::step] / ((rn + h0_m) * np.cos(lat0)) / DEG
    frame = LocalFrame(lat0_deg, lon0_deg, h0_m)
    enu = frame.to_enu(lat_deg, lon_deg, np.full_like(t, h0_m))
    return trajectory_from_enu(frame, t, enu, yaw_hint=yaw[::step])


def paper_drive_segments() -> list:
    """The paper's default drive: 45 s stationary, then about 12 min and 5 km of road driving."""
    leg = [{"type": "accelerate", "duration_s": 10, "speed_mps": 9.5},
           {"type": "cruise", "duration_s": 40},
           {"type": "turn", "duration_s": 8, "angle_deg": 90},
           {"type": "cruise", "duration_s": 30},
           {"type": "stop", "duration_s": 8},
           {"type": "stand", "duration_s": 19},
           {"type": "accelerate", "duration_s": 8, "speed_mps": 7.5},
           {"type": "turn", "duration_s": 10, "angle_deg": -60},
           {"type": "cruise", "duration_s": 35},
           {"type": "turn", "duration_s": 6, "angle_deg": 30},
           {"type": "stop", "duration_s": 6}]
    segs = [{"type": "stand", "duration_s": 45}]
    for _ in range(4):
        segs += leg
    segs[-1] = {"type": "stop", "duration_s": 6}
    return segs


PAPER_DATUM = {"latitude_deg": 21.0285, "longitude_deg": 105.8542, "height_m": 10.0}
"""A datum for the paper's drive (Hanoi); any latitude works."""


def paper_drive(lat0_deg: float = PAPER_DATUM["latitude_deg"], lon0_deg: float = PAPER_DATUM["longitude_deg"],
                h0_m: float = PAPER_DATUM["height_m"]) -> TruthTrajectory:
    """The built-in default scenario's trajectory (see :func:`paper_drive_segments`)."""
    return segments_trajectory(paper_drive_segments(), lat0_deg, lon0_deg, h0_m)


# ----------------------------------------------------------------------------- GNSS track and truth CSV


TRACK_GAP_WARN_S = 5.0  # fixes further apart than this: the spline bridges a stretch no fix saw (said)


def read_gnss_track(path):
    """KF-GINS style GNSS text: (t s from first row, lat deg, lon deg, h m, std n/e/d (n, 3) m).

    Read as the project reads whitespace tables (``nav_core.datasets``): a malformed or cut row is skipped and
    named by its line, more than 1 % of them refuse the file; a row with a NaN/Inf or stamped at or before an
    earlier one is dropped and named too (the splines need finite, increasing times). Damage and gaps over
    ``TRACK_GAP_WARN_S`` are logged as warnings naming the file and line.
    """
    from nav_core.datasets import _load_text
    from nav_core.recording import RecordingError

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: file not found")
    first = _first_row(path)
    if len(first) not in (4, 7):
        raise RecordingError(f"{path}: expected whitespace-separated columns 'seconds lat_deg lon_deg h_m "
                             f"[std_n std_e std_d]', the first row has {len(first)} field(s)")
    data, damage, skipped = _load_text(path, len(first))
    lines = np.setdiff1d(np.arange(1, len(data) + len(skipped) + 1), skipped)[:len(data)]  # no blank lines assumed
    bad = ~np.all(np.isfinite(data), axis=1)
    latest = np.maximum.accumulate(np.concatenate(([-np.inf], np.where(bad, -np.inf, data[:, 0])[:-1])))
    back = ~bad & (data[:, 0] <= latest)
    notes = [damage] if damage else []
    for mask, what in ((bad, "not a finite number"), (back, "stamped at or before an earlier row")):
        if mask.any():
            notes.append(f"{path}: {int(mask.sum())} row(s) {what} dropped (line {lines[np.argmax(mask)]})")
    data, lines = data[~(bad | back)], lines[~(bad | back)]
    if len(data) < 6:
        raise RecordingError(f"{path}: {len(data)} usable fix(es); a quintic track needs at least 6")
    gaps = np.flatnonzero(np.diff(data[:, 0]) > TRACK_GAP_WARN_S)
    if len(gaps):
        k = gaps[0]
        notes.append(f"{path}: {len(gaps)} gap(s) over {TRACK_GAP_WARN_S:g} s between fixes, bridged by the spline "
                     f"(first: line {lines[k]} to {lines[k + 1]}, {data[k + 1, 0] - data[k, 0]:.3g} s)")
    for note in notes[1 if damage else 0:]:
        LOG.warning("%s", note)
    std = data[:, 4:7] if data.shape[1] >= 7 else np.full((len(data), 3), 0.02)
    return data[:, 0] - data[0, 0], data[:, 1], data[:, 2], data[:, 3], std


def _first_row(path) -> list:
    """The fields of the first non-empty, non-comment line of a whitespace table ([] for none)."""
    with open(path, errors="replace") as fh:
        return next((f for f in (ln.split("#", 1)[0].split() for ln in fh) if f), [])


def gnss_track_trajectory(path, duration_s: float | None = None, min_std_m: float = 0.02) -> TruthTrajectory:
    """A smooth car trajectory through a real GNSS track (antenna fixes), quintic smoothing splines in ENU.

    Each axis is fitted with ``UnivariateSpline(k=5)`` weighted by the fix std (floored
    at ``min_std_m``), smoothing factor = number of fixes (chi^2 per fix ~ 1).
    """
    t, lat, lon, h, std = read_gnss_track(path)
    if duration_s is not None:
        keep = t <= duration_s + 1e-9
        t, lat, lon, h, std = t[keep], lat[keep], lon[keep], h[keep], std[keep]
    frame = LocalFrame(float(lat[0]), float(lon[0]), float(h[0]))
    enu = frame.to_enu(lat, lon, h)
    sd = np.maximum(std[:, [1, 0, 2]], min_std_m)
    splines = [UnivariateSpline(t, enu[:, i], w=1.0 / sd[:, i], k=5, s=len(t)) for i in range(3)]
    position = ComponentSplinePosition(splines, t[0], t[-1])
    t_dense = np.arange(t[0], t[-1] + 1e-9, KNOT_SPACING_S)
    traj = trajectory_from_enu(frame, t_dense, position.enu(t_dense), position=position)
    return traj


EXACT_ROW_STD_M = 1e-6
"""Row noise (m) below which a truth CSV's positions are interpolated exactly: 1 um at 10 Hz moves 1-s mean
specific force by about 2e-4 m/s^2 at most, far below any sensor's noise; smoothing at this level only bends the
path."""
SIXTH_DIFFERENCE_VAR = 924.0
"""Variance of the sixth difference of unit white noise (binomial(12, 6))."""


def row_noise_m(enu_m: np.ndarray) -> np.ndarray:
    """Per-axis noise (m, 1 sigma) of evenly spaced position rows, from the RMS of their sixth differences.

    A smooth path's sixth difference is h^6 x^(6) (micrometres at 10 Hz even through a 2 m/s^2 quintic speed
    change), so what is left is the rows' own noise: the CSV's print step, a logger's rounding. It is at most the
    path's own sixth difference / 30, so over-estimating it on a jerky path costs only micrometres of smoothing.
    (Not a median: rounding of a steady motion is quasi-periodic, most of its sixth differences near 0.)
    """
    d6 = np.diff(np.asarray(enu_m, float), n=6, axis=0)
    if len(d6) < 8:
        return np.zeros(np.shape(enu_m)[1])
    return np.sqrt(np.mean(d6**2, axis=0) / SIXTH_DIFFERENCE_VAR)


def _row_spline(t: np.ndarray, x: np.ndarray, noise_m: float):
    """A quintic spline through rows x(t): exact when their noise is below :data:`EXACT_ROW_STD_M`, else smoothing
    with chi^2 per row ~ 1 at that noise."""
    if noise_m <= EXACT_ROW_STD_M:
        return make_interp_spline(t, x, k=5)
    return UnivariateSpline(t, x, k=5, s=len(t) * noise_m**2)


class RowsPosition:
    """Position from a truth file's position rows, its derivatives from the velocity rows when those are the better
    source (:func:`truth_csv_trajectory`): ``enu(t, 0)`` the position splines, ``enu(t, nu)`` the (nu-1)-th
    derivative of the velocity splines (tangent-plane ENU, m/s^nu)."""

    def __init__(self, position: ComponentSplinePosition, velocity: ComponentSplinePosition):
        self.position, self.velocity = position, velocity
        self.t0, self.t1 = position.t0, position.t1

    def enu(self, t, nu: int = 0) -> np.ndarray:
        """nu-th time derivative of the ENU position, shape (n, 3)."""
        return self.position.enu(t) if nu == 0 else self.velocity.enu(t, nu - 1)


VELOCITY_AGREEMENT_M = 1.0
"""Velocity rows whose integral leaves the position rows by more than this (RMS about a constant, m) are not the
same motion (another frame, another antenna) and are not used; a smoothed track's slow error is 5-60 cm."""


def _velocity_rows_spline(truth: Trajectory, frame: LocalFrame, t: np.ndarray, position) -> object | None:
    """Splines through the velocity rows in the tangent-plane ENU frame, when they agree with the position rows
    (their integral within :data:`VELOCITY_AGREEMENT_M`); else None. A velocity row is a direct sample of the
    derivative: differentiating it once for acceleration amplifies its print step far less than differentiating
    positions twice."""
    v_n = getattr(truth, "velocity_n", None)
    if v_n is None or len(t) <= 7 or not np.all(np.isfinite(v_n)):
        return None
    m = earth.mat_ne(frame.lat0_deg * DEG, frame.lon0_deg * DEG)
    v = np.einsum("ij,njk,nk->ni", m, np.transpose(earth.mat_ne(truth.lat, truth.lon), (0, 2, 1)), v_n)
    noise = row_noise_m(v)
    velocity = ComponentSplinePosition([_row_spline(t, v[:, i], noise[i]) for i in range(3)], t[0], t[-1])
    drift = np.column_stack([s.antiderivative()(t) for s in velocity.splines]) - position.enu(t)
    if np.sqrt(np.mean((drift - drift.mean(axis=0)) ** 2)) > VELOCITY_AGREEMENT_M:
        return None
    return velocity


def truth_csv_trajectory(truth: Trajectory, frame: LocalFrame | None = None) -> TruthTrajectory:
    """A smooth trajectory through a truth trajectory (nav_core :class:`Trajectory`, e.g. a truth CSV).

    Position is a quintic spline per ENU axis through every row: interpolating when the rows carry no noise of
    their own (a CSV printed to 15 digits), else a smoothing spline at the rows' noise as :func:`row_noise_m`
    measures it (a 10-digit CSV's ~2 mm of longitude), so rounding does not become acceleration noise and
    exact rows keep their acceleration (an assumed 3 mm had smoothed 1-s specific force by up to 0.07 m/s^2 at
    the end of a quintic speed change). When the position rows are noisy, velocity and acceleration come from the
    velocity rows instead if the file has them and they agree with the positions (a 10-digit CSV at 10 Hz: 1-s
    specific force 3e-5 m/s^2 off from them, 0.04 from its positions). Attitude: a quintic quaternion spline
    through rows thinned to ~10 Hz.
    """
    if len(truth.t) < 2:
        raise ValueError("truth trajectory needs at least 2 rows")
    step = max(1, int(round(KNOT_SPACING_S / np.median(np.diff(truth.t)))))
    idx = np.unique(np.r_[np.arange(0, len(truth.t), step), len(truth.t) - 1])
    frame = frame or LocalFrame(float(truth.lat[0] / DEG), float(truth.lon[0] / DEG), float(truth.h[0]))
    enu = frame.to_enu(truth.lat / DEG, truth.lon / DEG, truth.h)
    rot = rotation_from_euler(truth.roll[idx], truth.pitch[idx], truth.yaw[idx])
    t = truth.t
    if len(t) > 5:
        noise = row_noise_m(enu)
        splines = [_row_spline(t, enu[:, i], noise[i]) for i in range(3)]
        position = ComponentSplinePosition(splines, t[0], t[-1])
        velocity = _velocity_rows_spline(truth, frame, t, position) if np.max(noise) > EXACT_ROW_STD_M else None
        if velocity is not None:
            position = RowsPosition(position, velocity)
    else:
        position = EnuSplinePosition(t, enu)
    return TruthTrajectory(frame, position, QuatSplineAttitude(t[idx], rot), float(t[0]), float(t[-1]))


# ----------------------------------------------------------------------------- static and rate table


def static_trajectory(static_segments, lat0_deg: float, lon0_deg: float, h0_m: float = 0.0) -> TruthTrajectory:
    """Fixed position; attitude held (or spun at ``rate_dps`` about ``axis_body``) on each segment.

    Each segment: ``t0``, ``t1`` (s), ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (body-to-ENU,
    REP-103, the attitude at t0); optional ``rate_dps`` and ``axis_body`` (default z) for a
    rate table. Between segments the unit moves smoothly (C2) to the next attitude.
    """
    spans = []
    for i, seg in enumerate(static_segments):
        try:
            t0, t1 = float(seg["t0"]), float(seg["t1"])
            rot = rotation_from_euler(*(float(seg.get(k, 0.0)) * DEG for k in ("roll_deg", "pitch_deg", "yaw_deg")))
        except (KeyError, TypeError, ValueError) as err:
            raise ValueError(f"static_segments[{i}]: needs numeric t0, t1 and angles ({err})") from err
        if not t1 > t0:
            raise ValueError(f"static_segments[{i}]: t1 ({t1}) must be > t0 ({t0})")
        axis = np.asarray(seg.get("axis_body", [0.0, 0.0, 1.0]), float)
        axis = axis / np.linalg.norm(axis)
        spans.append((t0, t1, rot, axis * float(seg.get("rate_dps", 0.0)) * DEG))
    spans.sort(key=lambda s: s[0])
    frame = LocalFrame(lat0_deg, lon0_deg, h0_m)
    attitude = PiecewiseAttitude(spans)
    t_pos = np.array([attitude.t0, attitude.t1])
    return TruthTrajectory(frame, EnuSplinePosition(t_pos, np.zeros((2, 3))), attitude, attitude.t0, attitude.t1)


def six_position_segments(hold_s: float = 60.0, move_s: float = 10.0) -> list:
    """Six static orientations (each axis up, then down) for multi-position accelerometer calibration."""
    poses = [(0, 0, 0), (180, 0, 0), (0, -90, 0), (0, 90, 0), (90, 0, 0), (-90, 0, 0)]
    return [{"t0": i * (hold_s + move_s), "t1": i * (hold_s + move_s) + hold_s,
             "roll_deg": r, "pitch_deg": p, "yaw_deg": y} for i, (r, p, y) in enumerate(poses)]


def rate_table_segments(rates_dps=(-100.0, 100.0), hold_s: float = 60.0, move_s: float = 10.0,
                        axis_body=(0.0, 0.0, 1.0)) -> list:
    """Constant-rate spins (rate table) about a body axis, vertical body z, with spin-up gaps between."""
    return [{"t0": i * (hold_s + move_s), "t1": i * (hold_s + move_s) + hold_s, "roll_deg": 0.0,
             "pitch_deg": 0.0, "yaw_deg": 0.0, "rate_dps": float(r), "axis_body": list(axis_body)}
            for i, r in enumerate(rates_dps)]

