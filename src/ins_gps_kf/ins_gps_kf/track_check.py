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
    from scipy.spatial.transform import Rotation

    if len(est_t) < 2 or len(fixes_t) < 3:
        return None
    t_est, bias = est_t, accel_bias
    k = np.clip(np.searchsorted(t_est, imu_t), 0, len(t_est) - 1)
    dt = np.diff(imu_t, prepend=imu_t[0])
    dt = np.where((dt > 0) & (dt < 1.0), dt, 0.0)
    dv_ins = np.zeros((len(imu_t) + 1, 2))
    for s in range(0, len(imu_t), CHUNK):  # in chunks: rotating a 2-hour 64-Hz run at once took 60 MB more
        e = min(s + CHUNK, len(imu_t))
        f_n = Rotation.from_quat(quats[k[s:e]]).apply(accel[s:e] - bias[k[s:e]])
        dv_ins[s + 1:e + 1] = dv_ins[s] + np.cumsum(f_n[:, :2] * dt[s:e, None], axis=0)
    good = np.isfinite(fixes_t) & np.all(np.isfinite(fixes_enu[:, :2]), axis=1)
    ft, fe = fixes_t[good], fixes_enu[good, :2]
    if len(ft) < 3 or np.any(np.diff(ft) <= 0):
        return None
    h = TRACK_WINDOW_S / 4  # GPS velocity: the chord over +-h s, its noise ~ std / (1.4 h)

    def v_gps(t):
        return (np.array([np.interp(t + h, ft, fe[:, c]) - np.interp(t - h, ft, fe[:, c]) for c in (0, 1)]) / (2 * h))

    ratios = []
    for a in np.arange(max(t_est[0], ft[0] + h), min(t_est[-1], ft[-1] - h) - TRACK_WINDOW_S, TRACK_WINDOW_S):
        b = a + TRACK_WINDOW_S
        i, j = np.searchsorted(imu_t, [a, b])
        dv = np.hypot(*(dv_ins[j] - dv_ins[i]))
        if dv >= TRACK_MIN_DV_MPS:
            ratios.append(np.hypot(*(v_gps(b) - v_gps(a))) / dv)
    return float(np.median(ratios)) if len(ratios) >= min_windows else None
