"""The simulated paper drive through the filter: nominal, outages, re-used fixes, hand-tuned noise model.

``ins-gps-kf evaluate --dataset paper-sim --out DIR`` runs the project simulator's paper drive
(:mod:`imu_sim`) through the filter with and without periodic GPS outages and writes
``DIR/paper_sim.json`` and PNG plots (Fig. 6 style).
"""
from __future__ import annotations

from pathlib import Path

from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate
from nav_core.units import DEG
from ins_gps_kf.offline import plot_north_east, to_trajectory
from nav_eval.metrics import consistency, drop_fixes, error_figures, outage_drift, outage_windows, run_case, \
    write_report
from nav_core.workspace import PAPER_DRIVE, workspace_file


def paper_sim(out_dir, seed: int = 0, scenario=None) -> dict:
    """The simulated paper drive: nominal, 30/60 s outages every 180 s, re-used fixes, hand-tuned noise model."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario = scenario or workspace_file(PAPER_DRIVE)
    model = bp3010_grade_model()
    sim = simulate(str(scenario), model=model, seed=seed, with_bytes=False)
    params = {"imu_rate_hz": sim.rate_hz}
    t_from = 60.0  # after alignment (45 s) and the heading fix
    figures = {"source": f"imu_sim paper_drive, seed {seed}, model bp3010_grade_model", "cases": {}}
    cases = {"nominal": (sim.gnss, model, params),
             "reuse_last_fix": (sim.gnss, model, {**params, "reuse_last_fix": True}),
             "hand_tuned_noise_model": (sim.gnss, None, params)}
    windows = {}
    for length in (30.0, 60.0):
        windows[length] = outage_windows(t_from, sim.truth.t[-1], 180.0, length, 120.0)
        cases[f"outage_{int(length)}s_every_180s"] = (drop_fixes(sim.gnss, windows[length]), model, params)
    for name, (gnss, mdl, prm) in cases.items():
        est, filt = run_case(sim.imu, gnss, mdl, prm)
        fig = {"errors": error_figures(est, sim.truth, filt.frame, sim.gnss, t_from),
               "consistency": consistency(est, sim.truth, filt.frame, t_from),
               "rejected_fixes": filt.counters.fixes_rejected, "zupts": filt.counters.zupts,
               "input": {k: v for k, v in filt.input_counters.items() if v}}
        if name.startswith("outage"):
            length = float(name.split("_")[1][:-1])
            fig["outage_drift"] = outage_drift(est, sim.truth, filt.frame, windows[length])
        figures["cases"][name] = fig
        if name in ("nominal", "outage_60s_every_180s"):
            truth_enu = filt.frame.to_enu(sim.truth.lat / DEG, sim.truth.lon / DEG, sim.truth.h)
            plot_north_east(out_dir / f"paper_sim_{name}.png", to_trajectory(est, filt.frame), gnss, filt.frame,
                            truth_enu, title=f"simulated paper drive ({name}): filter, GPS, truth")
    write_report(out_dir / "paper_sim.json", figures)
    return figures
