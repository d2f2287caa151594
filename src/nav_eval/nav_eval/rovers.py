"""Readers of the NaveGo planetary-rover runs in ``../shared/data/navego_rover`` (NaveGo, LGPL-3 code; data licence
not stated), used by the evaluations and ``nav-convert``: to nav_core recording types in SI units.

Katwijk beach (ESA): IMU 125 Hz (``katwijk_imu_planetary.mat``), RTK fixes every 3 s
(``katwijk_gps-latlong.txt``), and the source's 20 Hz reference interpolated from the
same fixes (``katwijk_gnss_planetary_r.mat``: position and NED velocity). The IMU time
was rebased by the source, so the IMU is aligned to the GPS by the start of motion.
The body axes are not documented (z reads +g at rest); the forward axis is chosen by
the data (smallest mean GPS NIS among the four level axis choices) and reported.
UTIAS Canadian planetary run 3: IMU 200 Hz, ~20 Hz GPS, a UTM pose ground truth.
"""
from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np

from nav_core.recording import GnssRecording, ImuRecording, RecordingError, Trajectory
from nav_core.units import DEG
from nav_core.workspace import shared_data

NAVEGO = shared_data("navego_rover")


# body FLU from the file's axes, z kept up: forward = +x, +y, -x or -y of the file
AXIS_CHOICES = {"x_fwd": np.eye(3), "y_fwd": np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]]),
                "-x_fwd": np.diag([-1.0, -1.0, 1.0]), "-y_fwd": np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])}


def _loadmat(path, key):
    import scipy.io as sio
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: not found")
    try:
        return sio.loadmat(path, squeeze_me=True, struct_as_record=False)[key]
    except (KeyError, ValueError, OSError) as err:
        raise RecordingError(f"{path}: cannot read '{key}': {err}") from err


def read_navego_imu(path, key="imu_planetary", axes=np.eye(3)) -> ImuRecording:
    """NaveGo ``imu_planetary`` struct: ``t`` (s), ``wb`` (rad/s), ``fb`` (m/s^2), rows rotated by ``axes``."""
    m = _loadmat(path, key)
    return ImuRecording(np.asarray(m.t, float), np.asarray(m.wb, float) @ axes.T, np.asarray(m.fb, float) @ axes.T,
                        source=str(path))


def read_katwijk_gps(path) -> GnssRecording:
    """RTK fixes ``YYYY_MM_DD_hh_mm_ss_mmm TYPE lat lon h std_e std_n std_u``; t from the first fix (s)."""
    path = Path(path)
    rows, status = [], []
    for line_no, line in enumerate(path.read_text().splitlines(), start=1):
        parts = line.split()
        if not parts:
            continue
        try:
            stamp = _dt.datetime.strptime(parts[0], "%Y_%m_%d_%H_%M_%S_%f").timestamp()
            rows.append([stamp, *map(float, parts[2:8])])
        except (ValueError, IndexError) as err:
            raise RecordingError(f"{path}: line {line_no}: {err}") from err
        status.append(2 if parts[1].startswith("RTK") else 0)  # NavSatStatus GBAS_FIX for RTK
    a = np.asarray(rows)
    return GnssRecording(a[:, 0] - a[0, 0], a[:, 1] * DEG, a[:, 2] * DEG, a[:, 3], a[:, 4:7], status,
                         source=str(path))


def read_navego_reference(path, key="gnss_planetary_r") -> Trajectory:
    """The source's reference: lat/lon (rad), h (m), NED velocity -> ENU; no attitude (NaN)."""
    r = _loadmat(path, key)
    vel_ned = np.asarray(r.vel, float)
    nan = np.full(len(r.t), np.nan)
    return Trajectory(np.asarray(r.t, float), np.asarray(r.lat, float), np.asarray(r.lon, float),
                      np.asarray(r.h, float), nan, nan, nan, vel_ned[:, [1, 0, 2]] * [1, 1, -1])


def motion_onset(t, values, rate_hz, factor=2.0, block_s=1.0):
    """Start (s) of the first ``block_s`` block whose mean ``values`` exceeds ``factor`` x the first 10 blocks' median."""
    n = max(int(round(rate_hz * block_s)), 1)
    k = len(values) // n
    blocks = np.asarray(values[:k * n]).reshape(k, n).mean(axis=1)
    base = np.median(blocks[:10])
    idx = int(np.argmax(blocks > factor * base))
    return float(t[idx * n])


def load_katwijk(axes_name="x_fwd", data=NAVEGO):
    """(imu, gnss, reference, info): the IMU re-timed so its motion onset meets the reference's."""
    imu = read_navego_imu(data / "katwijk_imu_planetary.mat", axes=AXIS_CHOICES[axes_name])
    gnss = read_katwijk_gps(data / "katwijk_gps-latlong.txt")
    ref = read_navego_reference(data / "katwijk_gnss_planetary_r.mat")
    imu_on = motion_onset(imu.t, np.linalg.norm(imu.gyro, axis=1), imu.rate_hz)
    speed = np.hypot(ref.velocity_n[:, 0], ref.velocity_n[:, 1])
    ref_on = float(ref.t[np.argmax(speed > 0.02)])
    imu.t = imu.t - imu_on + ref_on
    return imu, gnss, ref, {"imu_onset_s": imu_on, "reference_onset_s": ref_on, "axes": axes_name}


