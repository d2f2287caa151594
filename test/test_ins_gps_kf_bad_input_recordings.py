"""``ins-gps-kf replay`` on recordings a user brings damaged: no exit 0 with nothing (or nonsense) computed; the
error names the file and the column or field; what the filter can still use is used and the rest is said."""
import numpy as np
import pytest

from nav_core import recording
from nav_core.recording import ImuRecording
from nav_core.units import DEG, G0, imu_unit_problem
from ins_gps_kf import synthetic as syn
from ins_gps_kf.input_checks import IMU_STEP_CONFIRM
from ins_gps_kf.replay import main

RATE = 32.0
MOTION = syn.circle(still_s=25.0, accel_s=5.0, straight_s=10.0, turn_s=20.0)


NOISY_GYRO = np.random.default_rng(7).normal(0.0, 0.014, (int(sum(MOTION.durations) * RATE), 3))  # BP3010's white
# noise per 64-Hz sample, rad/s: a gyro this noisy in deg/s reads ~1.4 "rad/s" at rest


@pytest.fixture(scope="module")
def inputs():
    rng = np.random.default_rng(3)
    imu = syn.add_imu_errors(syn.ideal_imu(MOTION, RATE), rng, np.array([2e-4, -1e-4, 3e-4]),
                             np.array([0.005, -0.004, 0.003]), 0.02 * DEG, 2e-3)
    return imu, syn.gnss(MOTION, RATE, 1.0, rng)


