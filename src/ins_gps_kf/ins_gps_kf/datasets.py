"""Rover evaluation on the NaveGo recordings (loaders in :mod:`nav_core.datasets`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nav_core.datasets import AXIS_CHOICES, load_canada, load_katwijk
from nav_core.recording import RecordingError
from nav_core.units import DEG


def evaluate_rover(name, out_dir) -> dict:
    """Katwijk: the filter with each axis choice, the best (by GPS NIS) reported against the reference."""
    from ins_gps_kf import evaluate
    from ins_gps_kf.filter import NAVIGATING
    from ins_gps_kf.replay import plot_north_east, to_trajectory

    if name not in ("katwijk", "canada"):
        raise RecordingError(f"dataset {name!r}: no loader (katwijk, canada)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if name == "katwijk":
        loader, outage_period = load_katwijk, 90.0
        params = {"imu_rate_hz": 125.0, "gps_rate_hz": 1.0 / 3.0, "alignment_time_s": 15.0,
                  "heading_min_speed_mps": 0.1, "stationary_gyro_dps": 2.0}
    else:
        loader, outage_period = load_canada, 90.0
        # the run turns after ~4 s of rest: a short alignment is all there is
        params = {"imu_rate_hz": 200.0, "gps_rate_hz": 20.0, "alignment_time_s": 3.0, "min_alignment_time_s": 2.0,
                  "gps_std_m": 1.0,
                  "gps_std_up_m": 2.0, "heading_min_speed_mps": 0.1, "stationary_gyro_dps": 2.0}
    results = {}
    for axes_name in AXIS_CHOICES:
        imu, gnss, ref, info = loader(axes_name)
        est, filt = evaluate.run_case(imu, gnss, None, params)
        nis = [e.nis for e in est if e.gps_used and np.isfinite(e.nis)]
        results[axes_name] = (float(np.mean(nis)) if nis else np.inf, est, filt, imu, gnss, ref, info)
    best = min(results, key=lambda k: results[k][0])
    _, est, filt, imu, gnss, ref, info = results[best]
    t_from = next((e.t for e in est if e.status == NAVIGATING), 0.0) + 10.0
    source = {"katwijk": "ESA Katwijk beach; reference = the source's 20 Hz interpolation of the same RTK fixes",
              "canada": "UTIAS Canadian planetary run 3; reference = its pose ground truth (UTM), placed on the "
                        "GPS by a fitted rotation + translation (relative errors only)"}[name]
    figures = {"source": f"NaveGo examples/planetary-rovers (LGPL-3 code; data licence not stated): {source}",
               "params": params, "alignment": info, "mean_nis_by_axes": {k: v[0] for k, v in results.items()},
               "errors": evaluate.error_figures(est, ref, filt.frame, None, t_from),
               "consistency": evaluate.consistency(est, ref, filt.frame, t_from),
               "counters": {"fixes": filt.counters.fixes, "rejected": filt.counters.fixes_rejected,
                            "zupts": filt.counters.zupts, "gps_resets": filt.counters.gps_resets}}
    windows = evaluate.outage_windows(t_from, min(gnss.t[-1], ref.t[-1]), outage_period, 30.0, t_from + 20.0)
    est_o, filt_o, = evaluate.run_case(imu, evaluate.drop_fixes(gnss, windows), None, params)
    figures["outage_30s_every_90s"] = evaluate.outage_drift(est_o, ref, filt_o.frame, windows)
    ref_enu = filt.frame.to_enu(ref.lat / DEG, ref.lon / DEG, ref.h)
    plot_north_east(out_dir / f"{name}.png", to_trajectory(est, filt.frame), gnss, filt.frame, ref_enu,
                    title=f"{name} rover: filter, GPS, reference")
    evaluate.write_report(out_dir / f"{name}.json", figures)
    return figures