Z_DOWN = np.diag([1.0, -1.0, -1.0])  # a 180 deg turn about x: z-down file axes to z up


def read_canada_gps(path) -> GnssRecording:
    """UTIAS GPS text: unix time (s), lat (deg), lon (deg), altitude (m); no std (configure gps_std_m)."""
    path = Path(path)
    try:
        a = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except ValueError as err:
        raise RecordingError(f"{path}: {err}") from err
    return GnssRecording(a[:, 0], a[:, 1] * DEG, a[:, 2] * DEG, a[:, 3], np.zeros((len(a), 3)), source=str(path))


def read_canada_truth_utm(path):
    """UTIAS reference ``frame;child;seq;sec;nanosec;E;N;U;qx;qy;qz;qw`` (UTM 18T, m): (t unix s, (n, 3) ENU m)."""
    return _read_canada_truth(path, slice(5, 8))


def read_canada_truth_attitude(path):
    """UTIAS reference attitude: (t unix s, (n, 4) quaternion x y z w of base_link in the UTM 'world' frame)."""
    return _read_canada_truth(path, slice(8, 12))


def _read_canada_truth(path, columns: slice):
    """(t unix s, the float ``columns`` of each row) of the UTIAS reference file."""
    path = Path(path)
    rows = []
    for line_no, line in enumerate(path.read_text().splitlines(), start=1):
        parts = line.strip().split(";")
        if len(parts) < 12:
            continue
        try:
            rows.append([int(parts[3]) + 1e-9 * int(parts[4]), *map(float, parts[columns])])
        except ValueError as err:
            raise RecordingError(f"{path}: line {line_no}: {err}") from err
    a = np.asarray(rows)
    return a[:, 0], a[:, 1:]


def _fit_plane_transform(src_xy, dst_xy):
    """Rotation + translation (2-D least squares, Kabsch) mapping ``src_xy`` onto ``dst_xy``."""
    sc, dc = src_xy.mean(axis=0), dst_xy.mean(axis=0)
    u, _, vt = np.linalg.svd((src_xy - sc).T @ (dst_xy - dc))
    rot = (u @ vt).T
    if np.linalg.det(rot) < 0:
        vt[-1] *= -1
        rot = (u @ vt).T
    return rot, dc - rot @ sc


def load_canada(axes_name="x_fwd", data=NAVEGO):
    """(imu, gnss, truth, info): times from the first GPS fix; the UTM truth mapped to geodetic through a
    rotation + translation fitted to the GPS (so its datum inherits the GPS bias; relative errors only)."""
    from nav_core.earth import LocalFrame

    imu = read_navego_imu(data / "canada_imu_planetary.mat", axes=AXIS_CHOICES[axes_name] @ Z_DOWN)
    gnss = read_canada_gps(data / "canada_gps-latlong.txt")
    t_truth, utm = read_canada_truth_utm(data / "canada_posecov_gt_data.csv")
    t0 = gnss.t[0]
    gnss.t = gnss.t - t0
    t_truth = t_truth - t0
    frame = LocalFrame(gnss.lat[0] / DEG, gnss.lon[0] / DEG, float(gnss.h[0]))
    g_enu = frame.to_enu(gnss.lat / DEG, gnss.lon / DEG, gnss.h)
    inside = (gnss.t >= t_truth[0]) & (gnss.t <= t_truth[-1])
    utm_at_g = np.column_stack([np.interp(gnss.t[inside], t_truth, utm[:, i]) for i in range(3)])
    rot, shift = _fit_plane_transform(utm_at_g[:, :2], g_enu[inside, :2])
    enu = np.column_stack([utm[:, :2] @ rot.T + shift, utm[:, 2] - np.mean(utm_at_g[:, 2] - g_enu[inside, 2])])
    lat, lon, h = frame.to_geodetic(enu)
    vel = np.gradient(enu, t_truth, axis=0)
    nan = np.full(len(t_truth), np.nan)
    truth = Trajectory(t_truth, lat * DEG, lon * DEG, h, nan, nan, nan, vel)
    # the truth starts moving; the GPS shows the start of motion: align the IMU onset to the GPS onset
    imu_on = motion_onset(imu.t, np.abs(imu.gyro[:, 2]), imu.rate_hz, factor=5.0)
    g_speed = np.hypot(*np.gradient(g_enu[:, :2], gnss.t, axis=0).T)
    k = max(int(round(gnss.t.size / (gnss.t[-1] - gnss.t[0]))), 1)  # fixes per second
    smooth = np.convolve(g_speed, np.ones(k) / k, mode="same")
    ref_on = float(gnss.t[np.argmax(smooth > 0.1)])
    imu.t = imu.t - imu_on + ref_on
    return imu, gnss, truth, {"imu_onset_s": imu_on, "reference_onset_s": ref_on, "axes": axes_name,
                              "utm_to_enu_rotation_deg": float(np.degrees(np.arctan2(rot[1, 0], rot[0, 0])))}
