"""Zero-velocity updates only at rest. A car pulling away gently barely changes |f|, the 1-s GPS chord cannot see it
under the fixes' noise, and each ZUPT clamps the INS speed under its own veto: on the paper drive ZUPTs were applied
at 0.1-0.55 m/s at every departure, and the forward position NEES was 5.7 instead of 3 (seed 3). The horizontal
specific force sees a departure; the ZUPT's own gate (``zupt_gate_probability``) refuses what still slips through."""
import numpy as np

from imu_sim.models import bp3010_grade_model
from nav_eval.metrics import run_case


def test_no_zero_velocity_update_once_the_vehicle_pulls_away(outage_drive):
    sim = outage_drive[0]  # with GNSS throughout: its stops fall inside the outages
    est, _ = run_case(sim.imu, sim.gnss, bp3010_grade_model(), {"imu_rate_hz": sim.rate_hz})
    t = np.array([e.t for e in est])
    speed = np.linalg.norm([np.interp(t, sim.truth.t, sim.truth.velocity_n[:, i]) for i in range(3)], axis=0)
    zupt = np.array([e.zupt_used for e in est])
    assert zupt[speed < 1e-3].mean() > 0.8  # at rest they are applied
    # before: 0.08-0.55 m/s at each departure (46, 46.5, 224, 226.5 s ...); now one epoch at 0.08 m/s (406 s)
    assert not np.any(zupt & (speed > 0.1)), np.round(np.column_stack([t, speed])[zupt & (speed > 0.1)], 2)


def test_a_stop_inside_a_gnss_outage_gets_zero_velocity_updates_when_asked():
    """``zupt_max_ins_speed_outage_mps``: without fresh fixes the stale GPS chord no longer vetoes rest and the INS
    speed may drift up to its 3 sigma (at most the parameter) before it does; off by default. A car with NHC stops for
    15 s inside a 40-s outage (the outage's ZUPTs at zupt_std_outage_mps, 0.2 m/s)."""
    from ins_gps_kf import config
    from ins_gps_kf import synthetic as syn
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.offline import run
    from nav_eval.metrics import drop_fixes

    motion = syn.Motion((20, 5, 5, 4, 10, 5, 15, 5, 5, 6), (0, 2, 0, 0, 0, -2, 0, 2, 0, 0),
                        (0, 0, 0, 0.1, 0, 0, 0, 0, 0.1, 0), 0.2)
    outage, rng = (40.0, 80.0), np.random.default_rng(2)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, 32.0), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = drop_fixes(syn.gnss(motion, 32.0, 1.0, rng), [outage])
    t_true, pos, vel, _ = syn.truth(motion, 32.0)
    out = {}
    for limit in (0.0, 1.0):
        filt = InsGpsFilter(config.from_params({"alignment_time_s": 15.0, "imu_rate_hz": 32.0, "nhc_enabled": True,
                                                "zupt_max_ins_speed_outage_mps": limit}), None)
        est = [e for e in run(filt, imu, gnss) if e.t >= outage[0]]
        t = np.array([e.t for e in est])
        err = np.array([e.position_n for e in est]) - np.column_stack([np.interp(t, t_true, c) for c in pos.T])
        speed = np.interp(t, t_true, np.linalg.norm(vel, axis=1))
        zupt = np.array([e.zupt_used for e in est])
        out[limit] = (int(zupt.sum()), int(np.sum(zupt & (speed > 0.1))), float(np.max(np.hypot(*err[:, :2].T))))
    assert out[0.0][0] == 0  # off: the stale chord (10 m/s before the outage) vetoes the stop
    assert out[1.0][0] >= 25 and out[1.0][1] == 0, out  # measured 30 of the stop's 30 epochs, none moving
    assert out[1.0][2] < 0.5 * out[0.0][2], out  # measured 7.35 m against 28.6 m


def test_a_zero_velocity_update_in_an_outage_carries_the_std_of_a_cruise_the_imu_cannot_tell_from_rest():
    """``zupt_std_outage_mps``: without a fresh fix rest is the IMU's word alone, and a rover's 0.2-m/s cruise looks
    like rest to it (Katwijk: hard 0.02-m/s ZUPTs in its outages made the smoothed error worse, 1.59 -> 6.79 m; at
    0.2 m/s 1.38 m, better than none); with a fresh fix the GPS chord confirms rest and the std is zupt_std_mps."""
    from types import SimpleNamespace

    from ins_gps_kf import config
    from ins_gps_kf.updates import ZeroVelocity

    cfg = config.from_params({"zupt_max_ins_speed_outage_mps": 2.0})
    fresh, stale = SimpleNamespace(gnss_fresh=True), SimpleNamespace(gnss_fresh=False)
    assert ZeroVelocity(cfg).std(fresh) == 0.02 and ZeroVelocity(cfg).std(stale) == 0.2
    tight = config.from_params({"zupt_max_ins_speed_outage_mps": 2.0, "zupt_std_outage_mps": 0.0})
    assert ZeroVelocity(tight).std(stale) == 0.02  # never below zupt_std_mps
    off = config.from_params({"zupt_std_outage_mps": 0.5})
    assert ZeroVelocity(off).std(stale) == 0.02  # no ZUPT in outages asked: a stale epoch is not judged as one
