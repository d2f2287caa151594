"""The diagnosis on recordings it did not make: cases from ``independent_gen`` (no imu_sim code), files as users write.

    .venv/bin/python benchmarks/bench_diagnosis_independent.py [--seeds 20] [--null-seeds 20] [--cases ...] [--out DIR] [--quick] [--realistic]

Each case writes imu.csv (10 significant digits), scenario.yaml (a truth CSV at 100 Hz, or static segments as a
user types them), model.yaml (what the user believes) and, for drives, gnss.csv; then diagnoses them through
``load_case`` + ``diagnose`` (what ``imu-sim diagnose`` runs, without the plots) with ``--max-effects 2``.
Scores: right effect first, interval coverage of the true parameters, findings on the null cases.
The ``null_single_naive`` case is chained like a user: ``imu-calib allan`` on the recording writes the model.
Seeds 7000.. (effects) and 8000.. (nulls): neither the calibration (5000..) nor the own suite (1000.., 3000..).

``--realistic`` gives every case the input properties a real user's data has (issue 24): the model states each
noise level only to within +-10 %; the bias instability is flicker noise (two-sided PSD B^2 / (2 pi f)), stated in
the model (to +-10 %); fixtures (tumble poses, the static and up/down holds) are off their nominal attitude by up
to ATTITUDE_TOL_DEG while the user's truth states the nominal one; a drive's truth.csv is at 10 Hz and carries a
slow position error (5-30 cm horizontal, twice that vertical, periods 30-600 s) and a slow attitude error (roll and
pitch 0.005-0.03 deg, yaw 0.02-0.1 deg), as from smoothing a noisy GNSS track;
the rate table is typed as static_segments (its holds), so the simulator's own ramp shape differs from the table's;
the tumble holds each pose 20-35 s (HOLDS_REALISTIC_S), the up/down pauses 2 s on its side, and the temperature and
random-walk cases are resized (TEMP_REALISTIC, RW_REALISTIC) so the flicker bias instability does not bury them.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
import independent_gen as gen  # noqa: E402

SITE = (51.0784, -114.13, 1100.0)
REALISTIC = False
SLOW_SPEED = 0.62
"""Set by ``--realistic`` (see the module docstring)."""
DRIVE = "figure8"
"""``--drive town``: the drive cases run on a 240-s town drive (stops, quintic speed changes <= 2 m/s^2, turns with
lateral acceleration <= 2.5 m/s^2, hills, body roll; ``independent_gen.StopAndGo``) instead of the 1200-s
figure-eight."""
TRUTH_VELOCITY = True
"""``--truth-positions``: a realistic drive's truth.csv has positions and attitude only (no ve/vn/vu rows), as a
track smoothed from GNSS is often written: the simulator's specific force then comes from the positions' spline."""
NOISE_MISSTATED = 0.10
"""Largest relative error of a noise level the user's model states (realistic cases)."""
GYRO_FLICKER, ACCEL_FLICKER = 2e-5, 1e-4
"""Flicker bias instability B of the realistic cases, rad/s and m/s^2 (corner with the white noise near 1.6 mHz)."""
RW_REALISTIC = 5.0
"""The realistic random-walk case's walk is this many times larger: 6e-7 rad/s/sqrt(s) is buried under the flicker
bias instability over the whole 2-h record (their PSDs cross near 1e-4 Hz), so no method could name it."""
TEMP_REALISTIC = 3.0
"""The realistic temperature case's coefficients are this many times larger: 1e-6 rad/s/degC over the +-10 degC cycle
(period 30 min) is a 1e-5 rad/s bias wave under a flicker bias instability of 2e-5 rad/s, whose PSD at 0.56 mHz is
three times the white level: its likelihood ratio is ~7 against a threshold of 19.7, so no method could name it."""
FIXTURE_TEMP_ACCEL = np.array([5e-4, -4e-4, 6e-4])
"""An industrial accelerometer's bias temperature coefficient on the fixture cases (m/s^2/degC; 0.05 mg/degC,
times the square root of the grade's noise factor: 1.6e-4 tactical, 1.1e-3 consumer): uncompensated MEMS units
drift 0.1-1 mg/degC (the blind's tactical fixture carried ~1e-3 m/s^2/degC); the 1.5e-5 m/s^2/degC it had before
hid under an industrial unit's accelerometer wander."""
HOLDS_REALISTIC_S = (20.0, 35.0)
"""A realistic tumble holds each pose for a time drawn from this range (s), as an operator turning a cube by hand."""
UPDOWN_PAUSE_S = 2.0
"""A realistic up/down turns through a pause of this long on its side (level) between x up and x down."""
ATTITUDE_TOL_DEG = 1.0
"""A realistic fixture is off its nominal attitude by up to this, per angle (the scenario's default tolerance)."""
GYRO_WHITE, ACCEL_WHITE = 2e-4, 1e-3
"""White noise of every case, rad/s/sqrt(s) and m/s/sqrt(s) (the own suite's)."""
TUMBLE_POSES = [(0, 0, 0), (180, 0, 40), (0, -89, 80), (0, 89, 130), (90, 0, 200), (-90, 0, 270), (0, 0, 90),
                (45, 30, 300), (-30, 60, 10), (120, -45, 160), (0, 0, 225), (180, 0, 315)]
TABLE_RATES = [10, -10, 20, -20, 30, -30, 40, -40, 60, -60]
MIS_XZ = 7e-4
"""Gyro x senses this fraction (rad) of the z rate (the rate-table misalignment case)."""
TEMP_COEF = np.array([1.0e-6, -0.8e-6, 1.2e-6])
GRADE_KINDS = ("table", "drive", "mtable", "ltable")
"""The realistic table and drive cases cycle over GRADES by seed (noise, turn-on biases and the table's scale factor
and misalignment are the industrial ones times the grade's factor); their model states the noise to +-10 % and no
grade, so the diagnosis infers it (navigation: ARW 0.007 deg/sqrt(h), flicker B 0.04 deg/h)."""
COLORED_SIGMA_REALISTIC = [1.0, 1.0, 2.0]
"""The realistic coloured GNSS error (m, E N U; tau 30 s): a stand-alone receiver's multipath and residual
atmospheric error (1-5 m at correlation times of tens of seconds to minutes, Groves 9.3-9.4). The plain cases' 0.3,
0.3, 0.5 m is what a truth smoothed from a GNSS track carries itself (up to 0.3 m horizontal, 0.6 m vertical), so on
a realistic drive it is not separable from the reference by design."""
TABLE_TOLERANCE_DEG = 0.01
"""The realistic rate table's fixture is machined and aligned to this (deg, stated as the scenario's
attitude_tolerance_deg); the unit sits on it tilted by up to that in roll and pitch. A misalignment no larger than
such a tilt is not separable from the mounting on a one-axis table (navigation and tactical grades)."""
MTABLE_TOLERANCE_DEG = 1.0
"""The unit remounted by hand on the table for each spin axis sits within this of its nominal mounting (deg, stated
as attitude_tolerance_deg); each mounting's tilt is drawn up to it per body axis."""
MTABLE_MOUNTS = [(0.0, 0.0), (0.0, -90.0), (90.0, 0.0)]
"""(roll, pitch) deg of the mounted table's mountings: body z, x, then y up (the spin axis)."""
MTABLE_RATES = [10, -10, 30, -30, 60, -60]
"""Dwell rates (deg/s) of each mounting's run."""
MTABLE_SCALE = [4e-3, -3e-3, 5e-3]
"""Industrial-grade gyro scale factors of the mounted-table case (x, y, z; times the grade's factor)."""
MTABLE_MIS = np.array([[0.0, 1.2e-3, -0.8e-3], [0.9e-3, 0.0, 1.1e-3], [-1.0e-3, 0.7e-3, 0.0]])
"""Industrial-grade gyro misalignment (row senses column's rate) of the mounted-table case (times the grade's)."""
SLOW_LEGS = [(kind, dur, val * SLOW_SPEED if kind == "speed" else val) for kind, dur, val in gen.STOP_AND_GO]
"""--drive slow: the town drive's legs at SLOW_SPEED of their speeds (a slow vehicle: up to 9 m/s, mean 5.9 m/s,
1.4 km in 240 s)."""
SHORT_LEGS = [("stand", 5, 0), ("speed", 10, 3.1), ("cruise", 45, 0), ("turn", 20, 90), ("cruise", 45, 0),
              ("turn", 20, -90), ("cruise", 45, 0), ("turn", 20, 90), ("cruise", 45, 0), ("turn", 20, -90),
              ("cruise", 30, 0), ("speed", 5, 0)]
"""--drive short: a 6-knot (3.1 m/s) boat or slow vehicle, four 90-deg turns, ~900 m in 300 s (~300 fixes), the
blind's short consumer drive."""
CRUISE_LEGS = [("stand", 5, 0), ("speed", 10, 13.3), ("cruise", 30, 0), ("turn", 15, 90), ("cruise", 25, 0),
               ("turn", 20, -120), ("cruise", 30, 0), ("turn", 10, 60), ("cruise", 35, 0), ("turn", 15, -90),
               ("cruise", 30, 0), ("speed", 10, 0), ("stand", 5, 0)]