def _replay(tmp_path, imu, gnss, capsys):
    """Exit code, stderr and whether the output was written."""
    paths = [recording.write_imu_csv(tmp_path / "imu.csv", imu), recording.write_gnss_csv(tmp_path / "g.csv", gnss)]
    out = tmp_path / "traj.csv"
    code = main(["replay", "--recording", str(paths[0]), "--gnss", str(paths[1]), "--model", "default", "--quiet",
                 "--no-plot", "--param", "alignment_time_s=20.0", "--out", str(out)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err, out.exists()


def _copy(imu, t=None, gyro=None, accel=None):
    return ImuRecording(imu.t if t is None else t, imu.gyro if gyro is None else gyro,
                        imu.accel if accel is None else accel)


def test_the_clean_recording_replays_with_no_warning(tmp_path, inputs, capsys):
    code, err, written = _replay(tmp_path, *inputs, capsys)
    assert code == 0 and written and "warning" not in err


@pytest.mark.parametrize("case, words", [
    ("accel_in_g", ["imu.csv", "columns ax, ay, az", "in g?"]),
    ("gyro_in_deg_per_s", ["imu.csv", "columns gx, gy, gz", "deg/s"]),
    ("time_in_ms", ["imu.csv", "column t", "median sample interval 31.25 s"]),
    ("rows_in_reverse_order", ["imu.csv", "column t", "reverse order"]),
    ("header_only", ["imu.csv", "0 IMU sample"]),
])
def test_an_imu_csv_in_other_units_or_order_is_exit_2_naming_file_and_column_not_exit_0(tmp_path, inputs, capsys,
                                                                                       case, words):
    imu, gnss = inputs
    bad = {"accel_in_g": lambda: _copy(imu, accel=imu.accel / G0),
           "gyro_in_deg_per_s": lambda: _copy(imu, gyro=(imu.gyro + NOISY_GYRO) / DEG),
           "time_in_ms": lambda: _copy(imu, t=imu.t * 1000.0),
           "rows_in_reverse_order": lambda: _copy(imu, t=imu.t[::-1], gyro=imu.gyro[::-1], accel=imu.accel[::-1]),
           "header_only": lambda: _copy(imu, t=imu.t[:0], gyro=imu.gyro[:0], accel=imu.accel[:0])}[case]()
    code, err, written = _replay(tmp_path, bad, gnss, capsys)
    # was: exit 0, with 0 epochs (deg/s, ms, reversed, header only) or a 5x larger error (g)
    assert code == 2 and not written, err
    line = next(ln for ln in err.splitlines() if "error" in ln)
    for w in words:
        assert w in line, (w, line)


def test_fixes_on_another_time_base_are_exit_2_naming_the_gnss_file(tmp_path, inputs, capsys):
    imu, gnss = inputs
    gnss.t = gnss.t * 1000.0  # ms: was exit 0 with all but the first fix dropped and the INS alone
    code, err, written = _replay(tmp_path, imu, gnss, capsys)
    gnss.t = gnss.t / 1000.0
    assert code == 2 and not written
    assert "g.csv" in err and "1 of" in err and "fixes fall within the IMU recording's time" in err


def test_a_cut_gnss_file_and_a_step_back_in_imu_time_are_said_and_the_run_goes_on(tmp_path, inputs, capsys):
    imu, gnss = inputs
    keep = gnss.t < 40.0
    cut = recording.GnssRecording(gnss.t[keep], gnss.lat[keep], gnss.lon[keep], gnss.h[keep], gnss.std_enu[keep])
    t = imu.t.copy()
    t[1000], t[1001] = t[1001], t[1000]
    code, err, written = _replay(tmp_path, _copy(imu, t=t), cut, capsys)
    assert code == 0 and written
    assert "the last fix is" in err and "before the end of the IMU recording" in err
    assert "gap(s) over" not in err  # a cut file is not a gap
    assert "time going backwards (sample 1001" in err


def test_a_recording_that_never_aligns_is_exit_2_with_the_reason(tmp_path, inputs, capsys):
    imu, gnss = inputs
    rng = np.random.default_rng(1)
    # turning by 0.5 rad/s in place from the start: never at rest
    gyro = imu.gyro + np.array([0.0, 0.0, 0.5]) + rng.normal(0, 0.01, imu.gyro.shape)
    code, err, written = _replay(tmp_path, _copy(imu, gyro=gyro), gnss, capsys)
    assert code == 2 and not written
    assert "no filter epoch" in err and "stationary_gyro_dps" in err and "in_motion" in err


@pytest.mark.parametrize("scale, flagged", [(1.0, None), (1.0 / G0, "accel"), (1000.0 / G0, "accel"),
                                            (1.0 / DEG, "gyro")])
def test_imu_unit_problem_flags_only_what_si_cannot_be(scale, flagged):
    rng = np.random.default_rng(0)
    n = 2000
    gyro = rng.normal(0, 0.02, (n, 3)) + [0, 0, 0.1]  # a noisy MEMS gyro, turning a little
    accel = rng.normal(0, 0.3, (n, 3)) + [0.5, 0.2, 9.8]
    if flagged == "accel":
        accel = accel * scale
    elif flagged == "gyro":
        gyro = gyro * scale
    gyro[5] = np.nan  # ignored
    text = imu_unit_problem(gyro, accel, "GYRO", "ACCEL")
    assert (text is None) if flagged is None else (flagged.upper() in text)


@pytest.mark.parametrize("back", ["swapped_pair", "block_reversed", "step_back_0.5_s"])
def test_imu_samples_stamped_a_little_back_are_dropped_and_counted_not_a_reset(inputs, back):
    from ins_gps_kf import config
    from ins_gps_kf.filter import InsGpsFilter
    from ins_gps_kf.offline import run

    imu, gnss = inputs
    k = int(30.0 * RATE)  # moving
    t = imu.t.copy()
    if back == "swapped_pair":
        t[k], t[k + 1] = t[k + 1], t[k]
        dropped = 1
    elif back == "block_reversed":
        t[k:k + 16] = t[k:k + 16][::-1]
        dropped = 15
    else:
        t[k:] -= 0.5  # the IMU clock steps back by less than time_jump_s: re-stamped once 3 samples show it
        dropped = IMU_STEP_CONFIRM - 1  # (was: 0.5 s of samples dropped, and the stamps 0.5 s behind to the end)
    runs = []
    for stamps in (imu.t, t):
        filt = InsGpsFilter(config.from_params({"alignment_time_s": 20.0}))
        runs.append((filt, run(filt, _copy(imu, t=stamps), gnss)))
    (clean_filt, clean), (filt, est) = runs
    assert filt.counters.resets == 0  # was: a reset, and no output until the filter had its heading again
    assert filt.input_counters["imu_out_of_order"] == dropped
    assert filt.input_counters["imu_clock_steps"] == (back == "step_back_0.5_s")
    assert len(est) >= len(clean) - 1
    err = [np.linalg.norm(a.position_n - b.position_n) for a, b in zip(clean, est) if a.t == b.t and a.t > 31.0]
    assert max(err) < 1.0  # the step: was up to 10 m (the IMU 0.5 s behind the fixes for the rest of the run)


def test_the_filter_never_takes_a_specific_force_far_from_g_as_rest_and_says_so(inputs):
    from ins_gps_kf import config
    from ins_gps_kf.filter import ALIGNING, InsGpsFilter
    from ins_gps_kf.offline import run

    imu, gnss = inputs
    filt = InsGpsFilter(config.from_params({"alignment_time_s": 20.0}))
    est = run(filt, _copy(imu, accel=imu.accel / G0), gnss)  # the node's path: no whole-file unit check there
    counts = filt.input_counters
    assert est == [] and filt.status == ALIGNING  # was: aligned on 1 m/s^2 of "gravity" and navigated
    assert counts["alignment_not_gravity"] >= 20 and "in g" in counts["last_rejection"]
    filt = InsGpsFilter(config.from_params({"alignment_time_s": 20.0}))
    assert run(filt, imu, gnss) and filt.input_counters["alignment_not_gravity"] == 0


def test_a_misspelt_param_override_names_the_parameter_meant(tmp_path, inputs, capsys):
    paths = [recording.write_imu_csv(tmp_path / "imu.csv", inputs[0]), recording.write_gnss_csv(tmp_path / "g.csv",
                                                                                                  inputs[1])]
    assert main(["replay", "--recording", str(paths[0]), "--gnss", str(paths[1]), "--model", "default",
                 "--out", str(tmp_path / "t.csv"), "--param", "alignment_tme_s=20"]) == 2
    assert "did you mean 'alignment_time_s'?" in capsys.readouterr().err


def test_an_outage_in_the_fixes_is_said(tmp_path, inputs, capsys):
    imu, gnss = inputs
    keep = (gnss.t < 30.0) | (gnss.t > 45.0)
    holed = recording.GnssRecording(gnss.t[keep], gnss.lat[keep], gnss.lon[keep], gnss.h[keep], gnss.std_enu[keep])
    code, err, written = _replay(tmp_path, imu, holed, capsys)
    assert code == 0 and written and "1 gap(s) over 10 s between fixes" in err
