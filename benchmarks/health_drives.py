"""Drives and faults for the sensor-health benchmark, made without imu_sim: the motion and the true IMU output
come from ``independent_gen`` (its own Earth model and kinematics); the sensor here is a BP3010-like MEMS unit
(white noise, Gauss-Markov bias, rate random walk, increment quantization), and the faults are applied to its
output the way they happen to a real unit. NumPy only.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import independent_gen as gen  # noqa: E402

RATE_HZ = 64.0
SITE = (51.0784, -114.13, 1100.0)
SENSOR = {
    # per-triad: white (rad/sqrt(s), m/s/sqrt(s)), GM bias sd (rad/s, m/s^2), GM tau s, RRW, increment LSB
    "gyro": dict(white=1.5e-3, gm_sd=2e-4, gm_tau=200.0, rrw=2e-6, lsb=2.5e-6),
    "accel": dict(white=2e-3, gm_sd=2e-3, gm_tau=200.0, rrw=2e-5, lsb=5e-5),
}
FAULTS = ("stuck_output", "saturation", "dropout", "non_finite", "white_noise_increase", "vibration",
          "bias_shift_gyro", "bias_shift_accel", "sample_rate_change", "bias_shift_gyro_z", "bias_shift_accel_x",
          "bias_shift_accel_y")


def sensor_noise(rng, n: int, dt: float) -> np.ndarray:
    """Noise (n, 6) of the unit, before quantization (rad/s, m/s^2), turn-on bias included."""
    out = np.zeros((n, 6))
    for k, name in enumerate(("gyro", "accel")):
        p = SENSOR[name]
        out[:, 3 * k:3 * k + 3] = (rng.normal(0, p["white"] / np.sqrt(dt), (n, 3))
                                   + gen.gauss_markov(rng, n, dt, [p["gm_sd"]] * 3, [p["gm_tau"]] * 3)
                                   + np.cumsum(rng.normal(0, p["rrw"] * np.sqrt(dt), (n, 3)), axis=0)
                                   + rng.normal(0, 5 * p["gm_sd"], 3))
    return out


def quantize(x: np.ndarray, dt: float) -> np.ndarray:
    """The unit's increment counters (remainder carried), per triad."""
    return np.hstack([gen.quantize_increments(x[:, :3], dt, SENSOR["gyro"]["lsb"]),
                      gen.quantize_increments(x[:, 3:], dt, SENSOR["accel"]["lsb"])])


def static_run(seed: int, duration_s: float):
    """A level static recording: t (n,), x (n, 6)."""
    rng = np.random.default_rng(seed)
    site = gen.Site(*SITE)
    motion = gen.Poses([(0.0, 0.0, 30.0)], hold_s=duration_s, move_s=1.0)
    t, w, f = site.true_imu(motion, RATE_HZ)
    x = np.hstack([w, f]) + sensor_noise(rng, len(t), 1 / RATE_HZ)
    return t, quantize(x, 1 / RATE_HZ)


class RoadDrive(gen.Motion):
    """Straights and turns at a constant speed, the body rolling out of each turn (roll = K v psi_dot / g)."""

    ROLL_K = 0.05
    TURN_S = 8.0

    def __init__(self, duration_s: float, rng):
        super().__init__(duration_s)
        self.v = rng.uniform(8.0, 25.0)
        starts, angles, t = [], [], rng.uniform(10, 60)
        while t < duration_s + self.TURN_S:
            starts.append(t)
            angles.append(np.radians(rng.uniform(30, 120)) * rng.choice([-1, 1]))
            t += self.TURN_S + rng.uniform(15, 90)
        self.starts, self.angles = np.array(starts), np.array(angles)
        grid = np.arange(-1.0, duration_s + 2.0, 0.005)
        yaw = self._yaw(grid)[0]
        vel = self.v * np.column_stack([np.cos(yaw), np.sin(yaw)])
        self._grid = grid
        self._pos = np.vstack([[0.0, 0.0], np.cumsum((vel[1:] + vel[:-1]) / 2 * 0.005, axis=0)])

    def _yaw(self, t):
        """Heading (rad), its rate and its second derivative (piecewise smoothstep turns)."""
        yaw, rate, acc = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        ordered = t.ndim == 1 and np.all(np.diff(t) >= 0)
        for t0, ang in zip(self.starts, self.angles):
            # on sorted times only the turn's own span is computed (before it u = 0 adds nothing, after it u = 1
            # adds the whole angle): the same sums, term by term, without a pass over the drive per turn
            a, b = (np.searchsorted(t, t0, "left"), np.searchsorted(t, t0 + self.TURN_S, "right")) if ordered \
                else (0, len(t))
            u = np.clip((t[a:b] - t0) / self.TURN_S, 0.0, 1.0)
            inside = (u > 0) & (u < 1)
            yaw[a:b] += ang * (3 * u**2 - 2 * u**3)
            yaw[b:] += ang
            rate[a:b] += np.where(inside, ang * (6 * u - 6 * u**2) / self.TURN_S, 0.0)
            acc[a:b] += np.where(inside, ang * (6 - 12 * u) / self.TURN_S**2, 0.0)
        return yaw, rate, acc

    def position(self, t):
        """Plane position, velocity, acceleration (n, 3)."""
        yaw, rate, _ = self._yaw(t)
        z = np.zeros_like(t)
        p = np.column_stack([np.interp(t, self._grid, self._pos[:, 0]), np.interp(t, self._grid, self._pos[:, 1]), z])
        v = self.v * np.column_stack([np.cos(yaw), np.sin(yaw), z])
        a = self.v * rate[:, None] * np.column_stack([-np.sin(yaw), np.cos(yaw), z])
        return p, v, a

    def attitude(self, t):
        """Roll from the lateral acceleration, level pitch, heading along the velocity."""
        yaw, rate, acc = self._yaw(t)
        k = self.ROLL_K * self.v / gen.G_STANDARD
        z = np.zeros_like(t)
        return (k * rate, z, yaw), (k * acc, z.copy(), rate)