"""--drive cruise: 240 s at a steady 13.3 m/s between one start and one stop, four turns: the antenna's forward
offset rotates with the heading as the velocity does, so a lever arm's x and a latency differ only in the start,
the stop and the arm's lateral and vertical parts (blind seed 9's tactical lever arm, taken for a 57-ms latency)."""
GNSS_WHITE_M = [0.5, 0.5, 1.0]
"""White fix noise of the drives (m, E N U), stated in the scenario and in the fixes' std columns."""
SHORT_WHITE_M = [1.5, 1.5, 3.0]
"""--drive short: a consumer receiver's white fix noise (m, E N U): the blind's short drive had its coloured term at a
Whittle LR of 183, which 1.3/1.3/1.9 m over 0.5/0.5/1.0 m white reaches 600-1100 times."""
SHORT_COLORED = ([1.3, 1.3, 1.9], 150.0)
"""--drive short --realistic: the coloured GNSS error (m E N U, tau s) of the blind's short drive: tau half the
record."""
TABLE_PHYSICS = False
"""``--table-physics``: a realistic table unit carries a warm-up, a logged temperature with a bias coefficient and a
g-sensitivity at its grade (``_table_physics``), and a mounted table's dwells are off their stated rates by up to
TABLE_RATE_ERR (blind consumer table scale factor: intervals 2-3 times too narrow, with those physics found behind
it)."""
TABLE_RATE_ERR = 5e-5
"""Largest relative error of a dwell's true rate against its stated one on a consumer unit's table
(``--table-physics``; a servo table's rate accuracy is 1e-5 to 1e-4), in proportion to the grade's factor for the
others (a navigation unit's table: 1e-7): the scenario states no rate accuracy, so a table worse than the unit's
scale-factor interval (5e-5 against a navigation unit's +-4e-7) is a reference error no diagnosis could know."""
TABLE_RATE_ERR_ALL = 0.0
"""``--table-rate-err E``: every grade's table dwells off their stated rates by up to E (relative), not in proportion
to the grade (a tactical unit on a 5e-5 table: blind seed 8's tactical scale factors 1.5-2.3e-5 off, 1 of 3 covered)."""
TABLE_PHYS_RATES = [30, -30, 100, -100, 200, -200]
"""Dwell rates (deg/s) of each mounting's run with ``--table-physics``: a consumer unit's calibration spins to a
good part of its range, so its scale factors are determined to ~1e-4 and the slow physics' residue matters."""
TABLE_SHORT = False
"""``--table-short`` (with ``--table-physics``): the blind seed-8 tables - the unit sampled at TABLE_SHORT_HZ, dwells of
TABLE_SHORT_DWELL_S at TABLE_SHORT_RATES (up to ~110 deg/s)."""
TABLE_SHORT_HZ, TABLE_SHORT_DWELL_S, TABLE_SHORT_RATES = 100.0, (3.0, 8.0), [30, -30, 60, -60, 110, -110]
TABLE_OFFAXIS_M = 0.0
"""``--table-offaxis M``: the unit's sensing centre sits up to this far (m, per body axis) from the table's axis,
drawn per mounting (a hand-mounted unit on a table top), so its accelerometers sense the centripetal and tangential
acceleration w x (w x r) + dw/dt x r, which the scenario does not state."""
TABLE_WARMUP = ([4e-4, -3e-4, 5e-4], [2e-3, -2e-3, 3e-3])
"""Industrial-grade warm-up amplitudes of a table unit (gyro rad/s, accel m/s^2; the tumble case's)."""
TABLE_TYPED_S = 0.5
"""The realistic rate table's segments are typed to this (s): t0, t1 from the controller's schedule or a coarse log
rounded to it, so a stated dwell may begin up to half of it inside the ramp before it (or end inside the next)."""
TABLE_DWELL_S = (4.0, 8.0)
"""A realistic rate table dwells at each rate for a time drawn from this range (s)."""
TABLE_ACCEL_DPS2 = (20.0, 150.0)
LTABLE_DWELL_S, LTABLE_TOLERANCE_DEG = (20.0, 40.0), 0.5
"""The long rate table (``*_ltable``, the blind's table records of tens of minutes): TABLE_RATES twice, each dwell
drawn from this range (s; about 11 min in all), the unit on the table within this of level (deg, stated)."""
LTABLE_WALK = (1e-6, 1e-5)
"""Industrial-grade bias random walk of the long table's unit (gyro rad/s/sqrt(s), accel m/s^2/sqrt(s); times the
grade's factor), stated in the user's model to +-NOISE_MISSTATED: over 11 min it wanders as far as the flicker
bias instability, which a warm-up or temperature curve can follow."""
LTABLE_TEMP = (25.0, 8.0, 900.0)
"""The long table's logged temperature: start degC, rise degC, time constant s (the unit and the room warming up;
the sensor has no temperature coefficient: the record's temperature is collinear with its slow bias wander)."""
"""Each realistic ramp between two rates has its own angular acceleration (deg/s^2, drawn from this range) and its
own shape (linear, cubic or quintic); the scenario states only the dwells."""
UPDOWN_ROLL = [(45, 0, 0), (-135, 0, 0)]
"""An up/down turned about body x (east at yaw 0, DESIGN.md's ENU convention): the y-z diagonal up, then down. The
Earth rate's parts that flip with the turn, its vertical and north ones, both lie in the y-z plane, which a gyro
g-sensitivity on y and z (two coefficients) reproduces wholly."""
UPDOWN_NORTH = [(45, 0, 90), (-135, 0, 90)]
"""The same up/down turned about north (body x north): only the Earth rate's vertical part flips, along gravity, so
a g-sensitivity k = Omega sin(lat) / g, equal on y and z, mimics it exactly (blind seed 9's navigation up/down:
y and z coefficients equal, -1.77e-6 rad/s per m/s^2, named before the Earth rate)."""
UPDOWN_HEADING_OFF_DEG = (10.0, 30.0)
"""An up/down's stated heading off its true one by this much (deg, either way; ``*_updown_heading``): an up/down
needs only its up axis, and its heading is rarely measured."""
UPDOWN_HEADING = {"poses": UPDOWN_NORTH, "heading_off_deg": UPDOWN_HEADING_OFF_DEG, "latitude_deg": 14.0}
"""Blind seed 9's navigation up/down (Earth rate LR 2.7e4, a g-sensitivity's 6.8e4, at latitude ~14 deg): there the
Earth rate's vertical part (1.8e-5 rad/s) is a quarter of its horizontal one, so a stated heading 10-30 deg off puts
a horizontal flip of 1.2-3.5e-5 rad/s into the Earth rate's regressor that the record does not hold, while a
g-sensitivity on y and z fits the vertical flip exactly (measured on 5800ee1's diagnosis, 7000-7007: the
g-sensitivity first 8/8, y and z 1.6-2.0e-6 for Omega sin(14 deg) / g = 1.80e-6; the Earth rate's scale 0.35)."""
UPDOWN_TACTICAL = {"grade": "tactical", "noise": (0.1, 3.0)}
"""The tactical up/down's unit (``*_updown_tactical``): white noise 2e-5 rad/s/sqrt(s), flicker B 6e-5 rad/s."""
CASES = {
    # name: (motion, effect, concealed parameters)
    "earth_rotation": ("tumble", "earth_rotation", {}),
    "gravity_model": ("tumble", "gravity_model", {}),
    "gyro_g_sensitivity": ("tumble", "gyro_g_sensitivity", {"g": [3e-5, -2e-5, 2.5e-5]}),
    "warmup_drift": ("tumble", "warmup_drift", {"gyro": [4e-4, -3e-4, 5e-4], "accel": [2e-3, -2e-3, 3e-3],
                                                 "tau": 60.0}),
    "vibration": ("tumble", "vibration", {"f": 17.3, "gyro_x": 5e-4, "accel_z": 3e-3}),
    "quantization": ("tumble", "quantization", {"gyro_lsb": 1e-5, "accel_lsb": 5e-5}),
    "scale_factor_table": ("table", "scale_factor", {"gyro_z": 7e-4}),
    "misalignment_table": ("table", "axis_misalignment", {"xz": MIS_XZ}),  # sizes per grade: effect_params
    "scale_factor_ltable": ("ltable", "scale_factor", {"gyro_z": 7e-4}),  # 11 min, bias walk, temperature logged
    "scale_factor_mtable": ("mtable", "scale_factor", {}),  # the unit in three mountings, MTABLE_*
    "misalignment_mtable": ("mtable", "axis_misalignment", {}),
    "temperature_bias": ("static", "temperature_bias", {}),
    "gauss_markov_bias": ("static", "gauss_markov_bias", {"gyro": 3.7e-5, "accel": 1.9e-4, "tau": 10.0}),
    "bias_random_walk": ("static", "bias_random_walk", {"gyro": 6e-7, "accel": 3e-6}),
    "earth_rotation_updown": ("updown", "earth_rotation", {}),  # one record, the turn recorded
    "gps_latency": ("drive", "gps_latency", {"latency": 0.03}),
    "gps_lever_arm": ("drive", "gps_lever_arm", {"arm": [0.35, -0.25, 0.4]}),
    "gps_lever_arm_z": ("drive", "gps_lever_arm", {"arm": [0.0, 0.0, 1.68]}),  # a roof antenna over the IMU
    # blind seed 9's tactical drive: an antenna behind and above the IMU (its x on the velocity, as a latency of
    # 57 ms at 13 m/s is), and the latency of that size alone
    "gps_lever_arm_tactical": ("drive", "gps_lever_arm", {"arm": [-0.76, 0.12, 0.92], "grade": "tactical"}),
    "gps_latency_tactical": ("drive", "gps_latency", {"latency": 0.057, "grade": "tactical"}),
    "colored_gps_noise": ("drive", "colored_gps_noise", {"sigma": [0.3, 0.3, 0.5], "tau": 30.0}),
    "coriolis": ("drive", "coriolis", {}),  # the user's model leaves out 2 Omega x v (and the transport rate)
    "coriolis_tactical": ("drive", "coriolis", {"grade": "tactical"}),  # blind seeds 5-9's class
    # a six-position test on an imperfect fixture, moved by hand (FIXTURE_* below); parameters at industrial grade,
    # scaled by the drawn grade's noise (GRADES)
    "fx_earth_rotation": ("fixture", "earth_rotation", {}),
    "fx_gravity_model": ("fixture", "gravity_model", {}),
    "fx_gyro_g_sensitivity": ("fixture", "gyro_g_sensitivity", {"g": [3e-5, -2e-5, 2.5e-5]}),
    "fx_warmup_drift": ("fixture", "warmup_drift", {"gyro": [4e-4, -3e-4, 5e-4], "accel": [2e-3, -2e-3, 3e-3],
                                                    "tau": 60.0}),
    "fx_vibration": ("fixture", "vibration", {"f": 17.3, "gyro_x": 5e-4, "accel_z": 3e-3}),
    "fx_quantization": ("fixture", "quantization", {"gyro_lsb": 1e-5, "accel_lsb": 5e-5}),
    "fx_temperature_bias": ("fixture", "temperature_bias", {}),
    "fx_gauss_markov_bias": ("fixture", "gauss_markov_bias", {"gyro": 3.7e-5, "accel": 1.9e-4, "tau": 10.0}),
    "fx_bias_random_walk": ("fixture", "bias_random_walk", {"gyro": 3e-6, "accel": 1.5e-5}),
    # the blind's industrial fixture Gauss-Markov bias (2.8e-4 rad/s at tau 40 s: the correlation time near the
    # holds, its wander across holds bounded where a walk's keeps growing); accel in the suite case's ratio
    "fx_gauss_markov_slow": ("fixture", "gauss_markov_bias", {"gyro": 2.8e-4, "accel": 1.4e-3, "tau": 40.0}),
    "fx_earth_rotation_updown": ("updown_fixture", "earth_rotation", {}),
    # blind seed 8's tactical up/down (Earth rate at GLS LR 6.2 against 8.7): a tactical unit whose gyro bias
    # instability (6e-5 rad/s, 12 deg/h: noise factors (white, flicker) against the industrial unit's) makes the
    # Earth rate's step between x up and x down (1.1e-4 rad/s on x, 0.9e-4 on z at Calgary) two of the flicker's
    # hold-to-hold steps (sd 0.96 B over 300-s holds)
    "fx_earth_rotation_updown_tactical": ("updown_fixture", "earth_rotation", UPDOWN_TACTICAL),
    "fx_earth_rotation_updown_roll": ("updown_fixture", "earth_rotation", {"poses": UPDOWN_ROLL}),
    "fx_earth_rotation_updown_roll_tactical": ("updown_fixture", "earth_rotation",
                                               {"poses": UPDOWN_ROLL, "grade": "tactical"}),
    "fx_earth_rotation_updown_heading": ("updown_fixture", "earth_rotation", UPDOWN_HEADING),
    "fx_earth_rotation_updown_heading_tactical": ("updown_fixture", "earth_rotation",
                                                  {**UPDOWN_HEADING, "grade": "tactical"}),
    # a real g-sensitivity on that up/down, the Earth rate in the user's model (it must stay named there)
    "fx_gyro_g_sensitivity_updown_roll": ("updown_fixture", "gyro_g_sensitivity",
                                          {"g": [3e-5, -2e-5, 2.5e-5], "poses": UPDOWN_ROLL}),
    # blind seed 7's navigation warm-up (tau ~160 s, mostly on the accelerometers) on a fixture whose logged
    # temperature follows its own exponential (time constant drawn in temp_tau_s): the two curves correlate at
    # r ~ -0.96..-0.99 over the record; sizes absolute (not scaled by the grade), the grade fixed
    "fx_warmup_temp": ("fixture", "warmup_drift", {"gyro": [6e-7, -4e-7, 3e-7], "accel": [2.7e-3, -0.8e-3, 0.8e-3],
                                                   "tau": 160.0, "absolute": True, "grade": "navigation",
                                                   "temp_tau_s": (200.0, 350.0)}),
}
NULL_PARAMS = {"null_updown_fixture_tactical": UPDOWN_TACTICAL, "null_updown_fixture_roll": {"poses": UPDOWN_ROLL},
               "null_updown_fixture_roll_tactical": {"poses": UPDOWN_ROLL, "grade": "tactical"},
               "null_updown_fixture_heading": UPDOWN_HEADING}
