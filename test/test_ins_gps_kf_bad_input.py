"""Bad input to the filter core: impossible IMU samples, bad or doubtful fixes, GPS glitches; nothing raises,
nothing poisons the state, everything is counted in ``input_counters`` (issue 16, the filter)."""
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nav_core import recording
from nav_core.earth import LocalFrame
from nav_core.recording import GnssRecording, ImuRecording
from nav_core.units import DEG
from ins_gps_kf import config, input_checks, synthetic as syn
from ins_gps_kf.filter import NAVIGATING, InsGpsFilter
from ins_gps_kf.offline import run
from ins_gps_kf.replay import main
from nav_eval.bad_input import shift_north

RATE = 32.0
PARAMS = {"alignment_time_s": 20.0}
CIRCLE = syn.circle(still_s=25.0, accel_s=10.0, straight_s=15.0, turn_s=120.0, accel=1.0, yaw_rate=0.04)
TRUE_MAX_SPEED = 10.0  # m/s: accel 1 m/s^2 for 10 s


def _inputs(motion=CIRCLE, seed=3):
    rng = np.random.default_rng(seed)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, np.array([2e-4, -1e-4, 3e-4]),
                             np.array([0.005, -0.004, 0.003]), 0.02 * DEG, 2e-3)
    return imu, syn.gnss(motion, RATE, 1.0, rng)


def _run(imu, gnss, params=None):
    filt = InsGpsFilter(config.from_params({**PARAMS, **(params or {})}))
    return filt, run(filt, imu, gnss)


def _errors(filt, est, motion=CIRCLE):
    """Horizontal position error (m) against the truth and estimated speed (m/s) at every estimate."""
    t = np.array([e.t for e in est])
    tt, pos, _, _ = syn.truth(motion, RATE)
    idx = np.clip(np.round(t * RATE).astype(int), 0, len(tt) - 1)
    origin = LocalFrame(motion.lat0_deg, motion.lon0_deg, motion.h0_m)
    ref = filt.frame.to_enu(*origin.to_geodetic(pos[idx]))
    err = np.hypot(*(np.array([e.position_n for e in est]) - ref)[:, :2].T)
    speed = np.linalg.norm(np.array([e.velocity_n for e in est]), axis=1)
    return t, err, speed


def _finite(est) -> bool:
    return all(np.all(np.isfinite(e.position_n)) and np.all(np.isfinite(e.velocity_n))
               and np.all(np.isfinite(e.quat_xyzw)) and np.all(np.isfinite(e.cov)) for e in est)


# ---------------------------------------------------------------------------------------------- IMU


def test_nan_inf_and_impossible_imu_samples_are_dropped_counted_and_navigation_goes_on():
    imu, gnss = _inputs()
    clean_filt, clean = _run(imu, gnss)
    imu.gyro[1500, 1] = np.nan
    imu.accel[2500, 2] = np.inf
    imu.t[3000] = np.nan
    imu.gyro[3500, 0] = 100.0  # rad/s: beyond any MEMS gyro's range
    imu.accel[4000, 0] = -1e4  # m/s^2
    imu.t[4501] = imu.t[4500]  # a repeated stamp
    filt, est = _run(imu, gnss)
    counts = filt.input_counters
    assert (counts["imu_nonfinite"], counts["imu_out_of_range"], counts["imu_duplicate_stamps"]) == (3, 2, 1)
    assert "IMU sample" in counts["last_rejection"]
    assert _finite(est) and filt.status == NAVIGATING and filt.counters.resets == 0
    t, err, _ = _errors(filt, est)
    _, err_clean, _ = _errors(clean_filt, clean)
    assert len(est) == len(clean)
    assert err[t > 40].max() < err_clean[t > 40].max() + 0.5  # six lost samples of 5,600 change next to nothing


