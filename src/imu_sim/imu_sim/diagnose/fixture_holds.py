"""Where each static segment's fixture tilt acts in a record: its weight at each sample (1 on its hold, blended across
the moves) and that weight's time derivative (NumPy only; :mod:`fixture` fits the tilts)."""
from __future__ import annotations

import numpy as np


def hold_weights(case) -> np.ndarray | None:
    """(n, segments) weight of each static segment's tilt at each sample and its time derivative (1/s), or None: 1 on
    the hold; across a move the tilt passes from one hold's to the next's with the move's own profile (the simulator
    moves along a smoothstep in rotation-vector space, so its rate magnitude is that profile's slope)."""
    if getattr(case.scenario, "source", None) != "static_segments":
        return truth_hold_weights(case)
    t = case.sim_t_abs
    segs = sorted(case.scenario.spec, key=lambda s: float(s["t0"]))
    n, m = case.n, len(segs)
    w, wdot = np.zeros((n, m)), np.zeros((n, m))
    speed = np.linalg.norm(case.gyro_true, axis=1)
    for s, seg in enumerate(segs):
        w[(t > float(seg["t0"])) & (t <= float(seg["t1"])), s] = 1.0
    w[t <= float(segs[0]["t0"]), 0] = 1.0
    w[t > float(segs[-1]["t1"]), m - 1] = 1.0
    for s in range(m - 1):
        rows = (t > float(segs[s]["t1"])) & (t <= float(segs[s + 1]["t0"]))
        if not rows.any():
            continue
        p = speed[rows] if speed[rows].sum() > 0 else np.ones(rows.sum())
        p = p / (p.sum() * case.dt)
        cum = np.cumsum(p) * case.dt
        w[rows, s], w[rows, s + 1] = 1.0 - cum, cum
        wdot[rows, s], wdot[rows, s + 1] = -p, p
    # a rate table's spinning segments get no tilt of their own: the unit is mounted once, and its tilt against the
    # table axis, common to every spinning hold, is the gyro misalignment the table is there to measure
    spinning = [s for s, seg in enumerate(segs) if float(seg.get("rate_dps", 0.0) or 0.0) != 0.0]
    w[:, spinning], wdot[:, spinning] = 0.0, 0.0
    return np.stack([w, wdot])


STILL_RAD_S = 1e-3
"""A truth file's hold turning slower than this (rad/s; the Earth rate is 7.3e-5) is a static fixture pose."""


def truth_hold_weights(case) -> np.ndarray | None:
    """Weights of :func:`hold_weights` for a truth file's static holds (:func:`reference.holds` that do not turn: a
    tumble from a CSV), blended linearly across each move; None with fewer than two. A rate table's spinning holds
    are left out: its one mounting tilt, common to every hold, is the gyro misalignment it is there to measure."""
    from imu_sim.diagnose.reference import holds
    spans = [(a, b) for a, b in holds(case) if np.max(np.abs(case.gyro_true[a:b])) < STILL_RAD_S]
    if len(spans) < 2:
        return None
    n, m = case.n, len(spans)
    w, wdot = np.zeros((n, m)), np.zeros((n, m))
    for s, (a, b) in enumerate(spans):
        w[a:b, s] = 1.0
    w[:spans[0][0], 0] = 1.0
    w[spans[-1][1]:, m - 1] = 1.0
    for s in range(m - 1):
        a, b = spans[s][1], spans[s + 1][0]
        if b > a:
            u = (np.arange(a, b) - a + 1) / (b - a + 1)
            w[a:b, s], w[a:b, s + 1] = 1.0 - u, u
            wdot[a:b, s], wdot[a:b, s + 1] = -1.0 / ((b - a + 1) * case.dt), 1.0 / ((b - a + 1) * case.dt)
    return np.stack([w, wdot])
