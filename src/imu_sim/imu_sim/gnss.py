"""GNSS fix simulation: truth at the fix time (minus latency) + lever arm + white and coloured noise.

Output is a nav_core :class:`GnssRecording` (NavSatFix-equivalent arrays, diagonal
ENU covariance). Outage fixes carry status -1 (NO_FIX), NaN position and the
configured std (or are dropped with ``outage_mode: drop``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymap3d

from nav_core.recording import GnssRecording
from nav_core.units import DEG

from imu_sim.effects import EffectError, param
from imu_sim.errors import gauss_markov
from imu_sim.trajectory import TruthTrajectory

NO_FIX = -1


@dataclass
class GpsConfig:
    """Receiver settings from the scenario's ``gps`` mapping (SI units)."""

    rate_hz: float = 1.0
    sigma_m: np.ndarray = field(default_factory=lambda: np.array([0.5, 0.5, 1.0]))
    """White position noise std, ENU, m."""
    status: int = 0
    """NavSatStatus of good fixes (0 FIX, 1 SBAS, 2 GBAS/RTK)."""
    outages: list = field(default_factory=list)
    """[[t0, t1], ...] s: no fix inside."""
    outage_mode: str = "nofix"
    enabled: bool = True


@dataclass
class GpsEffects:
    """Parameters of the GNSS effects in the physics section (zero = absent)."""

    lever_arm_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    latency_s: float = 0.0
    colored_sigma_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    colored_time_s: float = 60.0

    @classmethod
    def from_physics(cls, physics: dict | None, scenario_lever_arm=None) -> GpsEffects:
        """Read gps_lever_arm / gps_latency / colored_gps_noise; the lever arm defaults to the scenario's."""
        physics = physics or {}
        out = cls()
        if "gps_lever_arm" in physics:
            p = physics["gps_lever_arm"] or {}
            default = np.zeros(3) if scenario_lever_arm is None else scenario_lever_arm
            out.lever_arm_m = param(p, "gps_lever_arm", "lever_arm_m", default)
        if "gps_latency" in physics:
            out.latency_s = float(param(physics["gps_latency"] or {}, "gps_latency", "latency_s", 0.0, shape=()))
            if not 0.0 <= out.latency_s <= 10.0:
                raise EffectError(f"physics.gps_latency.latency_s: expected a number in [0, 10] s, got {out.latency_s}")
        if "colored_gps_noise" in physics:
            p = physics["colored_gps_noise"] or {}
            out.colored_sigma_m = param(p, "colored_gps_noise", "sigma_m", 0.0)
            if np.any(out.colored_sigma_m < 0):
                raise EffectError("physics.colored_gps_noise.sigma_m: expected numbers >= 0 (m)")
            out.colored_time_s = float(param(p, "colored_gps_noise", "correlation_time_s", 60.0, shape=()))
            if not out.colored_time_s > 0:
                raise EffectError("physics.colored_gps_noise.correlation_time_s: must be > 0 (s)")
        return out


def fix_times(t0: float, t1: float, rate_hz: float) -> np.ndarray:
    """Fix stamps (s) from t0 to t1 inclusive at rate_hz."""
    return t0 + np.arange(int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1) / rate_hz


def antenna_offset_n(traj: TruthTrajectory, t, lever_arm_b) -> np.ndarray:
    """ENU offset (m) of the antenna from the IMU, C_nb l, shape (n, 3)."""
    return traj.attitude.rotation(t).apply(np.tile(np.asarray(lever_arm_b, float), (len(t), 1)))


def simulate_gnss(traj: TruthTrajectory, cfg: GpsConfig, effects: GpsEffects, seed: int) -> GnssRecording:
    """GNSS fixes over the trajectory at ``cfg.rate_hz``."""
    t = fix_times(traj.t0, traj.t1, cfg.rate_hz)
    t_true = np.clip(t - effects.latency_s, traj.t0, traj.t1)
    lat, lon, h = traj.geodetic(t_true)
    offset = antenna_offset_n(traj, t_true, effects.lever_arm_m)
    rng = np.random.default_rng([int(seed), 777])
    offset = offset + rng.standard_normal((len(t), 3)) * cfg.sigma_m
    if np.any(effects.colored_sigma_m > 0):
        offset += gauss_markov(len(t), 1.0 / cfg.rate_hz, effects.colored_sigma_m,
                               np.full(3, effects.colored_time_s), np.random.default_rng([int(seed), 778]))
    lat_d, lon_d, h_f = pymap3d.enu2geodetic(offset[:, 0], offset[:, 1], offset[:, 2], lat / DEG, lon / DEG, h)
    std = np.broadcast_to(np.sqrt(cfg.sigma_m**2 + effects.colored_sigma_m**2), (len(t), 3))
    status = np.full(len(t), cfg.status, dtype=int)
    out = np.zeros(len(t), dtype=bool)
    for t_a, t_b in cfg.outages:
        out |= (t >= t_a) & (t < t_b)
    lat_r, lon_r = np.asarray(lat_d) * DEG, np.asarray(lon_d) * DEG
    h_f = np.asarray(h_f, float)
    if cfg.outage_mode == "drop":
        keep = ~out
        return GnssRecording(t[keep], lat_r[keep], lon_r[keep], h_f[keep], std[keep], status[keep], source="imu_sim")
    status[out] = NO_FIX
    lat_r[out], lon_r[out], h_f[out] = np.nan, np.nan, np.nan
    return GnssRecording(t, lat_r, lon_r, h_f, std, status, source="imu_sim")
