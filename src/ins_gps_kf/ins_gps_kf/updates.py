"""Update models: each turns the navigation state at a filter epoch into one measurement of the error state.

One interface (:class:`UpdateModel`): ``measurement(epoch)`` returns ``(z, H, R)`` (z = predicted minus
measured, H on the error state, R the noise covariance) or None when the model has nothing to say at
this epoch. The filter gates, applies and feeds back every measurement the same way
(:meth:`ins_gps_kf.filter.InsGpsFilter._apply`) and counts per model. Models today: GNSS position
(:class:`GnssPosition`), zero velocity at rest (:class:`ZeroVelocity`), vehicle constraints
(:class:`NonHolonomic`, judging the epoch as ZUPT does) and the wheel odometer (:class:`WheelOdometer`, holding
its pending speed as GNSS holds its fix; its scale factor is a filter state).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from nav_core import frames
from nav_core.frames import skew
from ins_gps_kf import measurements, strapdown
from ins_gps_kf.error_model import BA, BG, DV, PHI
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import Fix


class Epoch:
    """What an update model sees at one filter epoch: the stamp (s), the navigation state (read live: a model
    applied after another sees its correction), the epoch's motion statistics and the GNSS chord speed."""

    def __init__(self, t: float, nav: np.ndarray, n_states: int, motion: tuple, gravity: float):
        self.t = t
        self.nav = nav
        self.n_states = n_states
        self.f_n = motion[0]  # m/s^2, the epoch's mean specific force (ENU, bias-corrected)
        self.w_rms, self.w_mean, self.f_mean, self.f_std = motion[1:]  # rad/s, rad/s, m/s^2, m/s^2
        self.gravity = gravity  # m/s^2
        self.gps_speed = 0.0    # m/s, horizontal speed between the last two fixes less 3 sigma of its noise
        self.rate_b = np.zeros(3)  # rad/s, the epoch's mean bias-corrected body rate
        self.stationary = False  # the zero-velocity detector's verdict (set once it has judged the epoch)
        self.heading_known = False  # navigating with a heading (not pending one from the GNSS course)
        self.gnss_fresh = False  # a fix was used within 1.5 GNSS periods (the velocity is GNSS-aided, not drifting)
        self.yaw_std = float("inf")  # rad, the heading's std from the covariance
        self.vel_std_h = 0.0  # m/s, the horizontal velocity's std from the covariance (before this epoch's updates)

    @property
    def mat_nb(self) -> np.ndarray:
        """Body-to-ENU rotation of the current state."""
        return strapdown.mat_nb(self.nav)


class UpdateModel:
    """A measurement of the error state at filter epochs; subclasses give ``name`` and :meth:`measurement`."""

    name = ""
    gate_probability: float | None = None  # chi-square gate of this model; None: the filter's (gate_probability)

    def measurement(self, epoch: Epoch):
        """``(z, H, R)`` at ``epoch``, or None when the model does not apply now."""
        raise NotImplementedError


class GnssPosition(UpdateModel):
    """The GNSS antenna position: the INS position moved by the lever arm (m, body), back to the fix's stamp.
    The GNSS policy (:mod:`ins_gps_kf.gnss_policy`) sets :attr:`fix` to the one this epoch uses."""

    name = "gnss"

    def __init__(self, lever_arm_b):
        self.lever_arm_b = np.asarray(lever_arm_b, dtype=float)
        self.fix: Fix | None = None

    def measurement(self, epoch: Epoch):
        fix = self.fix
        if fix is None:
            return None
        return measurements.gps_position(epoch.nav[strapdown.P], epoch.nav[strapdown.V], epoch.mat_nb,
                                         self.lever_arm_b, fix.enu, fix.cov, epoch.t - fix.t, epoch.n_states)


