"""Update models: each turns the navigation state at a filter epoch into one measurement of the error state.

One interface (:class:`UpdateModel`): ``measurement(epoch)`` returns ``(z, H, R)`` (z = predicted minus
measured, H on the error state, R the noise covariance) or None when the model has nothing to say at
this epoch. The filter gates, applies and feeds back every measurement the same way
(:meth:`ins_gps_kf.filter.InsGpsFilter._apply`) and counts per model. Models today: GNSS position
(:class:`GnssPosition`) and zero velocity at rest (:class:`ZeroVelocity`); vehicle constraints (NHC) and a
wheel odometer (issue 25) are further models of the same shape: an odometer holds its pending speed as
GNSS holds its fix, NHC judges the epoch as ZUPT does.
"""
from __future__ import annotations

import numpy as np

from ins_gps_kf import measurements, strapdown
from ins_gps_kf.config import FilterConfig
from ins_gps_kf.records import Fix


class Epoch:
    """What an update model sees at one filter epoch: the stamp (s), the navigation state (read live: a model
    applied after another sees its correction), the epoch's motion statistics and the GNSS chord speed."""

    def __init__(self, t: float, nav: np.ndarray, n_states: int, motion: tuple, gravity: float):
        self.t = t
        self.nav = nav
        self.n_states = n_states
        self.w_rms, self.w_mean, self.f_mean, self.f_std = motion[1:]  # rad/s, rad/s, m/s^2, m/s^2
        self.gravity = gravity  # m/s^2
        self.gps_speed = 0.0    # m/s, horizontal speed between the last two fixes less 3 sigma of its noise

    @property
    def mat_nb(self) -> np.ndarray:
        """Body-to-ENU rotation of the current state."""
        return strapdown.mat_nb(self.nav)


class UpdateModel:
    """A measurement of the error state at filter epochs; subclasses give ``name`` and :meth:`measurement`."""

    name = ""

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

    def stationary(self, epoch: Epoch) -> bool:
        """Whether the epoch looks like rest."""
        cfg = self.cfg
        # rms catches vibration, the mean catches a steady turn; GPS and INS speed veto smooth cruising and
        # braking, which a MEMS IMU cannot tell from rest
        return bool(epoch.w_rms < cfg.stationary_gyro and epoch.w_mean < 0.25 * cfg.stationary_gyro
                    and epoch.f_std < cfg.stationary_accel
                    and abs(epoch.f_mean - epoch.gravity) < 3 * cfg.stationary_accel
                    and epoch.gps_speed < cfg.zupt_max_gps_speed
                    and float(np.linalg.norm(epoch.nav[strapdown.V])) < cfg.zupt_max_ins_speed)

    def measurement(self, epoch: Epoch):
        if not (self.cfg.zupt_enabled and self.stationary(epoch)):
            return None
        return measurements.zero_velocity(epoch.nav[strapdown.V], self.cfg.zupt_std, epoch.n_states)