"""A null's unit where it is not its kind's default (grade and noise factors; no concealed effect)."""
NULLS = {"null_drive": "drive", "null_table": "table", "null_mtable": "mtable", "null_ltable": "ltable", "null_single_naive": "static_rw",
         "null_tumble": "tumble",
         "null_fixture": "fixture", "null_updown_fixture": "updown_fixture",
         "null_updown_fixture_tactical": "updown_fixture", "null_updown_fixture_roll": "updown_fixture",
         "null_updown_fixture_roll_tactical": "updown_fixture", "null_updown_fixture_heading": "updown_fixture"}
GRADES = {"navigation": 0.01, "tactical": 0.1, "industrial": 1.0, "consumer": 5.0}
FIXTURE_NOISE = {"consumer": (1.5, 7.5)}
"""(white, flicker) factors of a fixture case's noise where they differ from GRADES': a consumer MEMS gyro's angle
random walk is ~1 deg/sqrt(h) (3e-4 rad/sqrt(s)) but its bias instability 10-50 deg/h (1.5e-4 rad/s here, twice
the Earth rate), so on still holds its bias wander, not the white noise, hides the Earth rate."""
"""Sensor grades of the fixture cases: noise (white, flicker, turn-on bias) and sensor-effect sizes are the
industrial ones times this; the model states the grade (provenance.grade)."""
FIXTURE_POSES = [(0, 0, 0), (180, 0, 0), (0, -90, 0), (0, 90, 0), (90, 0, 0), (-90, 0, 0)]
FIXTURE_HOLD_S, FIXTURE_MOVE_S, FIXTURE_WOBBLE_DEG = (40.0, 90.0), (4.0, 12.0), 10.0
"""A six-position test by hand: each hold 40-90 s, each move 4-12 s with its own uneven profile and a wobble of up
to 10 deg per Euler angle; the scenario states only the holds (static_segments, nominal attitudes)."""
TRUE = {
    "earth_rotation": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "earth_rotation_updown": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "gyro_g_sensitivity": {f"gyro_coeff_rad_per_s_per_mps2[{a}]": v for a, v in zip("xyz", [3e-5, -2e-5, 2.5e-5])},
    "warmup_drift": {"time_constant_s": 60.0, **{f"gyro_amplitude_rad_per_s[{a}]": v
                                                 for a, v in zip("xyz", [4e-4, -3e-4, 5e-4])}},
    "vibration": {"frequency_hz": 17.3},
    "gravity_model": {"gravity_mps2": float(gen.normal_gravity(np.radians(SITE[0]), SITE[2]))},
    "quantization": {f"gyro_lsb_rad[{a}]": 1e-5 for a in "xyz"},
    "scale_factor_table": {"gyro[z]": 7e-4},
    "scale_factor_ltable": {"gyro[z]": 7e-4},
    "misalignment_table": {"gyro[xz]": MIS_XZ},
    "scale_factor_mtable": {f"gyro[{a}]": v for a, v in zip("xyz", MTABLE_SCALE)},
    "misalignment_mtable": {f"gyro[{'xyz'[i]}{'xyz'[j]}]": MTABLE_MIS[i, j] for i in range(3) for j in range(3)
                            if i != j},
    "temperature_bias": {f"gyro_coeff_rad_per_s_per_degc[{a}]": v for a, v in zip("xyz", TEMP_COEF)},
    "gauss_markov_bias": {f"gyro_sigma_rad_per_s[{a}]": 3.7e-5 for a in "xyz"},
    "bias_random_walk": {f"gyro_rad_per_s_per_sqrt_s[{a}]": 6e-7 for a in "xyz"},
    "gps_latency": {"latency_s": 0.03},
    "gps_lever_arm": {"lever_arm_m[x]": 0.35, "lever_arm_m[y]": -0.25},
    "gps_lever_arm_z": {"lever_arm_m[z]": 1.68},
    "gps_lever_arm_tactical": {"lever_arm_m[x]": -0.76, "lever_arm_m[y]": 0.12},
    "gps_latency_tactical": {"latency_s": 0.057},
    "colored_gps_noise": {"sigma_m[e]": 0.3, "sigma_m[n]": 0.3, "sigma_m[u]": 0.5},
    "coriolis": {"coriolis_scale": 1.0},
    "coriolis_tactical": {"coriolis_scale": 1.0},
    "fx_earth_rotation_updown": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_earth_rotation_updown_tactical": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_earth_rotation_updown_roll": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_earth_rotation_updown_roll_tactical": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_earth_rotation_updown_heading_tactical": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_earth_rotation_updown_heading": {"earth_rate_rad_per_s": gen.OMEGA_E},
    "fx_gyro_g_sensitivity_updown_roll": {f"gyro_coeff_rad_per_s_per_mps2[{a}]": v
                                          for a, v in zip("yz", [-2e-5, 2.5e-5])},
    "fx_bias_random_walk": {f"gyro_rad_per_s_per_sqrt_s[{a}]": 3e-6 for a in "xyz"},
    "fx_gauss_markov_slow": {f"gyro_sigma_rad_per_s[{a}]": 2.8e-4 for a in "xyz"},
    "fx_warmup_temp": {"time_constant_s": 160.0,
                       **{f"gyro_amplitude_rad_per_s[{a}]": v for a, v in zip("xyz", [6e-7, -4e-7, 3e-7])},
                       **{f"accel_amplitude_mps2[{a}]": v for a, v in zip("xyz", [2.7e-3, -0.8e-3, 0.8e-3])}},
}
for _name in ("earth_rotation", "gravity_model", "gyro_g_sensitivity", "warmup_drift", "vibration", "quantization",
              "temperature_bias", "gauss_markov_bias"):
    TRUE["fx_" + _name] = TRUE[_name]