def test_replay_of_a_csv_with_a_nan_sample_exits_0_and_reports_the_rejection(tmp_path, capsys):
    imu, gnss = _inputs(syn.circle(still_s=25.0, accel_s=5.0, straight_s=10.0, turn_s=20.0))
    imu.gyro[900, 2] = np.nan
    paths = [recording.write_imu_csv(tmp_path / "imu.csv", imu), recording.write_gnss_csv(tmp_path / "g.csv", gnss)]
    args = ["replay", "--recording", str(paths[0]), "--gnss", str(paths[1]), "--model", "default", "--quiet",
            "--no-plot", "--param", "alignment_time_s=20.0"]
    assert main([*args, "--out", str(tmp_path / "a.csv")]) == 0
    out = capsys.readouterr()
    assert "imu_nonfinite 1" in out.out and "warning" in out.err
    assert main([*args, "--out", str(tmp_path / "b.csv"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["input"]["imu_nonfinite"] == 1 and summary["resets"] == 0
    traj = recording.read_trajectory_csv(tmp_path / "b.csv")
    assert len(traj) > 20 and np.all(np.isfinite(traj.extra["e_m"]))


# ---------------------------------------------------------------------------------------------- GNSS values


def test_fixes_with_impossible_coordinates_are_dropped_and_counted():
    imu, gnss = _inputs()
    gnss.lat[70] = 221.0 * DEG
    gnss.lon[80] = -200.0 * DEG
    gnss.h[90] = np.nan
    gnss.status[100] = -1
    filt, est = _run(imu, gnss)
    counts = filt.input_counters
    assert counts["fixes_out_of_range"] == 2 and counts["fixes_invalid"] == 2 == filt.counters.fixes_invalid
    assert filt.counters.fixes_rejected == 0 and filt.counters.gps_resets == 0
    t, err, _ = _errors(filt, est)
    assert err[t > 40].max() < 5.0


@pytest.mark.parametrize("std", [0.0, -1.0, np.nan])
def test_a_std_that_is_zero_negative_or_nan_means_unknown_and_navigation_does_not_stall(std):
    imu, gnss = _inputs()
    gnss.std_enu[:] = std
    filt, est = _run(imu, gnss)
    assert filt.input_counters["fixes_std_unknown"] == len(gnss)
    nav = [e for e in est if e.status == NAVIGATING]
    assert len(nav) > 0.8 * len(est)  # the course is taken over a longer baseline with 10-m fixes
    t, err, _ = _errors(filt, est)
    assert err[t > 60].max() < 6.0  # real noise 1 m: the 10-m default is only cautious
    assert "estimated from the innovations" in filt.input_counters["unknown_fix_std"]


def test_a_std_of_zero_on_every_fix_navigates_near_the_run_with_the_real_std_not_7_times_worse():
    imu, gnss = _inputs()  # fixes with 1 m (horizontal) noise
    clean_filt, clean = _run(imu, gnss)
    t0, err0, _ = _errors(clean_filt, clean)
    gnss.std_enu[:] = 0.0  # a converter writing 0 for "unknown"
    filt, est = _run(imu, gnss)
    t, err, _ = _errors(filt, est)
    rms, rms0 = (float(np.sqrt(np.mean(e[tt > 60] ** 2))) for e, tt in ((err, t), (err0, t0)))
    assert rms < 1.5 * rms0, (rms, rms0)  # was: 10 m assumed, several times the clean error
    std_h = filt.unknown_fix_std.std_enu[0]
    assert 0.6 < std_h < 1.6, std_h  # the truth is 1 m
    assert f"{std_h:.3g} m horizontal" in filt.input_counters["unknown_fix_std"]


def test_replay_of_fixes_with_std_0_warns_with_the_estimated_std(tmp_path, capsys):
    imu, gnss = _inputs(syn.circle(still_s=25.0, accel_s=5.0, straight_s=10.0, turn_s=40.0))
    gnss.std_enu[:] = 0.0
    paths = [recording.write_imu_csv(tmp_path / "imu.csv", imu), recording.write_gnss_csv(tmp_path / "g.csv", gnss)]
    assert main(["replay", "--recording", str(paths[0]), "--gnss", str(paths[1]), "--model", "default", "--quiet",
                 "--no-plot", "--param", "alignment_time_s=20.0", "--out", str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    line = next(ln for ln in err.splitlines() if "carry no std" in ln)
    assert f"{len(gnss)} fixes" in line and "estimated from the innovations" in line and "gps_std_m" in line


def test_a_configured_gps_std_replaces_an_unknown_one_without_counting():
    imu, gnss = _inputs()
    gnss.std_enu[:] = 0.0
    filt, est = _run(imu, gnss, {"gps_std_m": 1.0, "gps_std_up_m": 2.0})
    assert filt.input_counters["fixes_std_unknown"] == 0
    assert est[-1].status == NAVIGATING


# ---------------------------------------------------------------------------------------------- GNSS stamps


def _with_rows(gnss, idx):
    return GnssRecording(gnss.t[idx], gnss.lat[idx].copy(), gnss.lon[idx].copy(), gnss.h[idx].copy(),
                         gnss.std_enu[idx], gnss.status[idx])


def test_exact_duplicate_fixes_are_dropped_and_counted_and_change_nothing():
    imu, gnss = _inputs()
    _, clean = _run(imu, gnss)
    k = np.arange(len(gnss))
    filt, est = _run(imu, _with_rows(gnss, np.sort(np.concatenate([k, k[60:70]]))))
    assert filt.input_counters["fixes_duplicate"] == 10
    assert [e.position_n.tolist() for e in est] == [e.position_n.tolist() for e in clean]


def test_conflicting_duplicate_stamps_are_counted_and_neither_position_is_used():
    imu, gnss = _inputs()
    k = np.arange(len(gnss))
    doubled = _with_rows(gnss, np.sort(np.concatenate([k, k[60:70]])))
    second = np.flatnonzero(np.diff(doubled.t) == 0) + 1
    doubled = shift_north(doubled, second, 22.0)
    filt, est = _run(imu, doubled)
    assert filt.input_counters["fixes_conflicting"] == 10
    t, err, _ = _errors(filt, est)
    assert not any(e.gps_used for e in est if 61.0 <= e.t < 69.0)  # ten fixes withdrawn, no fix in between
    assert err[t > 40].max() < 11.0  # 10 s of INS alone in a turn, far below the 22-m conflict
    assert err[t > 80].max() < 3.0


@pytest.mark.parametrize("step_s", [100.0, 1.5])  # 1.5 s: a fix comes after the one before, stamped 0.5 s before it
@pytest.mark.parametrize("burst", [True, False])
def test_fix_stamps_stepping_back_are_dropped_then_put_back_on_the_imu_clock(burst, step_s):
    imu, gnss = _inputs()
    back = slice(100, 112) if burst else slice(100, None)
    gnss.t[back] -= step_s  # a GNSS clock stepping back (and, for the burst, forward again)
    filt, est = _run(imu, gnss)
    counts = filt.input_counters
    n_confirm = config.from_params({}).max_rejected_fixes
    assert counts["fixes_out_of_order"] == n_confirm - 1  # dropped until the step is confirmed
    assert counts["gnss_clock_steps"] == (2 if burst else 1)
    assert filt.counters.gps_resets == 0 and filt.counters.fixes_rejected == 0
    t, err, _ = _errors(filt, est)
    assert err[t > 40].max() < 5.0
    assert any(e.gps_used for e in est if e.t > 150.0)


def test_a_single_fix_stamped_far_ahead_is_dropped_and_the_rest_is_used():
    imu, gnss = _inputs()
    _, clean = _run(imu, gnss)
    gnss.t[80] = 1e9
    filt, est = _run(imu, gnss)
    assert filt.input_counters["fixes_out_of_order"] == 1
    t, err, _ = _errors(filt, est)
    assert len(est) == len(clean) and err[t > 40].max() < 5.0


# ---------------------------------------------------------------------------------------------- GNSS glitches


@pytest.mark.parametrize("offset_m", [200.0, 500e3])
def test_six_fix_glitch_is_rejected_without_a_reset_and_the_error_stays_small(offset_m):
    imu, gnss = _inputs()
    k = int(np.searchsorted(gnss.t, 100.0))
    filt, est = _run(imu, shift_north(gnss, np.arange(k, k + 6), offset_m))
    t, err, speed = _errors(filt, est)
    assert err[t > 40].max() < 50.0
    assert speed.max() < 2 * TRUE_MAX_SPEED
    assert filt.counters.gps_resets == 0 and filt.counters.fixes_rejected == 6
    counts = filt.input_counters
    assert counts["gps_resets_refused"] >= 1 and counts["gps_jumps"] >= 2


def test_a_diverged_ins_is_still_reset_to_a_consistent_gps_track():
    imu, gnss = _inputs()
    wrong_yaw = {"initial_yaw_deg": CIRCLE.yaw0 / DEG + 180.0, "heading_std_deg": 1.0}  # confidently backwards
    filt, est = _run(imu, gnss, wrong_yaw)
    assert filt.counters.gps_resets == 1 and filt.input_counters["gps_resets_refused"] == 0
    t, err, _ = _errors(filt, est)
    assert err[(t > 25) & (t < 33)].max() > 40.0  # it did diverge
    assert err[t > 40].max() < 5.0  # and is back on the GPS track, heading from the course


def test_the_course_ignores_a_chord_faster_than_the_speed_limit():
    motion = syn.straight(still_s=25.0, accel_s=10.0, cruise_s=40.0)
    imu, gnss = _inputs(motion)
    k = int(np.searchsorted(gnss.t, 27.0))  # heading still pending: no gate against a known course yet
    filt, est = _run(imu, shift_north(gnss, np.array([k]), 300.0))
    _, _, speed = _errors(filt, est, motion)
    assert speed.max() < 2 * TRUE_MAX_SPEED
    assert filt.input_counters["gps_jumps"] >= 1 and est[-1].status == NAVIGATING


def test_an_ins_faster_than_twice_the_speed_limit_resets_and_is_never_output():
    imu, gnss = _inputs()
    filt, est = _run(imu, gnss, {"max_speed_mps": 3.0})
    _, _, speed = _errors(filt, est)
    assert filt.input_counters["state_resets"] >= 1 and filt.counters.resets >= 1
    assert speed.max() <= 6.0


# ---------------------------------------------------------------------------------------------- interface


def test_input_counters_are_plain_ints_under_documented_keys():
    imu, gnss = _inputs(syn.stationary(duration_s=30.0))
    filt, _ = _run(imu, gnss)
    counts = filt.input_counters
    assert set(counts) == set(input_checks.InputCounters().as_dict())
    for key in counts:
        assert key in input_checks.__doc__
        assert isinstance(counts[key], str if key in ("last_rejection", "unknown_fix_std") else int)
    assert all(v == 0 for v in counts.values() if isinstance(v, int)) and counts["unknown_fix_std"] == ""


# ---------------------------------------------------------------------------------------------- fuzz

SHORT = syn.circle(still_s=8.0, accel_s=4.0, straight_s=6.0, turn_s=12.0, accel=1.0, yaw_rate=0.1)
SHORT_IMU, SHORT_GNSS = _inputs(SHORT, seed=11)
WILD = st.sampled_from([np.nan, np.inf, -np.inf, 1e9, -1e9, 0.0, 1e-300])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(["imu_t", "gyro", "accel", "fix_t", "lat", "lon", "h", "std", "status",
                                           "dup_imu", "dup_fix", "back_imu", "back_fix"]),
                          st.integers(0, 10**6), WILD), max_size=12))
def test_random_damage_to_the_input_never_raises_and_never_makes_the_state_non_finite(damage):
    imu = ImuRecording(SHORT_IMU.t.copy(), SHORT_IMU.gyro.copy(), SHORT_IMU.accel.copy())
    g = _with_rows(SHORT_GNSS, np.arange(len(SHORT_GNSS)))
    g.std_enu = g.std_enu.copy()
    g.status = g.status.copy()
    for kind, pos, value in damage:
        i, j = pos % len(imu), pos % len(g)
        if kind == "imu_t":
            imu.t[i] = value
        elif kind in ("gyro", "accel"):
            getattr(imu, kind)[i, pos % 3] = value
        elif kind == "fix_t":
            g.t[j] = value
        elif kind in ("lat", "lon", "h"):
            getattr(g, kind)[j] = value
        elif kind == "std":
            g.std_enu[j, pos % 3] = value
        elif kind == "status":
            g.status[j] = -1 if np.isnan(value) else int(np.clip(value, -1, 2))
        elif kind == "dup_imu":
            imu.t[min(i + 1, len(imu) - 1)] = imu.t[i]
        elif kind == "dup_fix":
            g.t[min(j + 1, len(g) - 1)] = g.t[j]
        elif kind == "back_imu":
            imu.t[i:] -= (pos % 50) + 0.5
        else:
            g.t[j:] -= (pos % 50) + 0.5
    filt = InsGpsFilter(config.from_params({"alignment_time_s": 5.0, "min_alignment_time_s": 2.0}))
    est = run(filt, imu, g)
    est += filt.process_imu(np.array([np.nan, np.inf]), np.full((2, 3), np.nan), np.full((2, 3), np.inf))
    filt.process_gps(np.nan, np.inf, -np.inf, np.nan, np.full(3, np.nan), 0)
    assert _finite(est)
    if filt.nav is not None:
        assert np.all(np.isfinite(filt.nav)) and np.all(np.isfinite(filt.cov))


# ---------------------------------------------------------------------------------------------- wrong coordinates


def _replay_gnss(tmp_path, imu, gnss, capsys):
    paths = [recording.write_imu_csv(tmp_path / "imu.csv", imu), recording.write_gnss_csv(tmp_path / "g.csv", gnss)]
    out = tmp_path / "traj.csv"
    code = main(["replay", "--recording", str(paths[0]), "--gnss", str(paths[1]), "--model", "default", "--quiet",
                 "--no-plot", "--param", "alignment_time_s=20.0", "--out", str(out)])
    return code, capsys.readouterr().err, out.exists()


@pytest.mark.parametrize("case", ["clean", "radians", "persistently_rejected"])
def test_fixes_in_radians_or_persistently_rejected_are_a_named_error_not_exit_0(tmp_path, capsys, case):
    imu, gnss = _inputs()
    if case == "radians":  # radian numbers in the lat_deg/lon_deg columns (was: exit 0, thousands of km off)
        gnss.lat, gnss.lon = gnss.lat * DEG, gnss.lon * DEG
    if case == "persistently_rejected":  # fixes scattered by 5 m that claim 5 cm: ~80 % rejected, exit 0 before
        gnss = syn.gnss(CIRCLE, RATE, 5.0, np.random.default_rng(1))
        gnss.std_enu[:] = 0.05
    code, err, written = _replay_gnss(tmp_path, imu, gnss, capsys)
    if case == "clean":
        assert code == 0 and written and "error" not in err
        return
    assert code == 2 and not written, err
    line = one_line = next(ln for ln in err.splitlines() if "error" in ln)
    assert "g.csv" in line and "radians" in line and "swapped" in line, one_line
    if case == "radians":
        assert "velocity changes are 0.0" in line and "1/57.3" in line
    else:
        assert "rejected 1" in line and "of 171 fixes" in line and "std far below" in line
