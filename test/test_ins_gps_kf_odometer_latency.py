"""Wheel-speed latency and gaps handled like the GNSS's (issue 25): a speed is related to the INS state at its own
time (stamp minus ``odometer_latency_s``), taken back from the epoch with the INS acceleration, so speeds delayed by
0.1-0.3 s through hard accelerations and braking bridge a GNSS outage as well as undelayed ones; without the
compensation the same speeds are biased by lag x acceleration (up to 0.6 m/s here), fail the gate and bend the
velocity. A gap in the wheel speeds is counted once and the filter goes on with NHC alone."""
import numpy as np
import pytest

from ins_gps_kf import config
from ins_gps_kf import synthetic as syn
from ins_gps_kf.filter import InsGpsFilter
from ins_gps_kf.offline import run
from nav_eval.metrics import drop_fixes

RATE_HZ = 32.0
OUTAGE = (40.0, 78.0)  # s: no GNSS from 40 s to the end, through +-2 m/s^2 accelerations, braking and turns
MOTION = syn.Motion((20, 5, 5, 4, 3, 3, 3, 3, 10, 3, 3, 3, 3, 6), (0, 2, 0, 0, -2, 2, -2, 2, 0, -2, 2, -2, 2, 0),
                    (0, 0, 0, 0.1, 0, 0, 0, 0, 0.05, 0, 0, 0, 0, 0), 0.2)
PARAMS = {"alignment_time_s": 15.0, "imu_rate_hz": RATE_HZ, "nhc_enabled": True, "odometer_enabled": True}


@pytest.fixture(scope="module")
def hard_drive():
    """(imu, GNSS without the outage's fixes, truth t, position m, velocity m/s) of :data:`MOTION`."""
    rng = np.random.default_rng(1)
    imu = syn.add_imu_errors(syn.ideal_imu(MOTION, RATE_HZ), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = drop_fixes(syn.gnss(MOTION, RATE_HZ, 1.0, rng), [OUTAGE])
    t, pos, vel, _ = syn.truth(MOTION, RATE_HZ)
    return imu, gnss, t, pos, vel


def wheel_speeds(delay_s: float) -> tuple:
    """10-Hz wheel speeds (0.5 % scale error, 0.05 m/s noise) measured at t and stamped ``delay_s`` later."""
    t = np.arange(0.05, OUTAGE[1], 0.1)
    speed = 1.005 * MOTION.speed_yaw(t)[0] + np.random.default_rng(7).normal(0.0, 0.05, len(t))
    return np.round(t + delay_s, 6), speed


def outage_errors(drive, odometry, **params) -> tuple:
    """(largest horizontal position error m, horizontal velocity error RMS m/s) inside the outage, and the filter."""
    imu, gnss, t_true, pos, vel = drive
    filt = InsGpsFilter(config.from_params({**PARAMS, **params}), None)
    est = [e for e in run(filt, imu, gnss, odometry=odometry) if e.t >= OUTAGE[0]]
    t = np.array([e.t for e in est])
    d_pos = np.array([e.position_n for e in est]) - np.column_stack([np.interp(t, t_true, c) for c in pos.T])
    d_vel = np.array([e.velocity_n for e in est]) - np.column_stack([np.interp(t, t_true, c) for c in vel.T])
    return (float(np.max(np.hypot(d_pos[:, 0], d_pos[:, 1]))),
            float(np.sqrt(np.mean(np.sum(d_vel[:, :2] ** 2, axis=1)))), filt)


@pytest.fixture(scope="module")
def undelayed(hard_drive):
    """:func:`outage_errors` with undelayed wheel speeds."""
    return outage_errors(hard_drive, wheel_speeds(0.0))


@pytest.mark.parametrize("delay_s", [0.1, 0.3])
def test_delayed_wheel_speeds_bridge_an_outage_as_undelayed_ones_with_the_latency_compensated(hard_drive, undelayed,
                                                                                               delay_s):
    pos_0, vel_0, _ = undelayed
    pos_c, vel_c, filt = outage_errors(hard_drive, wheel_speeds(delay_s), odometer_latency_s=delay_s)
    pos_u, vel_u, filt_u = outage_errors(hard_drive, wheel_speeds(delay_s))
    # measured (0.1 s / 0.3 s): undelayed 2.54 m, 0.117 m/s; compensated 2.48 / 2.60 m, 0.118 / 0.112 m/s, none gated;
    # not compensated 5.92 / 7.59 m, 0.214 / 0.509 m/s, 20 / 47 of 101 gated
    assert filt.counters.odometer_rejected == 0 and filt.counters.odometer_updates > 90
    assert vel_c <= 1.15 * vel_0 + 0.005, (vel_c, vel_0)
    assert pos_c <= 1.25 * pos_0 + 0.3, (pos_c, pos_0)
    assert vel_u >= 1.5 * vel_0 and pos_u >= 1.5 * pos_0, (vel_u, pos_u, vel_0, pos_0)
    assert filt_u.counters.odometer_rejected >= 15


def test_an_odometer_gap_is_counted_once_and_the_filter_goes_on_with_nhc(hard_drive, undelayed):
    t, speed = wheel_speeds(0.0)
    keep = (t < 50.0) | (t > 60.0)  # 10 s without wheel speeds inside the GNSS outage
    pos_gap, _, filt = outage_errors(hard_drive, (t[keep], speed[keep]))
    pos_all, _, full = undelayed
    pos_nhc, _, nhc_only = outage_errors(hard_drive, None, odometer_enabled=False)
    assert filt.counters.odometer_gaps == 1 and full.counters.odometer_gaps == 0
    assert full.counters.odometer_updates - filt.counters.odometer_updates == 20  # 2-Hz epochs of the 10 s
    assert filt.counters.nhc_updates == full.counters.nhc_updates == nhc_only.counters.nhc_updates
    # measured 2.55 m against 2.54 m with all speeds and 3.74 m with NHC alone
    assert pos_gap < pos_nhc, (pos_gap, pos_all, pos_nhc)