SCALE_FREE = ("earth_rate_rad_per_s", "gravity_mps2", "frequency_hz", "time_constant_s")
"""Parameters a fixture case's grade does not scale."""


def gnss_white_m() -> list:
    """The drive's white fix noise (m, E N U)."""
    return SHORT_WHITE_M if DRIVE == "short" else GNSS_WHITE_M


def grade_of(kind: str, seed: int) -> str:
    """The sensor grade of a case: cycled over GRADES by seed for the realistic table and drive cases, else the
    plain cases' industrial sensor."""
    return list(GRADES)[seed % len(GRADES)] if REALISTIC and kind in GRADE_KINDS else "industrial"


def effect_params(name: str, grade: str) -> dict:
    """A case's concealed parameters; the table's scale factor and misalignment scaled with the grade's noise."""
    par = dict(CASES[name][2])
    if name == "colored_gps_noise" and REALISTIC:
        par["sigma"] = SHORT_COLORED[0] if DRIVE == "short" else COLORED_SIGMA_REALISTIC
        par["tau"] = SHORT_COLORED[1] if DRIVE == "short" else par["tau"]
    for key in ("gyro_z", "xz"):
        if key in par and CASES[name][0] in ("table", "ltable"):
            par[key] *= GRADES[grade]
    return par


def true_values(name: str, grade: str) -> dict:
    """The true parameters the case's first finding's intervals should cover."""
    if name in ("scale_factor_table", "misalignment_table", "scale_factor_mtable", "misalignment_mtable",
                "scale_factor_ltable"):
        return {k: v * GRADES[grade] for k, v in TRUE[name].items()}
    if CASES.get(name, ("",))[0] in ("fixture", "updown_fixture"):  # sensor effects scale with the grade's noise
        k = GRADES[grade] * (TEMP_REALISTIC if name == "fx_temperature_bias" else 1.0)
        k = 1.0 if CASES[name][2].get("absolute") else k
        out = {p: v * (1.0 if p in SCALE_FREE else k) for p, v in TRUE.get(name, {}).items()}
        if name == "fx_temperature_bias":  # the accelerometers' coefficients too (the blind scored six intervals)
            out.update({f"accel_coeff_mps2_per_degc[{a}]": np.sqrt(GRADES[grade]) * v
                        for a, v in zip("xyz", FIXTURE_TEMP_ACCEL)})
        return out
    if name == "colored_gps_noise" and REALISTIC:
        sigma, tau = SHORT_COLORED if DRIVE == "short" else (COLORED_SIGMA_REALISTIC, CASES[name][2]["tau"])
        return {**{f"sigma_m[{a}]": v for a, v in zip("enu", sigma)}, "correlation_time_s": tau}
    return TRUE.get(name, {})


def dwell_table(real, dwell_s=TABLE_DWELL_S, tolerance_deg=TABLE_TOLERANCE_DEG, rest_s=20.0):
    """A realistic rate table: TABLE_RATES twice, each dwell drawn from ``dwell_s`` (s), each ramp its own
    acceleration and shape, the unit tilted within ``tolerance_deg`` in roll and pitch, rests of ``rest_s``."""
    rates = TABLE_RATES + TABLE_RATES[::-1]
    dwell = real.uniform(*dwell_s, len(rates))
    steps = np.abs(np.diff(np.r_[0.0, rates, 0.0]))
    ramp = np.maximum(steps / real.uniform(*TABLE_ACCEL_DPS2, len(steps)), 0.3)
    shapes = real.choice(["linear", "smooth", "quintic"], len(steps))
    mount = real.uniform(-tolerance_deg, tolerance_deg, 2)
    return gen.DwellTable(rates, dwell, ramp, shapes, rest_s=rest_s, mount_deg=mount)


def long_table(real):
    """The long rate table: dwells of LTABLE_DWELL_S, the unit tilted within LTABLE_TOLERANCE_DEG, 60-s rests."""
    return dwell_table(real, LTABLE_DWELL_S, LTABLE_TOLERANCE_DEG, 60.0)


def mounted_table(real, phys=None, rate_err: float = 0.0):
    """The unit remounted by hand for each spin axis (MTABLE_MOUNTS), each mounting tilted by up to
    MTABLE_TOLERANCE_DEG per body axis; each run dwells at MTABLE_RATES with its own ramps, 10-s rests. With
    ``phys`` (``--table-physics``) each dwell's true rate is off its stated one by up to ``rate_err`` (relative)."""
    runs = []
    rates = MTABLE_RATES if phys is None else TABLE_SHORT_RATES if TABLE_SHORT else TABLE_PHYS_RATES
    for _ in MTABLE_MOUNTS:
        dwell = real.uniform(*(TABLE_SHORT_DWELL_S if TABLE_SHORT and phys is not None else TABLE_DWELL_S),
                             len(rates))
        steps = np.abs(np.diff(np.r_[0.0, rates, 0.0]))
        ramp = np.maximum(steps / real.uniform(*TABLE_ACCEL_DPS2, len(steps)), 0.3)
        shapes = real.choice(["linear", "smooth", "quintic"], len(steps))
        err = 1.0 + (phys.uniform(-rate_err, rate_err, len(rates)) if phys is not None else 0.0)
        runs.append(gen.DwellTable(np.asarray(rates, float) * err, dwell, ramp, shapes, rest_s=10.0))
        runs[-1].stated_dps = list(rates)
    tilts = np.radians(real.uniform(-MTABLE_TOLERANCE_DEG, MTABLE_TOLERANCE_DEG, (len(MTABLE_MOUNTS), 3)))
    return gen.MountedTable(runs, MTABLE_MOUNTS, tilts, move_s=5.0)


def _mtable_holds(table) -> list:
    """The mounted table as a user types it: per mounting its rests and dwells at the nominal mounting, spinning
    about the body axis that is up, yaw the table's encoder angle at each start (0.1 deg); remounts and ramps
    unstated."""
    segs = []
    for k, (run, (r, p)) in enumerate(zip(table.tables, table.mounts_deg)):
        axis = gen.body_to_enu(np.radians(r), np.radians(p), 0.0)[2]
        axis = [round(float(v), 9) + 0.0 for v in axis]
        for seg in _table_holds(run):
            t0 = float(table.starts[k]) + seg["t0"]
            yaw = table.yaw0(k) + run.attitude(np.array([seg["t0"]]))[0][2][0]
            segs.append({"t0": t0, "t1": float(table.starts[k]) + seg["t1"], "roll_deg": r, "pitch_deg": p,
                         "yaw_deg": round(float((np.degrees(yaw) + 180.0) % 360.0 - 180.0), 1),
                         "rate_dps": seg["rate_dps"], "axis_body": axis})
    return segs


