"""Unit conversions: the one place where degrees, g, deg/h and friends become SI."""
import numpy as np

G0 = 9.80665
"""Standard gravity in m/s^2 (conventional, not local gravity)."""

DEG = np.pi / 180.0
"""Radians per degree."""

DEG_PER_H = DEG / 3600.0
"""rad/s per deg/h."""

DEG_PER_SQRT_H = DEG / 60.0
"""rad/sqrt(s) per deg/sqrt(h) (angle random walk)."""

MG = 1e-3 * G0
"""m/s^2 per milli-g."""

UG = 1e-6 * G0
"""m/s^2 per micro-g."""

PPM = 1e-6
"""Dimensionless per part-per-million."""


def deg2rad(value_deg):
    """Degrees (scalar or array) to radians."""
    return np.asarray(value_deg, dtype=float) * DEG


def rad2deg(value_rad):
    """Radians (scalar or array) to degrees."""
    return np.asarray(value_rad, dtype=float) / DEG


def g2mps2(value_g):
    """Multiples of standard gravity to m/s^2."""
    return np.asarray(value_g, dtype=float) * G0


def mps22g(value_mps2):
    """m/s^2 to multiples of standard gravity."""
    return np.asarray(value_mps2, dtype=float) / G0


def dph2rps(value_deg_per_h):
    """deg/h to rad/s."""
    return np.asarray(value_deg_per_h, dtype=float) * DEG_PER_H


def rps2dph(value_rad_per_s):
    """rad/s to deg/h."""
    return np.asarray(value_rad_per_s, dtype=float) / DEG_PER_H
