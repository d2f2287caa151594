"""One regressor set per deterministic effect of the vocabulary, computed from the truth.

Each :func:`design_*` returns a :class:`Design`: columns per channel (index into
``case.CHANNELS``) sharing one parameter vector, parameter names (SI units in the
names), and a function turning fitted parameters into the effect's entry of the
model's ``physics`` section. Effects whose size is fixed by physics
(``earth_rotation``, ``gravity_model``, ``coriolis``) get one scale parameter on the
exact difference the effect makes (1 = the physical value).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from nav_core.earth import RATE as EARTH_RATE, normal_gravity
from nav_core.sensor_model import SensorModel
from nav_core.units import G0

from imu_sim.diagnose.case import Case, effective_model, kinematic_difference, trajectory

AXES = "xyz"
TAU_GRID_PER_DECADE = 8
"""Warm-up time constants tried per decade (profile likelihood)."""


@dataclass
class Design:
    """Columns per channel, parameter names, physics-section builder and the physical nominal values."""

    effect: str
    columns: dict
    names: list
    to_physics: Callable
    nominal: dict = field(default_factory=dict)
    profiled: dict = field(default_factory=dict)
    """Name -> (grid, chosen value) of a parameter found by profiling (e.g. time constant)."""

    @property
    def k(self) -> int:
        """Number of linear parameters."""
        return len(self.names)

    def without(self, dropped) -> Design:
        """The design less the parameters ``dropped`` (indices); their physics entry keeps the model's value."""
        keep = [j for j in range(self.k) if j not in set(dropped)]
        cols = {c: x[:, keep] for c, x in self.columns.items() if np.any(x[:, keep] != 0)}
        k_full, to_physics = self.k, self.to_physics

        def physics(theta):
            full = np.zeros(k_full)
            full[keep] = theta
            return to_physics(full)
        return Design(self.effect, cols, [self.names[j] for j in keep], physics, self.nominal, self.profiled)


def _per_channel(names_fmt, channels, cols_fn):
    cols, names = {}, []
    k = len(channels)
    for j, ch in enumerate(channels):
        x = np.zeros((len(cols_fn(ch)), k))
        x[:, j] = cols_fn(ch)
        cols[ch] = x
        names.append(names_fmt(ch))
    return cols, names


def _axis_name(ch: int) -> str:
    return ("gyro" if ch < 3 else "accel"), ch % 3


def design_kinematic(case: Case, model: SensorModel, effect: str) -> Design:
    """Scale on the exact difference an Earth-model effect makes (earth_rotation, gravity_model, coriolis)."""
    diff = kinematic_difference(case, model, effect)
    chans = [c for c in range(6) if np.any(np.abs(diff[:, c]) > 0)]
    cols = {c: diff[:, c:c + 1] for c in chans}
    name = {"earth_rotation": "earth_rate_scale", "gravity_model": "gravity_difference_scale",
            "coriolis": "coriolis_scale"}[effect]

    def to_physics(theta):
        return {}
    return Design(effect, cols, [name], to_physics)


def design_g_sensitivity(case: Case, model: SensorModel) -> Design:
    """Gyro error proportional to the specific force along the same axis (diagonal g-sensitivity)."""
    cols, names = _per_channel(lambda c: f"gyro_coeff_rad_per_s_per_mps2[{AXES[c]}]", [0, 1, 2],
                               lambda c: case.accel_true[:, c])
    base = np.zeros(3)
    if model.has_physics("gyro_g_sensitivity"):
        raw = np.asarray(model.physics["gyro_g_sensitivity"].get("gyro_coeff_rad_per_s_per_mps2", 0.0), float)
        base = np.diag(raw) if raw.ndim == 2 else np.broadcast_to(raw, (3,))
    return Design("gyro_g_sensitivity", cols, names,
                  lambda th: {"gyro_coeff_rad_per_s_per_mps2": (base + th).tolist()})


def _unit(triad: str) -> str:
    return "rad_per_s" if triad == "gyro" else "mps2"


def _channel_columns(n: int, signal, name) -> tuple:
    """One parameter per channel: channel c's design has ``signal`` (shared (n,), or column c of (n, 6)) in
    column c; ``name(triad, axis)`` names the parameters. Returns (columns by channel, names)."""
    sig = np.broadcast_to(np.asarray(signal, dtype=float).reshape(n, -1), (n, 6))
    cols, names = {}, []
    for c in range(6):
        x = np.zeros((n, 6))
        x[:, c] = sig[:, c]
        cols[c] = x
        tri, i = _axis_name(c)
        names.append(name(tri, AXES[i]))
    return cols, names