def motion_of(kind: str):
    """(motion, IMU rate Hz, truth rate Hz or None for static segments)."""
    if kind == "tumble":
        return gen.Poses(TUMBLE_POSES, 30.0, 6.0), 50.0, 100.0
    if kind == "table":
        return gen.RateTable(TABLE_RATES, 30.0, 2.0), 50.0, 100.0
    if kind == "ltable":
        return None, 50.0, 100.0
    if kind == "mtable":
        return None, TABLE_SHORT_HZ if TABLE_SHORT and TABLE_PHYSICS and REALISTIC else 50.0, None
    if kind == "drive":
        if DRIVE == "slow":
            return gen.StopAndGo(240.0, legs=SLOW_LEGS), 50.0, 100.0
        if DRIVE == "short":
            return gen.StopAndGo(300.0, legs=SHORT_LEGS), 50.0, 100.0
        if DRIVE == "cruise":
            return gen.StopAndGo(240.0, legs=CRUISE_LEGS), 50.0, 100.0
        return (gen.StopAndGo(240.0) if DRIVE == "town" else gen.FigureEight(1200.0)), 50.0, 100.0
    if kind == "updown":
        return None, 64.0, None
    return gen.Poses([(0, 0, 0)], 7200.0, 1.0), 5.0, None


def generate(name: str, seed: int, folder: Path) -> dict:
    """Write one case's files; returns their paths."""
    null = name in NULLS
    kind = NULLS[name] if null else CASES[name][0]
    grade = (None if null else CASES[name][2].get("grade")) or grade_of(kind, seed)
    kg = GRADES[grade]
    effect, par = (None, dict(NULL_PARAMS.get(name, {}))) if null else (CASES[name][1], effect_params(name, grade))
    rng = np.random.default_rng(seed)
    site = gen.Site(par.get("latitude_deg", SITE[0]), *SITE[1:])
    motion, rate, truth_rate = motion_of(kind)
    real = np.random.default_rng([seed, 24]) if REALISTIC else None
    if real is not None and kind == "tumble":
        motion = gen.Poses(TUMBLE_POSES, real.uniform(*HOLDS_REALISTIC_S, len(TUMBLE_POSES)), motion.move_s)
    if real is not None and kind == "table":
        motion = dwell_table(real)
    phys = np.random.default_rng([seed, 27]) if TABLE_PHYSICS and real is not None and kind in GRADE_KINDS else None
    if kind == "mtable":
        motion = mounted_table(real if real is not None else np.random.default_rng([seed, 24]), phys,
                               TABLE_RATE_ERR_ALL or TABLE_RATE_ERR * kg / GRADES["consumer"])
    if kind == "ltable":
        motion = long_table(real if real is not None else np.random.default_rng([seed, 24]))
    if kind == "updown":
        return _updown(site, rng, folder, effect, real)
    if kind in ("fixture", "updown_fixture"):
        return _fixture(site, rng, np.random.default_rng([seed, 25]), folder, kind, effect, par, seed)
    dt = 1.0 / rate
    off = real is not None and kind not in ("drive", "table", "mtable", "ltable")
    true_motion = _off_nominal(motion, real) if off else motion
    t, gyro, accel = site.true_imu(true_motion, rate)
    n = len(t)
    gyro_out, accel_out = gyro.copy(), accel.copy()
    temp = None
    if kind in ("static", "static_rw"):
        temp = 25.0 - 10.0 * np.cos(2 * np.pi * t / 1800.0)
    if phys is not None and kind in ("table", "mtable"):
        temp = _table_physics(phys, t, accel, gyro_out, accel_out, kg * (not null))
    if TABLE_OFFAXIS_M and kind == "mtable":
        _off_axis(np.random.default_rng([seed, 28]), motion, t, gyro, accel_out)
    if kind == "ltable":  # a unit warming with the room, with no temperature coefficient; and its bias walk
        temp = LTABLE_TEMP[0] + LTABLE_TEMP[1] * (1.0 - np.exp(-t / LTABLE_TEMP[2])) + rng.normal(0, 0.01, n)
        gyro_out += np.cumsum(rng.normal(0, kg * LTABLE_WALK[0] * np.sqrt(dt), (n, 3)), axis=0)
        accel_out += np.cumsum(rng.normal(0, kg * LTABLE_WALK[1] * np.sqrt(dt), (n, 3)), axis=0)
    if effect == "gyro_g_sensitivity":
        gyro_out += np.asarray(par["g"]) * accel
    elif effect == "warmup_drift":
        decay = np.exp(-(t - dt / 2) / par["tau"])[:, None]
        gyro_out += decay * par["gyro"]
        accel_out += decay * par["accel"]
    elif effect == "vibration":
        s = gen.interval_mean_sin(t, dt, par["f"], 0.7)
        gyro_out[:, 0] += par["gyro_x"] * s
        accel_out[:, 2] += par["accel_z"] * s
    elif effect == "scale_factor" and kind == "mtable":
        gyro_out += gyro * np.asarray(MTABLE_SCALE) * kg
    elif effect == "axis_misalignment" and kind == "mtable":
        gyro_out += gyro @ (MTABLE_MIS * kg).T
    elif effect == "scale_factor":
        gyro_out[:, 2] += par["gyro_z"] * gyro[:, 2]
    elif effect == "axis_misalignment":
        gyro_out[:, 0] += par["xz"] * gyro[:, 2]
    elif effect == "temperature_bias":
        k = TEMP_REALISTIC if real is not None else 1.0
        gyro_out += (temp - 25.0)[:, None] * TEMP_COEF * k
        accel_out += (temp - 25.0)[:, None] * 5e-6 * k
    elif effect == "gauss_markov_bias":
        gyro_out += gen.gauss_markov(rng, n, dt, [par["gyro"]] * 3, par["tau"])
        accel_out += gen.gauss_markov(rng, n, dt, [par["accel"]] * 3, par["tau"])
    elif effect == "bias_random_walk":
        k = RW_REALISTIC if real is not None else 1.0
        gyro_out += np.cumsum(rng.normal(0, k * par["gyro"] * np.sqrt(dt), (n, 3)), axis=0)
        accel_out += np.cumsum(rng.normal(0, k * par["accel"] * np.sqrt(dt), (n, 3)), axis=0)
    if kind == "static_rw":  # the naive-model null: the sensor has a rate random walk the user's model must learn
        gyro_out += np.cumsum(rng.normal(0, 6e-7 * np.sqrt(dt), (n, 3)), axis=0)
        accel_out += np.cumsum(rng.normal(0, 3e-6 * np.sqrt(dt), (n, 3)), axis=0)
    kw, kf = FIXTURE_NOISE.get(grade, (kg, kg)) if phys is not None else (kg, kg)  # a real consumer unit's noise
    gyro_out += rng.normal(0, kw * GYRO_WHITE / np.sqrt(dt), (n, 3))
    accel_out += rng.normal(0, kw * ACCEL_WHITE / np.sqrt(dt), (n, 3))
    if real is not None:
        gyro_out += gen.flicker(real, n, dt, [kf * GYRO_FLICKER] * 3)
        accel_out += gen.flicker(real, n, dt, [kf * ACCEL_FLICKER] * 3)
    # turn-on biases: present in every real sensor, unknown to the user (a nuisance for the diagnosis)
    gyro_out += rng.normal(0, kg * 1e-3, 3)
    accel_out += rng.normal(0, max(kg, 0.05) * 2e-2, 3)
    if effect == "quantization":
        gyro_out = gen.quantize_increments(gyro_out, dt, par["gyro_lsb"])
        accel_out = gen.quantize_increments(accel_out, dt, par["accel_lsb"])
    cols = {"t": t, "gx": gyro_out[:, 0], "gy": gyro_out[:, 1], "gz": gyro_out[:, 2],
            "ax": accel_out[:, 0], "ay": accel_out[:, 1], "az": accel_out[:, 2]}
    if temp is not None:
        cols["temp_c"] = temp
    paths = {"recording": gen.write_csv(folder / "imu.csv", cols)}
    scenario = {"rate_hz": rate}
    if kind == "mtable":
        scenario.update(latitude_deg=SITE[0], longitude_deg=SITE[1], height_m=SITE[2], gps=False,
                        attitude_tolerance_deg=MTABLE_TOLERANCE_DEG, static_segments=_mtable_holds(motion))
    elif truth_rate is None:
        scenario.update(latitude_deg=SITE[0], longitude_deg=SITE[1], height_m=SITE[2], gps=False,
                        static_segments=[{"t0": 0.0, "t1": float(motion.duration_s), "roll_deg": 0.0,
                                          "pitch_deg": 0.0, "yaw_deg": 0.0}])
    elif kind == "ltable" or (real is not None and kind == "table"):
        scenario.update(latitude_deg=SITE[0], longitude_deg=SITE[1], height_m=SITE[2], gps=False,
                        attitude_tolerance_deg=LTABLE_TOLERANCE_DEG if kind == "ltable" else TABLE_TOLERANCE_DEG,
                        static_segments=_table_holds(motion))
    elif real is not None and kind == "drive":
        gen.write_csv(folder / "truth.csv", _smoothed_gnss_truth(site, motion, real))
        scenario.update(trajectory="truth.csv", gps=False)
    else:
        gen.write_csv(folder / "truth.csv", site.truth_rows(motion, truth_rate))
        scenario.update(trajectory="truth.csv", gps=False)
    if kind == "drive":
        scenario["gps"] = {"rate_hz": 1.0, "sigma_m": list(gnss_white_m())}
        paths["gnss"] = _gnss(site, motion, rng, folder, effect, par)
    paths["scenario"] = folder / "scenario.yaml"
    paths["scenario"].write_text(yaml.safe_dump(scenario, sort_keys=False))
    paths["model"] = _model(folder, rate, effect, kind, real, grade, (kw, kf))
    paths["grade"] = grade
    return paths


