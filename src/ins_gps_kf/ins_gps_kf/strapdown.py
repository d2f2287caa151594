"""Strapdown mechanization on angle and velocity increments (numba kernel for the per-sample loop).

Inputs arrive as rates (``sensor_msgs/Imu``: rad/s, m/s^2) stamped at the end of
their sample interval; each becomes an increment ``rate * dt`` with ``dt`` the
stamp difference. From two successive increments (dtheta_{k-1}, dtheta_k,
dv_{k-1}, dv_k) the two-sample corrections are (Savage, Titterton & Weston):

* coning:   ``phi_k = dtheta_k + dtheta_{k-1} x dtheta_k / 12``
* rotation: ``dv_rot = dtheta_k x dv_k / 2``
* sculling: ``dv_scul = (dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12``

Attitude ``q_nb(k) = q(-zeta) * q_nb(k-1) * q(phi_k)`` with ``zeta = (w_ie + w_en) dt``
(Earth rate and transport rate turn the ENU frame); velocity adds the body
increment rotated to ENU with the start-of-interval attitude, less ``zeta x dv_n / 2``
(the frame turns during the interval), gravity and the Coriolis term; position (local ENU, m)
integrates velocity by the trapezoid rule. Earth rate, transport rate and normal
gravity come from :mod:`nav_core.earth`, evaluated once per filter epoch by the
caller and held over the epoch (they change by parts per billion in 0.5 s).

The quaternion helpers below are numba copies of what scipy's ``Rotation`` does;
they exist only because the kernel must run without the interpreter.
"""
import numpy as np
from numba import njit

# nav-state vector layout (one float64 array the kernel updates in place)
Q = slice(0, 4)        # body-to-ENU quaternion (x, y, z, w)
V = slice(4, 7)        # velocity, ENU, m/s
P = slice(7, 10)       # position, local ENU, m
NAV_SIZE = 10

# kernel memory layout: previous increments, last stamp, and per-epoch accumulators
M_DTH = slice(0, 3)    # previous angle increment, rad
M_DV = slice(3, 6)     # previous velocity increment, m/s
M_T = 6                # stamp of the last sample, s
M_HAS_PREV = 7         # 1 when M_DTH/M_DV are valid
M_FN = slice(8, 11)    # sum of ENU specific-force increments over the epoch, m/s
M_DT = 11              # sum of dt over the epoch, s
M_N = 12               # samples in the epoch
M_W2 = 13              # sum of |w|^2 (rad/s)^2, bias-corrected
M_F = 14               # sum of |f| (m/s^2)
M_F2 = 15              # sum of |f|^2
M_WSUM = slice(16, 19)  # sum of w (rad/s), bias-corrected
MEM_SIZE = 19


@njit(cache=True)
def _cross(a, b):
    return np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))


