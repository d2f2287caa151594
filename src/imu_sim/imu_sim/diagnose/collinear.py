"""Slow deterministic terms a record cannot tell apart: a warm-up's exponential and the recorded temperature.

A unit's temperature often rises with its warm-up, so the temperature regressor and the warm-up's exponential are
nearly the same curve over the record (blind seed 2: a tactical warm-up of time constant 193 s was named
temperature_bias, its statistic given the warm-up still large). Where they correlate beyond :data:`COLLINEAR` over
the stated samples, both candidates' ``tested`` notes say so (NumPy only).
"""
from __future__ import annotations

import numpy as np

COLLINEAR = 0.95
"""|correlation| of the two regressors (demeaned: the turn-on bias is free) beyond which the record cannot tell
the two effects apart."""


def correlation(t: np.ndarray, temp_c: np.ndarray, tau_s: float, keep: np.ndarray | None = None) -> float:
    """Correlation over ``keep`` of the temperature (degC) and exp(-(t - t0) / tau) (t, tau in s)."""
    keep = np.ones(len(t), bool) if keep is None else keep
    a = np.exp(-(t - t[0]) / tau_s)[keep]
    b = np.asarray(temp_c, float)[keep]
    a, b = a - a.mean(), b - b.mean()
    den = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / den) if den > 0 else 0.0


def note_collinear(case, cands: list) -> None:
    """Add to the significant warm-up and temperature candidates' notes when their regressors are collinear here."""
    by = {c.effect: c for c in cands}
    warm, temp = by.get("warmup_drift"), by.get("temperature_bias")
    if warm is None or temp is None or not (warm.significant and temp.significant):
        return
    tau = (warm.params or {}).get("time_constant_s")
    if getattr(case, "temp_c", None) is None or not tau:
        return
    unstated = getattr(case, "unstated", None)
    r = correlation(case.t, case.temp_c, float(tau), None if unstated is None else ~unstated)
    if abs(r) < COLLINEAR:
        return
    text = (f"collinear with {{other}} on this record: the recorded temperature and the warm-up's exponential (time "
            f"constant {float(tau):.3g} s) correlate at r = {r:.3f} over the stated samples, so this record cannot "
            "tell a warm-up from a temperature coefficient; which one is named rests on the fit's shape alone")
    for cand, other in ((warm, "temperature_bias"), (temp, "warmup_drift")):
        cand.reason = (cand.reason + "; " if cand.reason else "") + text.format(other=other)