class ZeroVelocity(UpdateModel):
    """Zero velocity while the IMU and the GNSS say the vehicle is at rest (``zupt_*`` parameters)."""

    name = "zupt"

    def __init__(self, cfg: FilterConfig):
        self.cfg = cfg
        self.gate_probability = cfg.zupt_gate_probability

    def stationary(self, epoch: Epoch) -> bool:
        """Whether the epoch looks like rest."""
        cfg = self.cfg
        # rms catches vibration, the mean catches a steady turn; GPS and INS speed veto smooth cruising and
        # braking, which a MEMS IMU cannot tell from rest. A car pulling away gently barely changes |f| and the GPS
        # chord cannot see it, while each ZUPT clamps the INS speed under its veto: the horizontal specific force
        # (ENU) can, and a vehicle accelerating by more than 3 ZUPT sigmas within the epoch is not at rest. In a GNSS
        # outage the last chord is stale: it vetoes every stop of the outage, and the INS speed drifts past its limit
        # (paper drive, NHC: 0.3-0.9 m/s over a 20-s stop, then a 15-m jump as the car turned away); opt-in, as a
        # slow rover's cruise looks like rest to the IMU (zupt_max_ins_speed_outage_mps)
        return bool(epoch.w_rms < cfg.stationary_gyro and epoch.w_mean < 0.25 * cfg.stationary_gyro
                    and epoch.f_std < cfg.stationary_accel
                    and abs(epoch.f_mean - epoch.gravity) < 3 * cfg.stationary_accel
                    and float(np.hypot(epoch.f_n[0], epoch.f_n[1])) < 3.0 * cfg.zupt_std * cfg.filter_rate_hz
                    and (epoch.gps_speed < cfg.zupt_max_gps_speed or self.in_outage(epoch))
                    and float(np.linalg.norm(epoch.nav[strapdown.V])) < self.ins_speed_limit(epoch))

    def in_outage(self, epoch: Epoch) -> bool:
        """Whether rest is judged as in a GNSS outage (``zupt_max_ins_speed_outage_mps`` > 0 and no fresh fix): the
        last GPS chord is stale then and does not veto."""
        return self.cfg.zupt_max_ins_speed_outage > 0.0 and not epoch.gnss_fresh

    def ins_speed_limit(self, epoch: Epoch) -> float:
        """The INS speed (m/s) above which the epoch is not rest: ``zupt_max_ins_speed_mps``; in an outage
        (:meth:`in_outage`) the INS speed drifts (NHC does not hold the forward speed), so up to 3 sigma of it, at
        most ``zupt_max_ins_speed_outage_mps``."""
        cfg = self.cfg
        if not self.in_outage(epoch):
            return cfg.zupt_max_ins_speed
        return min(max(cfg.zupt_max_ins_speed, 3.0 * epoch.vel_std_h), max(cfg.zupt_max_ins_speed_outage,
                                                                          cfg.zupt_max_ins_speed))

    def measurement(self, epoch: Epoch):
        if not (self.cfg.zupt_enabled and self.stationary(epoch)):
            return None
        return measurements.zero_velocity(epoch.nav[strapdown.V], self.std(epoch), epoch.n_states)

    def std(self, epoch: Epoch) -> float:
        """The zero-velocity std, m/s: ``zupt_std_mps``; in an outage (:meth:`in_outage`) at least
        ``zupt_std_outage_mps``, as the IMU alone cannot tell a slow cruise from rest (the Katwijk rover's 0.19 m/s:
        a hard ZUPT there made the smoothed outage error worse, 1.59 -> 6.79 m)."""
        if self.in_outage(epoch):
            return max(self.cfg.zupt_std, self.cfg.zupt_std_outage)
        return self.cfg.zupt_std


