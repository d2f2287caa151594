"""WGS-84 Earth for the blind generator: normal gravity, Earth rate, radii, transport rate (SI, ENU)."""
import numpy as np

SEMI_MAJOR_M = 6378137.0
FLATTENING = 1.0 / 298.257223563
ECC2 = FLATTENING * (2.0 - FLATTENING)
EARTH_RATE_RAD_S = 7.292115e-5
GM_M3_S2 = 3.986004418e14
GAMMA_EQUATOR = 9.7803253359
GAMMA_POLE = 9.8321849378
STANDARD_GRAVITY = 9.80665
"""What a naive simulation uses instead of the gravity model, m/s^2."""


def normal_gravity(lat_rad, h_m):
    """Normal gravity magnitude, m/s^2: Somigliana's closed form plus the second-order free-air term."""
    b = SEMI_MAJOR_M * (1.0 - FLATTENING)
    k = b * GAMMA_POLE / (SEMI_MAJOR_M * GAMMA_EQUATOR) - 1.0
    s2 = np.sin(lat_rad) ** 2
    g0 = GAMMA_EQUATOR * (1.0 + k * s2) / np.sqrt(1.0 - ECC2 * s2)
    m = EARTH_RATE_RAD_S**2 * SEMI_MAJOR_M**2 * b / GM_M3_S2
    a = SEMI_MAJOR_M
    return g0 * (1.0 - 2.0 / a * (1.0 + FLATTENING + m - 2.0 * FLATTENING * s2) * h_m + 3.0 * h_m**2 / a**2)


def earth_rate_enu(lat_rad):
    """Earth rotation in ENU, rad/s, shape (..., 3): (0, Omega cos lat, Omega sin lat)."""
    lat = np.asarray(lat_rad, float)
    return np.stack([np.zeros_like(lat), EARTH_RATE_RAD_S * np.cos(lat), EARTH_RATE_RAD_S * np.sin(lat)], -1)


def radii(lat_rad):
    """Meridian and prime-vertical radii of curvature, m."""
    w = np.sqrt(1.0 - ECC2 * np.sin(lat_rad) ** 2)
    return SEMI_MAJOR_M * (1.0 - ECC2) / w**3, SEMI_MAJOR_M / w


def transport_rate_enu(lat_rad, h_m, v_enu):
    """Rotation of the local ENU frame over the Earth, rad/s, shape (..., 3), for ENU velocity in m/s."""
    rm, rn = radii(lat_rad)
    v = np.asarray(v_enu, float)
    return np.stack([-v[..., 1] / (rm + h_m), v[..., 0] / (rn + h_m),
                     v[..., 0] * np.tan(lat_rad) / (rn + h_m)], -1)