def _table_physics(phys, t, accel, gyro_out, accel_out, kg: float) -> np.ndarray:
    """A table unit's own slow physics (``--table-physics``, in place): a warm-up (TABLE_WARMUP at the grade's
    factor, each amplitude drawn 0.3-1 times, tau 60-300 s), a bias temperature coefficient (the fixture's: TEMP_COEF
    x TEMP_REALISTIC and FIXTURE_TEMP_ACCEL, at the grade's) on a logged temperature warming 3-8 degC at 200-900 s,
    and a gyro g-sensitivity (the tumble case's at the grade's factor). Returns the logged temperature (degC). A
    null's unit (``kg`` 0) has none of them: its temperature is logged, its table's rates are still off."""
    tau_w, tau_t = phys.uniform(60.0, 300.0), phys.uniform(200.0, 900.0)
    temp = 24.0 + phys.uniform(3.0, 8.0) * (1.0 - np.exp(-t / tau_t)) + phys.normal(0, 0.01, len(t))
    decay = np.exp(-t / tau_w)[:, None]
    gyro_out += kg * decay * np.asarray(TABLE_WARMUP[0]) * phys.uniform(0.3, 1.0, 3)
    accel_out += kg * decay * np.asarray(TABLE_WARMUP[1]) * phys.uniform(0.3, 1.0, 3)
    gyro_out += kg * TEMP_REALISTIC * (temp - 25.0)[:, None] * TEMP_COEF
    accel_out += np.sqrt(kg) * (temp - 25.0)[:, None] * FIXTURE_TEMP_ACCEL
    gyro_out += kg * np.asarray(CASES["gyro_g_sensitivity"][2]["g"]) * accel
    return temp


def _off_axis(rng, table, t, gyro, accel_out) -> None:
    """The accelerometers of a unit mounted off the table's axis (in place): each mounting's sensing centre at r
    (body m, up to TABLE_OFFAXIS_M per axis) adds dw/dt x r + w x (w x r), with w the true body rate (rad/s)."""
    dw = np.gradient(gyro, t, axis=0)
    ends = np.r_[table.starts[1:], np.inf]
    for k, (t0, t1) in enumerate(zip(table.starts, ends)):
        r = rng.uniform(-TABLE_OFFAXIS_M, TABLE_OFFAXIS_M, 3)
        m = (t > t0 if k else t >= 0) & (t <= t1)
        accel_out[m] += np.cross(dw[m], r) + np.cross(gyro[m], np.cross(gyro[m], r))


def _off_nominal(motion, real):
    """The poses a real fixture holds: each nominal pose off by up to ATTITUDE_TOL_DEG per angle."""
    poses = np.degrees(motion.poses) + real.uniform(-ATTITUDE_TOL_DEG, ATTITUDE_TOL_DEG, motion.poses.shape)
    return gen.Poses(poses, motion.holds, motion.move_s)


def _table_holds(table) -> list:
    """The rate table as a user types it: static_segments of its rest and constant-rate dwells (yaw at each dwell's
    start to 0.1 deg, as the table's encoder gives it); the ramps between them are not stated."""
    spans = table.dwell_spans() if hasattr(table, "dwell_spans") else [
        (table.rest_s + k * table.seg + table.ramp_s, table.rest_s + k * table.seg + table.ramp_s + table.hold_s, r)
        for k, r in enumerate(table.rates[1:])]
    segs = [{"t0": 0.0, "t1": float(table.rest_s), "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0,
             "rate_dps": 0.0}]
    typed = TABLE_TYPED_S if REALISTIC else 0.0
    stated = getattr(table, "stated_dps", None)  # the commanded rates (--table-physics: the true ones are off)
    stated = np.radians(np.r_[stated, 0.0]) if stated is not None else None
    for j, (t0, t1, r) in enumerate(spans):
        r = stated[j] if stated is not None else r
        (_, _, yaw), _ = table.attitude(np.array([t0]))
        if typed:
            t0, t1 = typed * round(t0 / typed), typed * round(t1 / typed)
        segs.append({"t0": float(t0), "t1": float(t1), "roll_deg": 0.0, "pitch_deg": 0.0,
                     "yaw_deg": round(float((np.degrees(yaw[0]) + 180.0) % 360.0 - 180.0), 1),
                     "rate_dps": round(float(np.degrees(r)), 6)})
    return segs


def _smoothed_gnss_truth(site, motion, real) -> dict:
    """A drive's truth at 10 Hz with the slow errors of a track smoothed from noisy GNSS: position 5-30 cm
    horizontal and twice that vertical, roll and pitch 0.005-0.03 deg, yaw 0.02-0.1 deg, periods 30-600 s
    (velocity the position error's derivative)."""
    rows = site.truth_rows(motion, 10.0)
    t = rows["t"]
    pos, vel, _ = gen.slow_wander(real, t, (0.05, 0.30), (30.0, 600.0))
    pos[:, 2], vel[:, 2] = 2.0 * pos[:, 2], 2.0 * vel[:, 2]
    att, _, _ = gen.slow_wander(real, t, (0.005, 0.03), (30.0, 600.0))
    att[:, 2] *= 0.1 / 0.03  # a track's heading is known worse than its level: 0.017-0.1 deg
    enu = site.enu_offset(np.radians(rows["lat_deg"]), np.radians(rows["lon_deg"]), rows["h_m"]) + pos
    lat, lon, h = gen.geodetic_from_ecef(site.r0 + enu @ site.c_e_enu0.T)
    rows.update(lat_deg=np.degrees(lat), lon_deg=np.degrees(lon), h_m=h, ve=rows["ve"] + vel[:, 0],
                vn=rows["vn"] + vel[:, 1], vu=rows["vu"] + vel[:, 2], roll_deg=rows["roll_deg"] + att[:, 0],
                pitch_deg=rows["pitch_deg"] + att[:, 1],
                yaw_deg=(rows["yaw_deg"] + att[:, 2] + 180.0) % 360.0 - 180.0)
    if not TRUTH_VELOCITY:
        for key in ("ve", "vn", "vu"):
            rows.pop(key)
    return rows


def _gnss(site, motion, rng, folder, effect, par):
    """1 Hz fixes: the antenna (lever arm) position at stamp - latency, white (+ coloured) ENU noise."""
    t = np.arange(1.0, motion.duration_s + 1e-9, 1.0)
    arm = par["arm"] if effect == "gps_lever_arm" else None
    lag = par["latency"] if effect == "gps_latency" else 0.0
    rows = site.truth_rows(motion, 1.0, lever_arm_m=arm, t=t - lag)
    enu = site.enu_offset(np.radians(rows["lat_deg"]), np.radians(rows["lon_deg"]), rows["h_m"])
    white = gnss_white_m()
    enu += rng.normal(0, 1, (len(t), 3)) * white
    if effect == "colored_gps_noise":
        enu += gen.gauss_markov(rng, len(t), 1.0, par["sigma"], par["tau"])
    r = site.r0 + enu @ site.c_e_enu0.T
    lat, lon, h = gen.geodetic_from_ecef(r)
    cols = {"t": t, "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon), "h_m": h,
            "std_e": np.full(len(t), white[0]), "std_n": np.full(len(t), white[1]), "std_u": np.full(len(t), white[2])}
    return gen.write_csv(folder / "gnss.csv", cols)


def fixture_grade(kind: str, effect, seed: int) -> str:
    """The grade of a fixture case's seed: cycled over GRADES; a known constant's case at most industrial (on a
    consumer unit the Earth rate is below one hold's noise), the up/down always navigation."""
    if kind == "updown_fixture":
        return "navigation"
    names = list(GRADES)[:3] if effect in ("earth_rotation", "gravity_model") else list(GRADES)
    return names[seed % len(names)]


def _hand_turns(real, poses_deg, holds):
    """A fixture held at ``poses_deg`` off by up to ATTITUDE_TOL_DEG per angle, turned by hand between holds."""
    shape = np.shape(poses_deg)  # each angle off by 70-100 % of the tolerance, either way: a real fixture's worst
    off = real.choice([-1.0, 1.0], shape) * real.uniform(0.7, 1.0, shape) * ATTITUDE_TOL_DEG
    poses = np.radians(np.asarray(poses_deg, float) + off)
    m = len(poses) - 1
    return gen.HandTurns(poses, holds, real.uniform(*FIXTURE_MOVE_S, m),
                         [(real.uniform(1.0, 2.5), bool(real.integers(2))) for _ in range(m)],
                         np.radians(real.uniform(-FIXTURE_WOBBLE_DEG, FIXTURE_WOBBLE_DEG, (m, 3))))