class NonHolonomic(UpdateModel):
    """Non-holonomic constraints of a land vehicle: zero lateral and vertical velocity of the vehicle frame at the
    constraint point (rear axle, ``nhc_lever_arm_*`` from the IMU, body m), the IMU mounted in the vehicle as
    ``mounting`` (:class:`Mounting`: given, or filter states). Skipped at rest (ZUPT's) and while the heading is
    pending (the constraint acts along the body axes: with a yaw still unknown it bent the velocity and the tilt,
    0.56 -> 0.85 m RMS on the Katwijk rover with x forward; 0.54 m skipping), gated on its own
    (``nhc_gate_probability``): a skid, a jump or a vehicle the constraint does not fit fails the gate.

    With ``C_est = (I - [phi x]) C_true`` the vehicle velocity ``v_v = C_vb (C_bn v_n + w_b x l)`` has the error
    ``C_vb C_bn dv - C_vb C_bn [v_n x] phi + C_vb [l x] dbg + [v_v x] dm`` (the corrected rate is ``w - dbg``;
    ``dm`` the mounting error, :class:`Mounting`).
    """

    name = "nhc"

    def __init__(self, cfg: FilterConfig, mounting: "Mounting"):
        self.enabled = cfg.nhc_enabled
        self.std = cfg.nhc_std
        self.gate_probability = cfg.nhc_gate_probability
        self.lever_b = np.asarray(cfg.nhc_lever_arm_b, dtype=float)
        self.mounting = mounting

    def mounting_deg(self) -> tuple:
        """(pitch, yaw) of the IMU in the vehicle estimated from the drive, deg; (None, None) when given."""
        return self.mounting.pitch_yaw_deg() if self.mounting.index is not None else (None, None)

    def measurement(self, epoch: Epoch):
        if not self.enabled or epoch.stationary or not epoch.heading_known:
            return None
        mat_vb = self.mounting.mat_vb
        mat_bn = epoch.mat_nb.T
        vel_n = epoch.nav[strapdown.V]
        vel_v = mat_vb @ (mat_bn @ vel_n + np.cross(epoch.rate_b, self.lever_b))
        rows = mat_vb[1:] @ mat_bn  # lateral and vertical axes of the vehicle, in ENU
        h = np.zeros((2, epoch.n_states))
        h[:, DV] = rows
        h[:, PHI] = -rows @ skew(vel_n)
        h[:, BG] = mat_vb[1:] @ skew(self.lever_b)
        self.mounting.jacobian(h, vel_v, slice(1, 3))
        return vel_v[1:].copy(), h, np.eye(2) * self.std**2


