"""Each finding's share of the mismatch, on one scale for every effect: the residual power it accounts for.

Scale: the effect's energy in the residual over the per-sample noise variance of each channel it shows on,
sum over samples and channels (a signal-to-noise energy, the expected likelihood-ratio gain of knowing the
effect). Deterministic effects and lines: sum of contrib^2 / sigma^2; a bias random walk: n K^2 T / 6 / sigma^2
(a walk's variance about its mean over a record of T s); a Gauss-Markov bias: n sigma_gm^2 / sigma^2;
quantization: n (step^2 / 12) / sigma^2; GNSS effects the same on the fix residual with the fixes' white sigma.
The share of a finding is its energy over the sum over all findings.
"""
from __future__ import annotations

import numpy as np

from imu_sim.diagnose import metrics
from imu_sim.diagnose.case import CHANNELS, effective_model


def energy(case, cand, model, resid: np.ndarray) -> float:
    """The finding's energy in units of the per-sample noise variance (see module docstring)."""
    if cand.kind == "gnss":
        return _gnss_energy(case, cand, model)
    chans = [CHANNELS.index(c) for c in cand.channels] or list(range(6))
    sigma2 = np.array([max(metrics.robust_var(resid[:, c]), 1e-300) for c in range(6)])
    if cand.contrib is not None:
        return float(sum(np.sum((cand.contrib[:, c] - cand.contrib[:, c].mean()) ** 2) / sigma2[c] for c in chans))
    mdl = effective_model(model)
    total = 0.0
    for c in chans:
        tri, i, ax = ("gyro", "accel")[c // 3], c % 3, "xyz"[c % 3]
        if cand.effect == "bias_random_walk":
            unit = "rad_per_s_per_sqrt_s" if tri == "gyro" else "mps2_per_sqrt_s"
            k2 = max(cand.params.get(f"{tri}_{unit}[{ax}]", 0.0) ** 2 - mdl.triad(tri).rate_random_walk[i] ** 2, 0)
            var = k2 * (case.n * case.dt) / 6.0
        elif cand.effect == "gauss_markov_bias":
            unit = "sigma_rad_per_s" if tri == "gyro" else "sigma_mps2"
            var = cand.params.get(f"{tri}_{unit}[{ax}]", 0.0) ** 2
        elif cand.effect == "quantization":
            unit = "output_step_rad_per_s" if tri == "gyro" else "output_step_mps2"
            var = cand.params.get(f"{tri}_{unit}[{ax}]", 0.0) ** 2 / 12.0
        else:
            var = 0.0
        total += case.n * var / sigma2[c]
    return float(total)


def _gnss_energy(case, cand, model) -> float:
    from imu_sim.diagnose import gnss_tests as gt
    gr = gt.gnss_residual(case, model)
    if gr is None:
        return 0.0
    sw2 = np.maximum(np.asarray(gr.sigma_w, float) ** 2, 1e-300) * np.ones(3)
    if cand.contrib is not None:
        c = cand.contrib - cand.contrib.mean(axis=0)
        return float(np.sum(c**2 / sw2))
    extra = np.array([max(cand.params.get(f"sigma_m[{a}]", 0.0) ** 2 - s**2, 0.0)
                      for a, s in zip("enu", np.asarray(gr.colored_sigma, float) * np.ones(3))])
    return float(len(gr.r) * np.sum(extra / sw2))


def shares(energies) -> list:
    """Each energy's fraction of their sum (0 each when the sum is 0)."""
    total = float(np.sum(energies))
    return [float(e / total) if total > 0 else 0.0 for e in energies]


def _without(model, base, effect: str):
    """The final model less one finding: its physics entry removed (or back to the input model's own entry)."""
    out = model.copy()
    out.physics = dict(out.physics or {})
    if base.physics and effect in base.physics:
        out.physics[effect] = base.physics[effect]
    else:
        out.physics.pop(effect, None)
    return out


def _imu_drop(case, full: np.ndarray, dropped: np.ndarray, model=None) -> float:
    """Increase of the IMU residual's energy (per-sample noise variance units, turn-on bias per channel a
    nuisance) from the full model's residual to the residual without one finding. On a moving truth file both are
    whitened by the model's noise plus the reference's error first, as the tests weight them (else the truth's own
    slow error, correlated with a small effect by chance, decides its share)."""
    from imu_sim.diagnose import reference
    full, dropped = (reference.clean(case, r) for r in (full, dropped))
    if model is not None and getattr(case, "scenario", None) is not None and reference.moving_file_truth(case):
        full, cols = reference.whitened(case, model, full, {c: dropped[:, c] for c in range(6)})
        dropped = np.column_stack([cols[c] for c in range(6)])
    full, dropped = full - full.mean(axis=0), dropped - dropped.mean(axis=0)
    sigma2 = np.array([max(metrics.robust_var(full[:, c]), 1e-300) for c in range(6)])
    return float(np.sum((dropped**2 - full**2) / sigma2))


def _gnss_drop(case, model, without) -> float:
    """The same on the fix residual (datum offset per axis a nuisance), in units of the fixes' white variance."""
    from imu_sim.diagnose import gnss_tests as gt
    full, dropped = gt.gnss_residual(case, model), gt.gnss_residual(case, without)
    if full is None or dropped is None:
        return 0.0
    sw2 = np.maximum(np.asarray(full.sigma_w, float) ** 2, 1e-300) * np.ones(3)
    a, b = full.r - full.r.mean(axis=0), dropped.r - dropped.r.mean(axis=0)
    return float(np.sum((b**2 - a**2) / sw2))


DROP_ONE_FLOOR = 1e-9
"""Relative residual change below which dropping a finding changes no deterministic output (a stochastic term:
its energy is its variance, :func:`energy`)."""
STOCHASTIC_KINDS = ("noise", "quantization")


def drop_one(case, model, base, findings: list, cands: list) -> list:
    """Each finding's drop-one contribution in the joint fit: how much the final model's residual energy grows when
    that finding alone is removed, the others kept at their fitted values (same scale as :func:`energy`). A
    finding that changes no deterministic output (a noise term) keeps its own energy. Effects that explain the same
    part of the residual (a lever arm and a latency on a car) each get only what the other cannot explain."""
    from imu_sim.diagnose.case import residual
    full = residual(case, model)
    out = []
    for f, cand in zip(findings, cands):
        without = _without(model, base, cand.effect)
        if cand.kind == "gnss":
            gain = _gnss_drop(case, model, without) if cand.effect != "colored_gps_noise" else None
        else:
            dropped = residual(case, without)
            moved = np.abs(dropped - full).max() > DROP_ONE_FLOOR * max(np.abs(full).max(), 1e-300)
            gain = _imu_drop(case, full, dropped, model) if moved or cand.kind not in STOCHASTIC_KINDS else None
        out.append(max(gain, 0.0) if gain is not None else float(f.get("mismatch_energy") or 0.0))
    return out