@njit(cache=True)
def _quat_mul(a, b):
    """Hamilton product of (x, y, z, w) quaternions."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return np.array((aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz))


@njit(cache=True)
def _quat_from_rotvec(r):
    angle = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
    if angle < 1e-8:  # series keeps full precision for tiny angles
        s = 0.5 - angle * angle / 48.0
    else:
        s = np.sin(0.5 * angle) / angle
    return np.array((s * r[0], s * r[1], s * r[2], np.cos(0.5 * angle)))


@njit(cache=True)
def _mat_from_quat(q):
    x, y, z, w = q[0], q[1], q[2], q[3]
    return np.array(((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
                     (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
                     (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y))))


@njit(cache=True)
def integrate(nav, mem, t, gyro, accel, bias_gyro, bias_accel, w_ie_n, w_en_n, g_n):
    """Advance ``nav`` in place over samples ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2.

    ``mem`` carries the previous increments and the epoch accumulators; biases are
    subtracted before integration; ``w_ie_n``, ``w_en_n`` (rad/s) and ``g_n`` (m/s^2)
    are ENU vectors held over the call.
    """
    w_in = w_ie_n + w_en_n
    cor = 2.0 * w_ie_n + w_en_n
    for k in range(t.shape[0]):
        dt = t[k] - mem[M_T]
        mem[M_T] = t[k]
        w = gyro[k] - bias_gyro
        f = accel[k] - bias_accel
        dth = w * dt
        dvb = f * dt
        phi = dth.copy()
        dv_body = dvb + 0.5 * _cross(dth, dvb)
        if mem[M_HAS_PREV] > 0.5:
            pth = mem[M_DTH]
            pdv = mem[M_DV]
            phi += _cross(pth, dth) / 12.0
            dv_body += (_cross(pth, dvb) + _cross(pdv, dth)) / 12.0
        mem[M_DTH] = dth
        mem[M_DV] = dvb
        mem[M_HAS_PREV] = 1.0
        q = nav[Q].copy()
        dv_n = _mat_from_quat(q) @ dv_body
        dv_n = dv_n - 0.5 * _cross(w_in * dt, dv_n)  # the ENU frame turns during the interval too
        v_old = nav[V].copy()
        v_new = v_old + dv_n + (g_n - _cross(cor, v_old)) * dt
        nav[V] = v_new
        nav[P] = nav[P] + 0.5 * (v_old + v_new) * dt
        q = _quat_mul(_quat_mul(_quat_from_rotvec(-w_in * dt), q), _quat_from_rotvec(phi))
        nav[Q] = q / np.sqrt(np.sum(q * q))
        mem[M_FN] = mem[M_FN] + dv_n
        mem[M_DT] += dt
        mem[M_N] += 1.0
        mem[M_W2] += np.sum(w * w)
        mem[M_WSUM] = mem[M_WSUM] + w
        fn = np.sqrt(np.sum(f * f))
        mem[M_F] += fn
        mem[M_F2] += fn * fn


@njit(cache=True)
def mat_nb(nav):
    """Body-to-ENU rotation matrix (3, 3) of a nav-state array."""
    return _mat_from_quat(nav[Q])


@njit(cache=True)
def rotate_attitude(nav, phi_n):
    """Turn the attitude of ``nav`` in place by the small ENU rotation vector ``phi_n`` (rad), on the left."""
    q = _quat_mul(_quat_from_rotvec(phi_n), nav[Q])
    nav[Q] = q / np.sqrt(np.sum(q * q))


def new_state(quat_xyzw, velocity_n, position_n):
    """A nav-state array from a quaternion (x, y, z, w), ENU velocity (m/s) and local ENU position (m)."""
    nav = np.zeros(NAV_SIZE)
    nav[Q], nav[V], nav[P] = quat_xyzw, velocity_n, position_n
    return nav


def new_memory(t_last_s):
    """Kernel memory starting at stamp ``t_last_s`` (s), no previous increment."""
    mem = np.zeros(MEM_SIZE)
    mem[M_T] = t_last_s
    return mem


def reset_accumulators(mem):
    """Zero the per-epoch accumulators of ``mem`` (keeps the previous increments)."""
    mem[M_FN] = 0.0
    mem[M_DT:] = 0.0


def epoch_motion(mem):
    """Over the epoch: mean ENU specific force (m/s^2), rms and mean-vector norm of the angular rate (rad/s),
    mean and std of |f| (m/s^2)."""
    n = max(mem[M_N], 1.0)
    f_n = mem[M_FN] / mem[M_DT] if mem[M_DT] > 0 else np.zeros(3)
    w_rms = np.sqrt(mem[M_W2] / n)
    w_mean = float(np.linalg.norm(mem[M_WSUM] / n))
    f_mean = mem[M_F] / n
    f_std = np.sqrt(max(mem[M_F2] / n - f_mean**2, 0.0))
    return f_n, w_rms, w_mean, f_mean, f_std


def warm_up():
    """Run each kernel once so numba compiles (or loads its cache) before real data arrives."""
    nav, mem = new_state([0.0, 0.0, 0.0, 1.0], np.zeros(3), np.zeros(3)), new_memory(0.0)
    z = np.zeros(3)
    integrate(nav, mem, np.array([0.01]), np.zeros((1, 3)), np.zeros((1, 3)), z, z, z, z, z)
    mat_nb(nav)
    rotate_attitude(nav, z)
