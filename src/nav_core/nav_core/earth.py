"""WGS-84 Earth model: normal gravity, Earth rate, radii of curvature, transport rate, local ENU.

Latitudes and longitudes are in rad unless a name ends in ``_deg``; heights in m
above the ellipsoid; vectors in ENU.
"""
from dataclasses import dataclass

import numpy as np
import pymap3d

A = 6378137.0
"""WGS-84 semi-major axis, m."""
F = 1.0 / 298.257223563
"""WGS-84 flattening."""
E2 = F * (2.0 - F)
"""First eccentricity squared."""
RATE = 7.292115e-5
"""Earth rotation rate, rad/s."""
GM = 3.986004418e14
"""Geocentric gravitational constant, m^3/s^2."""
GAMMA_E = 9.7803253359
"""Normal gravity at the equator, m/s^2."""
K_SOMIGLIANA = 0.00193185265241
"""Somigliana constant (b*gamma_p / (a*gamma_e) - 1)."""
M_RATIO = 0.00344978600308
"""omega^2 a^2 b / GM."""


def normal_gravity(lat_rad, height_m=0.0):
    """Magnitude of WGS-84 normal gravity (gravitation + centrifugal) in m/s^2 at latitude and height."""
    s2 = np.sin(lat_rad) ** 2
    gamma0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    h = np.asarray(height_m, dtype=float)
    return gamma0 * (1.0 - 2.0 / A * (1.0 + F + M_RATIO - 2.0 * F * s2) * h + 3.0 * h**2 / A**2)


def gravity_n(lat_rad, height_m=0.0):
    """Normal gravity vector in ENU, m/s^2, shape (3,) or (n, 3) (points down: -z)."""
    g = np.asarray(normal_gravity(lat_rad, height_m))
    out = np.zeros(g.shape + (3,))
    out[..., 2] = -g
    return out


def earth_rate_n(lat_rad):
    """Earth rotation rate vector in ENU, rad/s, shape (3,) or (n, 3)."""
    lat = np.asarray(lat_rad, dtype=float)
    out = np.zeros(lat.shape + (3,))
    out[..., 1] = RATE * np.cos(lat)
    out[..., 2] = RATE * np.sin(lat)
    return out


def radii(lat_rad):
    """Meridian (north-south) and prime-vertical (east-west) radii of curvature, m."""
    s2 = np.sin(lat_rad) ** 2
    w = np.sqrt(1.0 - E2 * s2)
    return A * (1.0 - E2) / w**3, A / w


def transport_rate_n(lat_rad, height_m, velocity_n):
    """Rotation rate of ENU relative to the Earth, rad/s, for ENU velocity (m/s), shape (3,) or (n, 3)."""
    rm, rn = radii(lat_rad)
    v = np.asarray(velocity_n, dtype=float)
    out = np.empty(np.broadcast_shapes(v.shape, np.shape(lat_rad) + (3,)))
    out[..., 0] = -v[..., 1] / (rm + height_m)
    out[..., 1] = v[..., 0] / (rn + height_m)
    out[..., 2] = v[..., 0] * np.tan(lat_rad) / (rn + height_m)
    return out


@dataclass(frozen=True)
class LocalFrame:
    """A local ENU frame with its origin (datum) at a geodetic point (degrees and m at the edge)."""

    lat0_deg: float
    lon0_deg: float
    h0_m: float = 0.0

    def to_enu(self, lat_deg, lon_deg, h_m):
        """ENU coordinates in m, shape (..., 3), of geodetic points (deg, deg, m)."""
        e, n, u = pymap3d.geodetic2enu(lat_deg, lon_deg, h_m, self.lat0_deg, self.lon0_deg, self.h0_m)
        return np.stack(np.broadcast_arrays(e, n, u), axis=-1).astype(float)

    def to_geodetic(self, enu_m):
        """Geodetic (lat_deg, lon_deg, h_m) of ENU points in m, shape (..., 3)."""
        enu = np.asarray(enu_m, dtype=float)
        lat, lon, h = pymap3d.enu2geodetic(enu[..., 0], enu[..., 1], enu[..., 2],
                                           self.lat0_deg, self.lon0_deg, self.h0_m)
        return np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float)


def mat_ne(lat_rad, lon_rad):
    """Rotation matrix ECEF -> local ENU at geodetic (lat, lon) in rad, shape (3, 3) or (n, 3, 3).

    Its rows are the east, north and up unit vectors in ECEF; its transpose maps ENU to ECEF.
    """
    lat = np.asarray(lat_rad, dtype=float)
    lon = np.asarray(lon_rad, dtype=float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    out = np.zeros(np.broadcast_shapes(lat.shape, lon.shape) + (3, 3))
    out[..., 0, 0], out[..., 0, 1] = -so, co
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = -sl * co, -sl * so, cl
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = cl * co, cl * so, sl
    return out
