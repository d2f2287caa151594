"""The bias test's model of the motion: window means of gx, gy, az predicted from the vehicle's own motion.

A land vehicle rolls in a turn and pitches when it brakes: gx sees the roll rate, gy the yaw rate times the roll
(and the pitch rate), az loses a little of gravity and gains the lateral acceleration times the roll. The body's
roll and pitch follow the lateral and longitudinal accelerations, so each of these means is, to first order, a
linear function of a few products of the other channels (``motion_regressors``). A Kalman filter per tested
channel carries its bias (a random walk as fast as the model's bias wanders: ``thresholds.bias_walk_variance``) and the regression coefficients
(learned while driving, starting unknown): its innovation, standardised by its own variance (which includes the
coefficients' uncertainty, so an untrained turn is not a fault), feeds the two-sided bias CUSUM. The bias test
thus runs through turns, not only on straights.

Assumes z is the body's vertical axis (x forward, y left or right), as on a land vehicle's IMU.
"""
from __future__ import annotations

import numpy as np

REGRESSORS = ("gz", "ax", "ay", "gz*ay", "gz*ax", "ay^2", "ax^2", "gz^2", "d_ay", "d_ax", "d_gz")
"""Window means of the motion channels and their products, and their change across the window (LS slope)."""
_RATE_UNIT, _ACC_UNIT = 0.2, 2.0
"""Scale of a turn's yaw rate (rad/s) and a manoeuvre's acceleration (m/s^2): regressors of order 1 in a turn."""
DEAD_ZONE = 0.05
"""Regressors are shrunk towards 0 by this (soft threshold, in units of a turn's): on a straight they are noise,
bias and mount tilt, and an unlearned coefficient times them would let the bias leak into the motion part."""
PRIOR_COEF_SD = {"gyro": 0.05, "accel": 1.0}
"""Prior sd of a coefficient (channel units per unit regressor): generous, the drive teaches them."""
COEF_DRIFT_PER_WINDOW = 1e-4
"""Relative random walk of the coefficients per window (a vehicle's load or tyre pressure changes slowly)."""
MOTION_MODEL_ERROR = 0.05
"""Relative error of the linear motion model (suspension dynamics, products of window means): the predicted motion
part of a mean carries this fraction of itself as extra measurement sd, so a hard turn is not a bias step."""
RESTART_BIAS_SD = 10.0
"""After a named step, the bias is relearned: its variance is reset to this many window-mean sd squared."""


def motion_regressors(x: np.ndarray) -> np.ndarray:
    """Regressors (nw, 11) of windows x (nw, n, 6) (rad/s, m/s^2; non-finite samples as 0), of order 1 in a turn."""
    gz, ax, ay = x[..., 2] / _RATE_UNIT, x[..., 3] / _ACC_UNIT, x[..., 4] / _ACC_UNIT
    n = x.shape[1]
    tt = np.arange(n) - (n - 1) / 2.0

    def change(v):  # the LS slope times the window: the change across it, insensitive to the noise's mean
        return (v - v.mean(axis=1, keepdims=True)) @ tt / (tt @ tt) * (n - 1)

    cols = [gz.mean(1), ax.mean(1), ay.mean(1), (gz * ay).mean(1), (gz * ax).mean(1), (ay * ay).mean(1),
            (ax * ax).mean(1), (gz * gz).mean(1), change(ay), change(ax), change(gz)]
    phi = np.column_stack(cols)
    return np.sign(phi) * np.maximum(np.abs(phi) - DEAD_ZONE, 0.0)


class BiasFilter:
    """Kalman filters (one per tested channel, run together) of [bias, motion coefficients]; SI units.

    ``chans`` (C,) channel indices; ``sd_mean`` (C,) sd of a window mean of the model's white and quantization
    noise; ``q_bias`` (C,) the bias' random-walk variance per window (channel units squared; the Kalman gain on a
    level at steady state is about sqrt(q_bias) / sd_mean)."""

    def __init__(self, chans, sd_mean, q_bias):
        self.chans = np.asarray(chans, int)
        self.sd_mean = np.asarray(sd_mean, float)
        c, p = len(self.chans), len(REGRESSORS) + 1
        self.q_bias = np.asarray(q_bias, float)
        prior = np.array([PRIOR_COEF_SD["gyro" if ch < 3 else "accel"] for ch in self.chans])
        self.coef_var0 = prior**2
        self.theta = np.zeros((c, p))
        self.P = np.zeros((c, p, p))
        self.started = np.zeros(c, bool)
        for i in range(c):
            self.P[i] = np.diag(np.r_[1.0, np.full(p - 1, self.coef_var0[i])])

    def step(self, mean: np.ndarray, phi: np.ndarray, level: np.ndarray, use: np.ndarray):
        """One window: means (6,), regressors (p-1,), noise levels (6,), usable (C,) -> (z (C,), motion (C,)).

        z is the standardised innovation (0 where unused); motion the part of the mean the coefficients explain."""
        y = mean[self.chans]
        h = np.r_[1.0, phi]
        r = self.sd_mean**2 * np.maximum(level[self.chans], 1.0)
        first = use & ~self.started
        # the first window sets the bias outright (its variance: one window mean's)
        self.theta[first, 0] = y[first] - self.theta[first, 1:] @ phi
        self.P[first, 0, 0] = r[first]
        self.started |= first
        run = use & ~first
        q = np.zeros_like(self.P)
        q[:, 0, 0] = self.q_bias
        idx = np.arange(1, self.P.shape[1])
        q[:, idx, idx] = (COEF_DRIFT_PER_WINDOW**2 * self.coef_var0)[:, None]
        self.P = np.where(self.started[:, None, None], self.P + q, self.P)
        motion = self.theta[:, 1:] @ phi
        r = r + (MOTION_MODEL_ERROR * motion) ** 2
        e = y - self.theta @ h
        ph = self.P @ h
        s = ph @ h + r
        z = np.where(run, e / np.sqrt(s), 0.0)
        gain = ph / s[:, None]
        upd = run[:, None]
        self.theta = np.where(upd, self.theta + gain * e[:, None], self.theta)
        self.P = np.where(upd[..., None], self.P - gain[:, :, None] * ph[:, None, :], self.P)
        self.P = 0.5 * (self.P + np.swapaxes(self.P, 1, 2))
        return z, motion

    def restart_bias(self, i: int, step: float) -> None:
        """After a named step on filter ``i``: move the bias by it and relearn it from the windows that follow."""
        self.theta[i, 0] += step
        self.P[i, 0, 0] += (RESTART_BIAS_SD * self.sd_mean[i]) ** 2