def _fixture(site, rng, real, folder, kind, effect, par, seed):
    """A six-position test (or an up/down) on an imperfect fixture turned by hand: per-hold tilts, moves of unknown
    and varying profile, a grade from navigation to consumer, flicker bias instability, misstated noise, a logged
    temperature that warms 8 degC over the test; the scenario states the holds only."""
    grade = par.get("grade") or fixture_grade(kind, effect, seed)
    k = GRADES[grade]
    k_eff = 1.0 if par.get("absolute") else k  # the concealed effect's size factor
    if kind == "updown_fixture":
        rate, nominal = 64.0, par.get("poses") or [(0, -90, 0), (0, 90, 0)]
        holds = real.uniform(250.0, 350.0, 2)
    else:
        rate, nominal = 50.0, FIXTURE_POSES
        holds = real.uniform(*FIXTURE_HOLD_S, len(nominal))
    motion = _hand_turns(real, nominal, holds)
    dt = 1.0 / rate
    t, gyro, accel = site.true_imu(motion, rate)
    n = len(t)
    temp_tau = np.random.default_rng([seed, 26]).uniform(*par["temp_tau_s"]) if "temp_tau_s" in par else 400.0
    temp = 24.0 + 8.0 * (1.0 - np.exp(-t / temp_tau)) + 0.3 * np.sin(2 * np.pi * t / 200.0)
    gyro_out, accel_out = gyro.copy(), accel.copy()
    if effect == "gyro_g_sensitivity":
        gyro_out += k * np.asarray(par["g"]) * accel
    elif effect == "warmup_drift":
        decay = np.exp(-(t - dt / 2) / par["tau"])[:, None]
        gyro_out += k_eff * decay * par["gyro"]
        accel_out += k_eff * decay * par["accel"]
    elif effect == "vibration":
        s = gen.interval_mean_sin(t, dt, par["f"], 0.7)
        gyro_out[:, 0] += k * par["gyro_x"] * s
        accel_out[:, 2] += k * par["accel_z"] * s
    elif effect == "temperature_bias":
        gyro_out += k * TEMP_REALISTIC * (temp - 25.0)[:, None] * TEMP_COEF
        accel_out += np.sqrt(k) * (temp - 25.0)[:, None] * FIXTURE_TEMP_ACCEL
    elif effect == "gauss_markov_bias":
        gyro_out += gen.gauss_markov(rng, n, dt, [k * par["gyro"]] * 3, par["tau"])
        accel_out += gen.gauss_markov(rng, n, dt, [k * par["accel"]] * 3, par["tau"])
    elif effect == "bias_random_walk":
        gyro_out += np.cumsum(rng.normal(0, k * par["gyro"] * np.sqrt(dt), (n, 3)), axis=0)
        accel_out += np.cumsum(rng.normal(0, k * par["accel"] * np.sqrt(dt), (n, 3)), axis=0)
    kw, kf = par.get("noise") or FIXTURE_NOISE.get(grade, (k, k))
    gyro_out += rng.normal(0, kw * GYRO_WHITE / np.sqrt(dt), (n, 3)) + gen.flicker(real, n, dt,
                                                                                     [kf * GYRO_FLICKER] * 3)
    accel_out += rng.normal(0, kw * ACCEL_WHITE / np.sqrt(dt), (n, 3)) + gen.flicker(real, n, dt,
                                                                                       [kf * ACCEL_FLICKER] * 3)
    gyro_out += rng.normal(0, k * 1e-3, 3)
    accel_out += rng.normal(0, max(k, 0.05) * 2e-2, 3)
    if effect == "quantization":
        gyro_out = gen.quantize_increments(gyro_out, dt, k * par["gyro_lsb"])
        accel_out = gen.quantize_increments(accel_out, dt, k * par["accel_lsb"])
    cols = {"t": t, "gx": gyro_out[:, 0], "gy": gyro_out[:, 1], "gz": gyro_out[:, 2],
            "ax": accel_out[:, 0], "ay": accel_out[:, 1], "az": accel_out[:, 2], "temp_c": temp}
    paths = {"recording": gen.write_csv(folder / "imu.csv", cols)}
    yaw_off = 0.0  # an up/down's heading as stated: off by a drawn angle where the case says so (never measured)
    if "heading_off_deg" in par:
        yaw_off = float(np.random.default_rng([seed, 29]).choice([-1.0, 1.0]) *
                        np.random.default_rng([seed, 30]).uniform(*par["heading_off_deg"]))
    segs = [{"t0": round(a, 2), "t1": round(b, 2), "roll_deg": float(r), "pitch_deg": float(p),
             "yaw_deg": float(y) + yaw_off} for (a, b), (r, p, y) in zip(motion.hold_spans(), nominal)]
    scenario = {"rate_hz": rate, "latitude_deg": par.get("latitude_deg", SITE[0]), "longitude_deg": SITE[1],
                "height_m": SITE[2],
                "gps": False, "static_segments": segs}
    paths["scenario"] = folder / "scenario.yaml"
    paths["scenario"].write_text(yaml.safe_dump(scenario, sort_keys=False))
    from nav_core.sensor_model import SensorModel, save
    physics = {"earth_rotation": {}, "gravity_model": {}, "coriolis": {}}
    physics.pop(effect, None)
    model = SensorModel(gyro=_triad(kw * GYRO_WHITE, kf * GYRO_FLICKER, real),
                        accel=_triad(kw * ACCEL_WHITE, kf * ACCEL_FLICKER, real), sample_rate_hz=rate,
                        physics=physics, provenance={"grade": grade})
    paths["model"] = save(model, folder / "model.yaml")
    paths["grade"] = grade
    return paths


def _updown(site, rng, folder, effect, real=None):
    """Navigation-grade static run at 64 Hz: x axis up 300 s, a recorded 10-s turn, x down 300 s; truth CSV at 64 Hz."""
    rate, hold = 64.0, 300.0
    motion = (gen.Poses([(0, -90, 0), (0, 90, 0)], hold, 10.0) if real is None else
              gen.Poses([(0, -90, 0), (0, 0, 0), (0, 90, 0)], [hold, UPDOWN_PAUSE_S, hold], 5.0))
    t, gyro, accel = site.true_imu(motion if real is None else _off_nominal(motion, real), rate)
    n = len(t)
    gw, aw = 2e-6, 2e-5  # ring-laser-grade white noise, rad/s/sqrt(s), m/s/sqrt(s)
    gyro = gyro + rng.normal(0, gw * np.sqrt(rate), (n, 3)) + rng.normal(0, 1e-7, 3)
    accel = accel + rng.normal(0, aw * np.sqrt(rate), (n, 3)) + rng.normal(0, 1e-4, 3)
    if real is not None:
        gyro += gen.flicker(real, n, 1.0 / rate, [gw / 10] * 3)
        accel += gen.flicker(real, n, 1.0 / rate, [aw / 10] * 3)
    cols = {"t": t, "gx": gyro[:, 0], "gy": gyro[:, 1], "gz": gyro[:, 2], "ax": accel[:, 0], "ay": accel[:, 1],
            "az": accel[:, 2]}
    paths = {"recording": gen.write_csv(folder / "imu.csv", cols)}
    gen.write_csv(folder / "truth.csv", site.truth_rows(motion, rate))
    paths["scenario"] = folder / "scenario.yaml"
    paths["scenario"].write_text(yaml.safe_dump({"trajectory": "truth.csv", "rate_hz": rate, "gps": False}))
    from nav_core.sensor_model import SensorModel, save
    model = SensorModel(gyro=_triad(gw, gw / 10, real), accel=_triad(aw, aw / 10, real), sample_rate_hz=rate,
                        physics={"gravity_model": {}, "coriolis": {}})
    paths["model"] = save(model, folder / "model.yaml")
    return paths


def _triad(white, flicker, real):
    """The user's statement of one triad's noise: exact without ``real``, else each level within
    +-NOISE_MISSTATED and the flicker bias instability stated too."""
    from nav_core.sensor_model import TriadModel
    if real is None:
        return TriadModel(white_noise=np.full(3, white))
    err = real.uniform(1 - NOISE_MISSTATED, 1 + NOISE_MISSTATED, (2, 3))
    return TriadModel(white_noise=white * err[0], bias_instability=flicker * err[1])


def _model(folder, rate, effect, kind, real=None, grade="industrial", noise=None):
    """The user's model: white noise and the full Earth model, less the concealed Earth-model term; ``noise`` the
    (white, flicker) factors of the unit's noise when they are not the grade's."""
    from nav_core.sensor_model import SensorModel, save
    if kind == "static_rw":
        from imu_calib.cli import main as calib_main
        calib_main(["allan", str(folder / "imu.csv"), "--out", str(folder / "calib"), "--no-progress"])
        return folder / "calib" / "sensor_model.yaml"
    physics = {"earth_rotation": {}, "gravity_model": {}, "coriolis": {}}
    physics.pop(effect, None)
    kg = GRADES[grade]
    kw, kf = noise or (kg, kg)
    model = SensorModel(gyro=_triad(kw * GYRO_WHITE, kf * GYRO_FLICKER, real),
                        accel=_triad(kw * ACCEL_WHITE, kf * ACCEL_FLICKER, real),
                        sample_rate_hz=rate, physics=physics)
    if kind == "ltable":  # the unit's bias walk, stated to +-NOISE_MISSTATED
        rw = real.uniform(1 - NOISE_MISSTATED, 1 + NOISE_MISSTATED, 2) if real is not None else np.ones(2)
        model.gyro.rate_random_walk[:] = kg * LTABLE_WALK[0] * rw[0]
        model.accel.rate_random_walk[:] = kg * LTABLE_WALK[1] * rw[1]
    return save(model, folder / "model.yaml")