def design_temperature(case: Case, model: SensorModel, ref_c: float = 25.0) -> Design | None:
    """Bias linear in (temperature - reference) on every channel; None without a temperature."""
    if case.temp_c is None:
        return None
    cols, names = _channel_columns(case.n, case.temp_c - ref_c,
                                   lambda tri, ax: f"{tri}_coeff_{_unit(tri)}_per_degc[{ax}]")
    return Design("temperature_bias", cols, names,
                  lambda th: {"gyro_coeff_rad_per_s_per_degc": th[:3].tolist(),
                              "accel_coeff_mps2_per_degc": th[3:].tolist(), "reference_temp_c": ref_c})


def warmup_taus(duration_s: float, dt: float) -> np.ndarray:
    """Time constants (s) tried for the warm-up: from 20 samples to half the run, log-spaced."""
    lo, hi = max(20 * dt, 1.0), 0.5 * duration_s
    return np.logspace(np.log10(lo), np.log10(hi), max(2, int(TAU_GRID_PER_DECADE * np.log10(hi / lo)) + 1))


def design_warmup(case: Case, model: SensorModel, tau_s: float) -> Design:
    """Bias decaying as exp(-t / tau) on every channel, for one time constant tau (s)."""
    cols, names = _channel_columns(case.n, np.exp(-(case.t - case.t[0]) / tau_s),
                                   lambda tri, ax: f"{tri}_amplitude_{_unit(tri)}[{ax}]")
    return Design("warmup_drift", cols, names,
                  lambda th: {"gyro_amplitude_rad_per_s": th[:3].tolist(), "accel_amplitude_mps2": th[3:].tolist(),
                              "time_constant_s": float(tau_s)})


def design_scale_factor(case: Case, model: SensorModel) -> Design:
    """Error proportional to the true rate / specific force on the same axis."""
    cols, names = _channel_columns(case.n, np.column_stack([case.gyro_true, case.accel_true]),
                                   lambda tri, ax: f"{tri}[{ax}]")
    eff = effective_model(model)
    base = np.concatenate([eff.gyro.scale_factor, eff.accel.scale_factor])
    return Design("scale_factor", cols, names,
                  lambda th: {"gyro": (base[:3] + th[:3]).tolist(), "accel": (base[3:] + th[3:]).tolist()})


def design_misalignment(case: Case, model: SensorModel) -> Design:
    """Error on axis i proportional to the true value on the other axes j != i (both triads)."""
    cols, names, index = {}, [], []
    for tri_i, true in ((0, case.gyro_true), (1, case.accel_true)):
        for i in range(3):
            for j in range(3):
                if i != j:
                    index.append((tri_i, i, j))
                    names.append(f"{('gyro', 'accel')[tri_i]}[{AXES[i]}{AXES[j]}]")
    k = len(index)
    for c in range(6):
        x = np.zeros((case.n, k))
        for p, (tri_i, i, j) in enumerate(index):
            if tri_i * 3 + i == c:
                x[:, p] = (case.gyro_true, case.accel_true)[tri_i][:, j]
        cols[c] = x
    eff = effective_model(model)

    def to_physics(th):
        mats = {"gyro": eff.gyro.misalignment.copy(), "accel": eff.accel.misalignment.copy()}
        for p, (tri_i, i, j) in enumerate(index):
            mats[("gyro", "accel")[tri_i]][i, j] += th[p]
        return {k_: v.tolist() for k_, v in mats.items()}
    return Design("axis_misalignment", cols, names, to_physics)


def physical_value(effect: str, theta: np.ndarray, ci: np.ndarray, case: Case) -> tuple:
    """Named value and interval of a kinematic effect's scale (Earth rate in rad/s, gravity in m/s^2)."""
    if effect == "earth_rotation":
        return {"earth_rate_rad_per_s": float(theta[0] * EARTH_RATE)}, {
            "earth_rate_rad_per_s": (ci[0] * EARTH_RATE).tolist()}
    if effect == "gravity_model":
        # the site from the trajectory itself: a truth CSV's scenario has no latitude_deg / height_m of its own
        traj = trajectory(case)
        lat, _, h = traj.geodetic(np.array([case.sim_t_abs[0]]))
        dg = float(normal_gravity(float(lat[0]), float(h[0])) - G0)
        return ({"gravity_mps2": G0 + float(theta[0]) * dg},
                {"gravity_mps2": sorted((G0 + ci[0] * dg).tolist())})
    return {"coriolis_scale": float(theta[0])}, {"coriolis_scale": ci[0].tolist()}