class WheelOdometer(UpdateModel):
    """The wheel odometer: forward speed of the vehicle (m/s) at the constraint point (``nhc_lever_arm_*``), the IMU
    mounted as ``mounting`` (:class:`Mounting`), measured as ``(1 + s) v_fwd + noise``, ``s`` its scale-factor error,
    a filter state at ``index``. The latest wheel speed stamped no longer than ``odometer_max_age_s`` before an epoch
    is used there; none is a gap (counted once as it starts, by ``count_gap``; NHC goes on alone); a speed of exactly
    0 while the INS says the vehicle moves faster than ``odometer_stuck_speed_mps`` is a stuck wheel, counted and not
    used.

    Like a fix, a speed is used at its own time: it was measured ``lag = t_epoch - stamp + odometer_latency_s``
    before the epoch, so the predicted speed is taken back over the lag with the INS acceleration along the
    vehicle's forward axis ``r`` (the epoch's mean specific force plus gravity, ENU): ``v_fwd - lag r.a`` (the
    forward axis's own turn adds ``w x v_v``, whose forward part is zero while NHC holds).

    With ``C_est = (I - [phi x]) C_true`` the computed ``a`` has the error ``[f x] phi - C_nb dba``, so
    ``z = (1 + s) (v_fwd - lag r.a) - speed`` has ``H[DV] = (1 + s) r``, ``H[PHI] = -(1 + s) r ([v_n x] + lag
    [f x])``, ``H[BA] = (1 + s) lag r C_nb``, ``H[BG] = (1 + s) C_vb[0] [l x]``, ``H[s] = v_fwd - lag r.a`` and the
    mounting's columns (:meth:`Mounting.jacobian`).
    """

    name = "odometer"

    def __init__(self, cfg: FilterConfig, index: int, stuck_counter, mounting: "Mounting", count_gap=None):
        self.enabled = cfg.odometer_enabled
        self.cfg = cfg
        self.index = index
        self.scale = 0.0  # estimated scale-factor error, unitless
        self.pending = None  # (t s, speed m/s): the latest wheel speed
        self.last_t = -np.inf
        self.count_stuck = stuck_counter
        self.count_gap = count_gap if count_gap is not None else (lambda: None)
        self.in_gap = False  # the last epoch had no wheel speed (a gap already counted)
        self.mounting = mounting
        self.lever_b = np.asarray(cfg.nhc_lever_arm_b, dtype=float)

    def _take(self, t_e: float):
        """The pending (stamp s, speed m/s) if stamped within ``odometer_max_age_s`` of ``t_e``, else None (a gap,
        counted as it starts)."""
        pending, self.pending = self.pending, None
        if pending is None or t_e - pending[0] > self.cfg.odometer_max_age:
            if not self.in_gap:
                self.count_gap()
            self.in_gap = True
            return None
        self.in_gap = False
        return pending

    def measurement(self, epoch: Epoch):
        if not self.enabled or not epoch.heading_known:
            return None  # with the heading pending the forward axis is not known (as for NHC)
        taken = self._take(epoch.t)
        if taken is None:
            return None
        t, speed = taken
        lag = epoch.t - t + self.cfg.odometer_latency  # s the speed was measured before the epoch
        mat_vb = self.mounting.mat_vb
        mat_nb = epoch.mat_nb
        vel_n = epoch.nav[strapdown.V]
        vel_v = mat_vb @ (mat_nb.T @ vel_n + np.cross(epoch.rate_b, self.lever_b))
        row = mat_vb[0] @ mat_nb.T  # the vehicle's forward axis in ENU
        accel_n = epoch.f_n + np.array([0.0, 0.0, -epoch.gravity])
        v_fwd = float(vel_v[0]) - lag * float(row @ accel_n)  # m/s at the speed's own time
        if speed == 0.0 and abs(v_fwd) > self.cfg.odometer_stuck_speed:
            self.count_stuck(f"wheel speed at t={t:.3f} s is 0 while the INS says {v_fwd:.1f} m/s: stuck, not used")
            return None
        gain = 1.0 + self.scale
        h = np.zeros((1, epoch.n_states))
        h[0, DV] = row
        h[0, PHI] = -row @ (skew(vel_n) + lag * skew(epoch.f_n))
        h[0, BA] = lag * row @ mat_nb
        h[0, BG] = mat_vb[0] @ skew(self.lever_b)
        self.mounting.jacobian(h, vel_v, slice(0, 1))
        h *= gain
        h[0, self.index] = v_fwd
        return np.array([gain * v_fwd - speed]), h, np.array([[self.cfg.odometer_std**2]])


class Mounting:
    """The IMU's mounting in the vehicle: ``mat_vb`` (body to vehicle; ``mounting_*_deg`` are the body's roll, pitch,
    yaw in the vehicle). Given, it is held; estimated (``index``: two filter states), its errors about the vehicle's
    lateral and vertical axes ``dm`` (rad, ``C_vb,est = (I - [dm x]) C_vb,true``; pitch and yaw) are states started
    at the given angles with ``mounting_std_deg``. A vehicle velocity ``v_v = C_vb v_b`` then has the error
    ``[v_v x] dm``. Roll about the forward axis turns the lateral into the vertical, both zero: not observable and
    not needed."""

    def __init__(self, cfg: FilterConfig, index: slice | None):
        self.mat_vb = frames.mat_nb_from_euler(*cfg.mounting_rpy)
        self.index = index

    def jacobian(self, h: np.ndarray, vel_v: np.ndarray, rows: slice) -> None:
        """Fill, in place, the mounting columns of ``h`` for the vehicle-velocity components ``rows`` (m/s)."""
        if self.index is not None:
            h[:, self.index] = skew(vel_v)[rows, 1:3]

    def feed_back(self, dm_pitch_yaw: np.ndarray) -> None:
        """Remove an estimated mounting error (rad about the vehicle's y and z axes) from ``mat_vb``."""
        self.mat_vb = Rotation.from_rotvec([0.0, *dm_pitch_yaw]).as_matrix() @ self.mat_vb

    def pitch_yaw_deg(self) -> tuple:
        """(pitch, yaw) of the IMU in the vehicle (``mounting_*_deg``'s sense), deg."""
        _, pitch, yaw = frames.euler_from_rotation(Rotation.from_matrix(self.mat_vb))
        return float(np.degrees(pitch)), float(np.degrees(yaw))