def run_case(name: str, seed: int, max_effects: int = 2) -> dict:
    """Generate, diagnose, score one case."""
    from imu_sim.diagnose.case import load_case
    from imu_sim.diagnose.engine import diagnose
    with tempfile.TemporaryDirectory(prefix="indep_") as tmp:
        p = generate(name, seed, Path(tmp))
        case = load_case(p["recording"], p["scenario"], p["model"], p.get("gnss"))
        res = diagnose(case, max_effects=max_effects, seed=seed).result
    effect = None if name in NULLS else CASES[name][1]
    first = res["findings"][0] if res["findings"] else None
    row = {"case": name, "effect": effect, "seed": seed, "tested_not_separable": [
               t["effect"] for t in res["tested"] if "not separable" in (t.get("note") or "")], "grade": p.get("grade"),
           "first": first["effect"] if first else None,
           "findings": [(f["effect"], f.get("share_of_mismatch")) for f in res["findings"]],
           "n_significant": res["n_significant_first_pass"],
           "significant": [t["effect"] for t in res["tested"] if t["significant"]]}
    if first and first["effect"] == effect:
        cover = []
        scale = {"bias_random_walk": RW_REALISTIC, "temperature_bias": TEMP_REALISTIC}.get(name, 1.0) if REALISTIC \
            else 1.0
        for par, true in true_values(name, p.get("grade") or "industrial").items():
            true *= scale
            if par in first["intervals"]:
                lo, hi = first["intervals"][par]
                cover.append(bool(lo <= true <= hi))
        row["covered"], row["n_params"] = int(sum(cover)), len(cover)
        row["fit"] = [first["fit_before"], first["fit_after"]]
    return row


def table(rows: list) -> str:
    """Markdown: per case right-first / coverage, per null the runs with a kept finding (crashed runs counted apart)."""
    errors = [r for r in rows if "error" in r]
    rows = [r for r in rows if "error" not in r]
    lines = ["| case | runs | right effect first | interval coverage |", "|---|---|---|---|"]
    for name in [c for c in CASES if any(r["case"] == c for r in rows)]:
        rs = [r for r in rows if r["case"] == name]
        hit = [r for r in rs if r["first"] == r["effect"]]
        n_par = sum(r.get("n_params", 0) for r in hit)
        wrong = sorted({str(r["first"]) for r in rs if r["first"] != r["effect"]})
        cov = f"{sum(r['covered'] for r in hit) / n_par:.0%}" if n_par else "-"
        lines.append(f"| {name} | {len(rs)} | {len(hit) / len(rs):.0%}" + (f" (else: {', '.join(wrong)})" if wrong
                                                                            else "") + f" | {cov} |")
    for name in [c for c in NULLS if any(r["case"] == c for r in rows)]:
        rs = [r for r in rows if r["case"] == name]
        kept = [r for r in rs if r["findings"]]
        what = sorted({f[0] for r in kept for f in r["findings"]})
        lines.append(f"| {name} | {len(rs)} | runs with a finding: {len(kept)}" + (f" ({', '.join(what)})" if what
                                                                                      else "") + " | |")
    eff = [r for r in rows if r["case"] in CASES]
    nul = [r for r in rows if r["case"] in NULLS]
    if eff:
        k = sum(r["first"] == r["effect"] for r in eff)
        lo = stats.beta.ppf(0.025, k, len(eff) - k + 1) if k else 0.0
        n_par = sum(r.get("n_params", 0) for r in eff)
        cov = sum(r.get("covered", 0) for r in eff) / n_par if n_par else float("nan")
        lines.append(f"| all effect cases | {len(eff)} | {k / len(eff):.1%} (95 % lower bound {lo:.1%}) | {cov:.0%} |")
    if nul:
        k = sum(not r["findings"] for r in nul)
        lo = stats.beta.ppf(0.025, k, len(nul) - k + 1) if k else 0.0
        lines.append(f"| all null cases | {len(nul)} | no finding {k / len(nul):.1%} (95 % lower bound {lo:.1%}) | |")
    for grade in [g for g in GRADES if any(r.get("grade") == g for r in rows)] if REALISTIC else []:
        ge = [r for r in eff if r.get("grade") == grade]
        gn = [r for r in nul if r.get("grade") == grade]
        lines.append(f"| grade {grade} (table, drive) | {len(ge)} + {len(gn)} nulls | "
                     f"first {sum(r['first'] == r['effect'] for r in ge)}/{len(ge)}, "
                     f"nulls clean {sum(not r['findings'] for r in gn)}/{len(gn)} | |")
    if errors:
        lines.append(f"| runs that crashed (not scored) | {len(errors)} | "
                     f"{'; '.join(sorted({r['case'] + ': ' + r['error'][:80] for r in errors}))} | |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--null-seeds", type=int, default=20)
    parser.add_argument("--cases", nargs="*", default=None, help=f"default all: {list(CASES) + list(NULLS)}")
    parser.add_argument("--out", default="/tmp/diag_independent")
    parser.add_argument("--resume", default=None, help="rows.json of an earlier run of the same code to reuse")
    parser.add_argument("--quick", action="store_true", help="1 seed of one effect and one null (a smoke run)")
    parser.add_argument("--drive", choices=("figure8", "town", "slow", "short", "cruise"), default="figure8",
                        help="drive of the GNSS, coriolis and null_drive cases (town: 240 s with stops, see DRIVE; "
                             "short: 300 s at 6 knots, SHORT_LEGS)")
    parser.add_argument("--realistic", action="store_true",
                        help="misstated noise, flicker bias instability, off-nominal fixtures, a 10-Hz drive truth with "
                             "slow error, the rate table typed as its holds (module docstring)")
    parser.add_argument("--truth-positions", action="store_true",
                        help="a realistic drive's truth.csv without velocity rows (positions and attitude only)")
    parser.add_argument("--table-physics", action="store_true",
                        help="a realistic table unit's warm-up, temperature coefficient, g-sensitivity and table rate "
                             "errors (TABLE_PHYSICS)")
    parser.add_argument("--table-short", action="store_true",
                        help="with --table-physics: 100-Hz tables, dwells of 3-8 s at up to 110 deg/s (TABLE_SHORT)")
    parser.add_argument("--table-offaxis", type=float, default=0.0, metavar="M",
                        help="a mounted table's unit up to M metres off the table's axis per body axis "
                             "(TABLE_OFFAXIS_M)")
    parser.add_argument("--table-rate-err", type=float, default=0.0, metavar="E",
                        help="with --table-physics: every grade's dwells off their stated rates by up to E (relative)")
    args = parser.parse_args(argv)
    global TRUTH_VELOCITY, TABLE_PHYSICS, TABLE_SHORT, TABLE_OFFAXIS_M, TABLE_RATE_ERR_ALL
    TABLE_SHORT, TABLE_OFFAXIS_M, TABLE_RATE_ERR_ALL = args.table_short, args.table_offaxis, args.table_rate_err
    TRUTH_VELOCITY = not args.truth_positions
    TABLE_PHYSICS = args.table_physics
    global REALISTIC
    REALISTIC = args.realistic
    global DRIVE
    DRIVE = args.drive
    if args.quick:
        args.seeds, args.null_seeds, args.cases = 1, 1, args.cases or ["gravity_model", "null_tumble"]
    names = args.cases or list(NULLS) + list(CASES)
    jobs = [(c, (8000 if c in NULLS else 7000) + s) for s in range(max(args.seeds, args.null_seeds)) for c in names
            if s < (args.null_seeds if c in NULLS else args.seeds)]
    done = {(r["case"], r["seed"]): r for r in json.loads(Path(args.resume).read_text())} if args.resume else {}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, start = [], time.perf_counter()
    for name, seed in jobs:
        t0 = time.perf_counter()
        try:
            rows.append(done.get((name, seed)) or run_case(name, seed))
        except Exception as err:  # noqa: BLE001 - a crashed case is reported, not hidden, and the run goes on
            rows.append({"case": name, "seed": seed, "error": f"{type(err).__name__}: {err}"})
            print(f"{name} {seed}: ERROR {rows[-1]['error']}", file=sys.stderr, flush=True)
            continue
        print(f"{name} {seed}: first {rows[-1]['first']} findings {rows[-1]['findings']} "
              f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
        (out / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    text = table(rows)
    (out / "table.md").write_text(text + "\n")
    print(text)
    print(f"{len(rows)} cases in {time.perf_counter() - start:.0f} s; outputs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