def drive(seed: int, duration_s: float):
    """A road drive (straights and turns with body roll, random speed and turns): t (n,), x (n, 6) (rad/s, m/s^2)."""
    rng = np.random.default_rng(seed)
    site = gen.Site(*SITE)
    motion = RoadDrive(duration_s, rng)
    t, w, f = site.true_imu(motion, RATE_HZ)
    x = np.hstack([w, f]) + sensor_noise(rng, len(t), 1 / RATE_HZ)
    return t, quantize(x, 1 / RATE_HZ)


def sample_sigma() -> np.ndarray:
    """Per-sample white-noise sd (6,) of the unit at RATE_HZ."""
    return np.repeat([SENSOR["gyro"]["white"], SENSOR["accel"]["white"]], 3) * np.sqrt(RATE_HZ)


def inject(fault: str, t: np.ndarray, x: np.ndarray, onset_s: float, channel: int, rng):
    """The recording with ``fault`` from ``onset_s`` on ``channel``: (t, x, truth dict)."""
    t, x = t.copy(), x.copy()
    after = t >= onset_s
    i0 = int(np.argmax(after))
    sig = sample_sigma()[channel]
    truth = {"effect": fault.split("_gyro")[0].split("_accel")[0], "channel": channel, "onset_s": float(t[i0])}
    if fault == "stuck_output":
        x[after, channel] = x[i0, channel]
    elif fault == "saturation":  # a range the motion exceeds after the onset (the monitor is told the range)
        level = np.abs(x[i0, channel]) + 4 * sig
        x[i0, channel] = np.sign(x[i0, channel] or 1.0) * level
        x[after, channel] = np.clip(x[after, channel], -level, level)
        truth["range"] = level
    elif fault == "dropout":
        keep = ~after | (rng.uniform(size=len(t)) > 0.05)
        keep[i0] = False
        t, x = t[keep], x[keep]
        truth["onset_s"] = float(t[i0 - 1] + 1 / RATE_HZ)
    elif fault == "non_finite":
        x[i0, channel] = np.nan
    elif fault == "white_noise_increase":
        x[after, channel] += rng.normal(0, np.sqrt(8.0) * sig, after.sum())  # sd x3
        truth["estimate"] = 3.0
    elif fault == "vibration":
        freq = rng.uniform(5.0, 25.0)
        x[after, channel] += 3 * sig * gen.interval_mean_sin(t[after], 1 / RATE_HZ, freq, rng.uniform(0, 6.28))
        truth["estimate"] = freq
    elif fault.startswith("bias_shift"):
        step = 10 * SENSOR["gyro" if channel < 3 else "accel"]["gm_sd"] * rng.choice([-1, 1])
        x[after, channel] += step
        truth["estimate"] = step
    elif fault == "sample_rate_change":
        keep = ~after | ((np.arange(len(t)) - i0) % 2 == 0)
        t, x = t[keep], x[keep]
        truth["onset_s"] = float(t[i0 - 1] + 1 / RATE_HZ)
    else:
        raise ValueError(f"unknown fault {fault!r}")
    return t, x, truth
