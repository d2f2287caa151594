"""A hand-mounted rate table's scale-factor fit set up without a scenario file (shared by the table tests)."""
from types import SimpleNamespace

import numpy as np

from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import mounting
from imu_sim.diagnose.candidate import Candidate
from imu_sim.diagnose.spectral import Whitener


def scale_factor_case(t, dt, gyro, accel, nominal, spec, resid, sd, tolerance_deg, **case):
    """(ctx, scale-factor candidate) of a table record sampled every ``dt`` s at ``t``: ``gyro``/``accel`` (n, 3)
    true rad/s and m/s^2 in the body, ``nominal`` (n, 3, 3) body to ENU, ``spec`` the stated segments, ``resid``
    (n, 6) the residual, ``sd`` (6,) its white per-sample sd; ``case`` adds attributes to the case."""
    n = len(t)
    model = SimpleNamespace(accel=SimpleNamespace(bias_instability=0.0, rate_random_walk=0.0))
    rec = SimpleNamespace(t=t, n=n, dt=dt, gyro_true=gyro, accel_true=accel, cache={"body_to_enu": nominal},
                          unstated=None, model=model, **case,
                          scenario=SimpleNamespace(source="static_segments", spec=spec,
                                                   attitude_tolerance_deg=tolerance_deg))
    psd = np.repeat((sd**2 * dt)[:, None], n // 2 + 1, axis=1)
    smodel = SensorModel(gyro=TriadModel(white_noise=sd[:3] * np.sqrt(dt)),
                         accel=TriadModel(white_noise=sd[3:] * np.sqrt(dt)), sample_rate_hz=1.0 / dt)
    ctx = SimpleNamespace(case=rec, model=smodel, resid=resid, wh=Whitener.from_psd(psd, resid, dt),
                          resid_f=np.fft.rfft(resid, axis=0), m_tests=14, factor=lambda e: 1.0)
    true = np.column_stack([gyro, accel])
    names = [f"{tri}[{a}]" for tri in ("gyro", "accel") for a in "xyz"]
    cand = Candidate("scale_factor", 1e6, 40.0, "GLS likelihood ratio", params=dict.fromkeys(names, 0.0),
                     columns={c: np.column_stack([true[:, c] if j == c else np.zeros(n) for j in range(6)])
                              for c in range(6)})
    return ctx, cand


def scale_errors_in_half_widths(ctx, cand, scale) -> np.ndarray:
    """Fit the table (``mounting.mounting_fit``); the gyro scale factors' errors from ``scale`` (3,) in half-widths
    of their 95 % intervals."""
    mounting.mounting_fit(ctx, cand)
    iv = np.array([cand.intervals[f"gyro[{a}]"] for a in "xyz"])
    return (iv.mean(axis=1) - scale) / (0.5 * np.diff(iv, axis=1)[:, 0])
