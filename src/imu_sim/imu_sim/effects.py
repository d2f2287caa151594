"""The library of physical effects, keyed by the diagnosis vocabulary (nav_core.sensor_model.EFFECTS).

Three kinds:

* kinematic (``earth_rotation``, ``coriolis``, ``gravity_model``): switch terms of the
  true motion, see :mod:`imu_sim.kinematics`; no parameters.
* sensor (``gyro_g_sensitivity``, ``temperature_bias``, ``warmup_drift``, ``vibration``,
  ``coning_sculling``): functions ``(params, ctx) -> (gyro_add, accel_add)`` returning
  additive mean-rate errors (n, 3) in rad/s and m/s^2.
* model overrides (``scale_factor``, ``axis_misalignment``, ``quantization``,
  ``gauss_markov_bias``, ``bias_random_walk``): set the sensor-model triad terms.
* GNSS (``gps_lever_arm``, ``gps_latency``, ``colored_gps_noise``): see :mod:`imu_sim.gnss`.

Parameter names are listed in src/imu_sim/README.md; bad parameters raise
:class:`EffectError` naming ``physics.<effect>.<key>``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nav_core.sensor_model import EFFECTS, SensorModel

KINEMATIC = ("earth_rotation", "coriolis", "gravity_model")
GNSS = ("gps_lever_arm", "gps_latency", "colored_gps_noise")
MODEL_OVERRIDES = ("scale_factor", "axis_misalignment", "quantization", "gauss_markov_bias", "bias_random_walk")


class EffectError(ValueError):
    """Invalid physics parameters; the message names physics.<effect>.<key>."""


@dataclass
class EffectContext:
    """What a sensor effect sees: sample stamps t (n,) s, dt s, true mean rates, temperature, seed."""

    t: np.ndarray
    dt: float
    gyro_true: np.ndarray
    accel_true: np.ndarray
    temp_c: np.ndarray | None
    seed: int


def param(params: dict, effect: str, key: str, default=None, shape=(3,)):
    """A numeric parameter as an array of ``shape`` (scalars broadcast), or ``default`` when absent."""
    if key not in params or params[key] is None:
        if default is None:
            return None
        return np.broadcast_to(np.asarray(default, float), shape).copy()
    try:
        arr = np.broadcast_to(np.asarray(params[key], dtype=float), shape).copy()
    except (TypeError, ValueError) as err:
        raise EffectError(f"physics.{effect}.{key}: expected numbers of shape {shape}, got {params[key]!r}") from err
    if not np.all(np.isfinite(arr)):
        raise EffectError(f"physics.{effect}.{key}: values must be finite")
    return arr


def _check_keys(params: dict, effect: str, allowed) -> None:
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise EffectError(f"physics.{effect}: unknown parameter(s) {unknown}; known: {sorted(allowed)}")


def _interval_mean_sin(t, dt, freq_hz, phase):
    """Mean of sin(2 pi f s + phase) over s in (t - dt, t], exact."""
    w = 2 * np.pi * freq_hz
    return (np.cos(w * (t - dt) + phase) - np.cos(w * t + phase)) / (w * dt)


def _interval_mean_cos(t, dt, freq_hz, phase):
    """Mean of cos(2 pi f s + phase) over s in (t - dt, t], exact."""
    w = 2 * np.pi * freq_hz
    return (np.sin(w * t + phase) - np.sin(w * (t - dt) + phase)) / (w * dt)


def gyro_g_sensitivity(params: dict, ctx: EffectContext):
    """Gyro rate error G @ f (G 3x3 or diagonal 3-vector, rad/s per m/s^2)."""
    _check_keys(params, "gyro_g_sensitivity", ["gyro_coeff_rad_per_s_per_mps2"])
    raw = np.asarray(params.get("gyro_coeff_rad_per_s_per_mps2", np.zeros(3)), float)
    mat = np.diag(raw) if raw.shape == (3,) else param(params, "gyro_g_sensitivity",
                                                       "gyro_coeff_rad_per_s_per_mps2", shape=(3, 3))
    return ctx.accel_true @ mat.T, np.zeros_like(ctx.accel_true)


def temperature_bias(params: dict, ctx: EffectContext):
    """Bias and scale factor linear in (temperature - reference_temp_c)."""
    keys = ["gyro_coeff_rad_per_s_per_degc", "accel_coeff_mps2_per_degc", "gyro_scale_per_degc",
            "accel_scale_per_degc", "reference_temp_c"]
    _check_keys(params, "temperature_bias", keys)
    if ctx.temp_c is None:
        raise EffectError("physics.temperature_bias: needs a temperature profile (scenario 'temperature')")
    d_temp = (ctx.temp_c - float(params.get("reference_temp_c", 25.0)))[:, None]
    gyro = d_temp * (param(params, "temperature_bias", keys[0], 0.0)
                     + param(params, "temperature_bias", keys[2], 0.0) * ctx.gyro_true)
    accel = d_temp * (param(params, "temperature_bias", keys[1], 0.0)
                      + param(params, "temperature_bias", keys[3], 0.0) * ctx.accel_true)
    return gyro, accel


def warmup_drift(params: dict, ctx: EffectContext):
    """Bias decaying after switch-on: amplitude * exp(-(t - t_start) / time_constant_s)."""
    _check_keys(params, "warmup_drift", ["gyro_amplitude_rad_per_s", "accel_amplitude_mps2", "time_constant_s"])
    tau = float(params.get("time_constant_s", 300.0))
    if not tau > 0:
        raise EffectError(f"physics.warmup_drift.time_constant_s: must be > 0, got {tau}")
    decay = np.exp(-(ctx.t - ctx.t[0]) / tau)[:, None]
    return (decay * param(params, "warmup_drift", "gyro_amplitude_rad_per_s", 0.0),
            decay * param(params, "warmup_drift", "accel_amplitude_mps2", 0.0))


def _band_noise(n, dt, density, band_hz, rng):
    """Band-limited white noise, one-sided PSD density^2 inside band_hz, shape (n, 3)."""
    freqs = np.fft.rfftfreq(n, dt)
    mask = (freqs >= band_hz[0]) & (freqs <= band_hz[1])
    spec = np.fft.rfft(rng.standard_normal((3, n)), axis=1) * mask
    return (np.fft.irfft(spec, n=n, axis=1) * (np.asarray(density, float)[:, None] / np.sqrt(2 * dt))).T


def vibration(params: dict, ctx: EffectContext):
    """Sinusoidal (exact interval means, so aliasing is right) and band-limited random vibration."""
    keys = ["sinusoids", "random_accel_density_mps2_per_sqrt_hz", "random_gyro_density_rad_per_s_per_sqrt_hz",
            "band_hz", "t0_s", "t1_s"]
    _check_keys(params, "vibration", keys)
    gyro, accel = np.zeros_like(ctx.gyro_true), np.zeros_like(ctx.accel_true)
    for i, sine in enumerate(params.get("sinusoids") or []):
        name = f"vibration.sinusoids[{i}]"
        _check_keys(sine, name, ["frequency_hz", "accel_amplitude_mps2", "gyro_amplitude_rad_per_s", "phase_rad"])
        freq = float(sine.get("frequency_hz", 0.0))
        if not freq > 0:
            raise EffectError(f"physics.{name}.frequency_hz: must be > 0")
        wave = _interval_mean_sin(ctx.t, ctx.dt, freq, float(sine.get("phase_rad", 0.0)))[:, None]
        accel += wave * param(sine, name, "accel_amplitude_mps2", 0.0)
        gyro += wave * param(sine, name, "gyro_amplitude_rad_per_s", 0.0)
    band = param(params, "vibration", "band_hz", [0.0, 0.5 / ctx.dt], shape=(2,))
    rng = np.random.default_rng([int(ctx.seed), 4242])
    for key, target in ((keys[1], accel), (keys[2], gyro)):
        density = param(params, "vibration", key, 0.0)
        if np.any(density > 0):
            target += _band_noise(len(ctx.t), ctx.dt, density, band, rng)
    active = (ctx.t >= float(params.get("t0_s", -np.inf))) & (ctx.t <= float(params.get("t1_s", np.inf)))
    return gyro * active[:, None], accel * active[:, None]


def coning_sculling(params: dict, ctx: EffectContext):
    """High-rate coning (x/y angular oscillation, 90 deg apart) with in-phase sculling acceleration.

    Attitude wobble phi = a (cos Wt, sin Wt, 0) gives the gyros phi_dot plus the rectified
    rate a^2 W / 2 on z (the attitude itself does not drift); acceleration
    A (-sin Wt, cos Wt, 0) gives the rectified specific force -a A on z. The truth
    trajectory does not include the bounded wobble (amplitude a).
    """
    _check_keys(params, "coning_sculling", ["coning_amplitude_rad", "frequency_hz", "sculling_accel_mps2"])
    amp = float(params.get("coning_amplitude_rad", 0.0))
    freq = float(params.get("frequency_hz", 0.0))
    acc = float(params.get("sculling_accel_mps2", 0.0))
    if not freq > 0:
        raise EffectError("physics.coning_sculling.frequency_hz: must be > 0")
    w = 2 * np.pi * freq
    t, dt = ctx.t, ctx.dt
    cos_m, sin_m = _interval_mean_cos(t, dt, freq, 0.0), _interval_mean_sin(t, dt, freq, 0.0)
    gyro = np.column_stack([-amp * w * sin_m, amp * w * cos_m, np.full_like(t, 0.5 * amp**2 * w)])
    phi = np.column_stack([amp * cos_m, amp * sin_m, np.zeros_like(t)])
    accel = np.column_stack([-acc * sin_m, acc * cos_m, np.full_like(t, -amp * acc)])
    accel -= np.cross(phi, ctx.accel_true)
    return gyro, accel


SENSOR_EFFECTS = {"gyro_g_sensitivity": gyro_g_sensitivity, "temperature_bias": temperature_bias,
                  "warmup_drift": warmup_drift, "vibration": vibration, "coning_sculling": coning_sculling}
assert set(SENSOR_EFFECTS) | set(KINEMATIC) | set(GNSS) | set(MODEL_OVERRIDES) == set(EFFECTS)


def sensor_errors(physics: dict | None, ctx: EffectContext):
    """Sum of the sensor effects in ``physics``: additive gyro (rad/s) and accel (m/s^2) errors, (n, 3)."""
    gyro, accel = np.zeros_like(ctx.gyro_true), np.zeros_like(ctx.accel_true)
    for name, fn in SENSOR_EFFECTS.items():
        if physics and name in physics:
            g, a = fn(dict(physics[name] or {}), ctx)
            gyro += g
            accel += a
    return gyro, accel


def apply_model_overrides(model: SensorModel) -> SensorModel:
    """A copy of ``model`` with the triad terms set by the model-override effects of its physics section."""
    out = model.copy()
    phys = out.physics or {}
    _override_vec(out, phys, "scale_factor", {"gyro": "gyro", "accel": "accel"}, "scale_factor")
    if "axis_misalignment" in phys:
        p = phys["axis_misalignment"] or {}
        _check_keys(p, "axis_misalignment", ["gyro", "accel"])
        for tri in ("gyro", "accel"):
            if tri in p:
                out.triad(tri).misalignment = param(p, "axis_misalignment", tri, shape=(3, 3))
    if "quantization" in phys:
        p = phys["quantization"] or {}
        _check_keys(p, "quantization", ["gyro_lsb_rad", "accel_lsb_mps"])
        for tri, key in (("gyro", "gyro_lsb_rad"), ("accel", "accel_lsb_mps")):
            if key in p:
                out.triad(tri).quantization = param(p, "quantization", key) / np.sqrt(12.0)
    _override_vec(out, phys, "gauss_markov_bias", {"gyro_sigma_rad_per_s": "gyro", "accel_sigma_mps2": "accel"},
                  "bias_instability",
                  {"gyro_correlation_time_s": "gyro", "accel_correlation_time_s": "accel"})
    _override_vec(out, phys, "bias_random_walk", {"gyro_rad_per_s_per_sqrt_s": "gyro",
                                                  "accel_mps2_per_sqrt_s": "accel"}, "rate_random_walk")
    return out


def _override_vec(model, phys, effect, keys, term, tau_keys=None):
    if effect not in phys:
        return
    p = phys[effect] or {}
    _check_keys(p, effect, list(keys) + list(tau_keys or {}))
    for key, tri in keys.items():
        if key in p:
            setattr(model.triad(tri), term, param(p, effect, key))
    for key, tri in (tau_keys or {}).items():
        if key in p:
            model.triad(tri).bias_correlation_time = param(p, effect, key)
