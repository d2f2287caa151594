"""Whether a recording's fixes show the motion its IMU measured: a whole-run check after the filter ran (no ROS).

The replay (:func:`ins_gps_kf.replay.check_fixes_against_ins`) refuses fixes whose velocity changes differ
from the INS's by ``TRACK_RATIO`` or more (latitude and longitude in radians read as degrees: 1/57.3) or
that the filter mostly rejected, naming the likely causes.
"""
from __future__ import annotations

import numpy as np


TRACK_WINDOW_S = 10.0  # velocity changes compared over windows this long: GPS noise / window is small
TRACK_MIN_DV_MPS = 1.0  # windows where the INS changes velocity by less than this say nothing
TRACK_RATIO = 10.0  # GPS and INS velocity changes differing by this factor (either way) are not one motion
CHUNK = 65536  # IMU samples rotated at a time
REJECTED_FRACTION = 0.5  # more than this share of the fixes at filter epochs rejected: persistently rejected
LIKELY_CAUSES = ("latitude/longitude in radians (or another unit) where degrees are expected, latitude and "
                 "longitude columns swapped, positions in another datum or projection, or fixes of another run")


def track_disagreement(imu_t, accel, est_t, quats, accel_bias, fixes_t, fixes_enu,
                       min_windows: int = 3) -> float | None:
    """The median ratio of the fixes' horizontal velocity change to the INS's over ``TRACK_WINDOW_S`` windows.

    ``imu_t`` (n,) s and ``accel`` (n, 3) m/s^2 (body); the filter's epochs ``est_t`` (k,) s with their
    attitude ``quats`` (k, 4) xyzw and accel bias ``accel_bias`` (k, 3) m/s^2; ``fixes_t`` (m,) s and
    ``fixes_enu`` (m, 3) m. The INS side is the specific force
    rotated by the estimated attitude and summed (gravity is vertical, so the horizontal sum is the
    velocity change whatever the heading); the GPS side differences the chord velocities. None when
    fewer than ``min_windows`` windows see the INS change velocity by ``TRACK_MIN_DV_MPS`` or more.
    """
    if len(est_t) < 2 or len(fixes_t) < 3:
        return None
    good = np.isfinite(fixes_t) & np.all(np.isfinite(fixes_enu[:, :2]), axis=1)
    ft, fe = fixes_t[good], fixes_enu[good, :2]
    if len(ft) < 3 or np.any(np.diff(ft) <= 0):
        return None
    h = TRACK_WINDOW_S / 4  # GPS velocity: the chord over +-h s, its noise ~ std / (1.4 h)

    def v_gps(t):
        return (np.array([np.interp(t + h, ft, fe[:, c]) - np.interp(t - h, ft, fe[:, c]) for c in (0, 1)]) / (2 * h))

    starts = np.arange(max(est_t[0], ft[0] + h), min(est_t[-1], ft[-1] - h) - TRACK_WINDOW_S, TRACK_WINDOW_S)
    ends = starts + TRACK_WINDOW_S
    dv_ins = _ins_velocity_changes(imu_t, accel, est_t, quats, accel_bias,
                                   np.searchsorted(imu_t, np.concatenate([starts, ends])))
    ratios = []
    for w, (a, b) in enumerate(zip(starts, ends)):
        dv = np.hypot(*(dv_ins[len(starts) + w] - dv_ins[w]))
        if dv >= TRACK_MIN_DV_MPS:
            ratios.append(np.hypot(*(v_gps(b) - v_gps(a))) / dv)
    return float(np.median(ratios)) if len(ratios) >= min_windows else None


def _ins_velocity_changes(imu_t, accel, est_t, quats, accel_bias, at) -> np.ndarray:
    """The INS's horizontal velocity change (m/s) from the first IMU sample to before sample ``at`` (k,) (the sum
    of the specific force rotated by the epoch's attitude, less its accel bias, over the sample intervals); in
    chunks of ``CHUNK`` samples, keeping only the ``at`` values: a whole-run sum held 20 MB for a 2-h 64-Hz drive."""
    from scipy.spatial.transform import Rotation

    out = np.zeros((len(at), 2))
    base = np.zeros(2)
    for s in range(0, len(imu_t), CHUNK):
        e = min(s + CHUNK, len(imu_t))
        k = np.clip(np.searchsorted(est_t, imu_t[s:e]), 0, len(est_t) - 1)
        dt = np.diff(imu_t[s:e], prepend=imu_t[max(s - 1, 0)])
        dt = np.where((dt > 0) & (dt < 1.0), dt, 0.0)
        f_n = Rotation.from_quat(quats[k]).apply(accel[s:e] - accel_bias[k])
        cum = base + np.cumsum(f_n[:, :2] * dt[:, None], axis=0)  # the change up to samples s + 1 .. e
        inside = (at > s) & (at <= e)
        out[inside] = cum[at[inside] - s - 1]
        base = cum[-1]
    return out
