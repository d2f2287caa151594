"""Diagnosis cases: a recording with one physical effect the given sensor model leaves out (or none).

Each case is what a user hands ``imu-sim diagnose``: an IMU CSV (with ``temp_c``), a scenario YAML
with the *nominal* reference (fixtures off their nominal attitude by up to the stated tolerance; a
drive's truth from a smoothed noisy GNSS track with its own low-frequency error), a sensor-model YAML
(noise levels as a calibration would find them, +-10 %), and for drives a GNSS CSV. The answer key
(``answer``) names the concealed effect and its true parameters; it is for the scorer only.
"""
from dataclasses import dataclass, field

import numpy as np
import pymap3d
from scipy.spatial.transform import Rotation

from . import earth, ideal, motion, sensor

M_FINE = 4
"""Fine-grid steps per IMU sample (Simpson means)."""

# scenario class -> (effects it conceals, grades it uses); None = null case
CLASSES = {
    "fixture": {None: sensor.GRADE_ORDER, "earth_rotation": ("navigation", "tactical", "industrial"),
                "gravity_model": sensor.GRADE_ORDER,
                "gyro_g_sensitivity": ("tactical", "industrial", "consumer"),
                "temperature_bias": sensor.GRADE_ORDER, "warmup_drift": sensor.GRADE_ORDER,
                "vibration": sensor.GRADE_ORDER, "gauss_markov_bias": sensor.GRADE_ORDER,
                "bias_random_walk": sensor.GRADE_ORDER, "quantization": ("consumer",)},
    "updown": {None: ("navigation", "tactical", "industrial"),
               "earth_rotation": ("navigation", "tactical", "industrial")},
    "rate_table": {None: ("tactical", "industrial", "consumer"),
                   "scale_factor": ("tactical", "industrial", "consumer"),
                   "axis_misalignment": ("tactical", "industrial", "consumer")},
    "drive": {None: ("navigation", "tactical", "industrial"), "coriolis": ("navigation", "tactical"),
              "gps_lever_arm": ("tactical", "industrial", "consumer"),
              "gps_latency": ("tactical", "industrial", "consumer"),
              "colored_gps_noise": ("tactical", "industrial", "consumer")},
}


def case_names():
    """Every 'class/effect' name (effect 'null' for none)."""
    return [f"{c}/{e or 'null'}" for c, effects in CLASSES.items() for e in effects]


@dataclass
class Case:
    """Files of one case (arrays and dicts) plus its answer key."""

    name: str
    seed: int
    imu: np.ndarray
    imu_header: list
    scenario: dict
    model: dict
    answer: dict
    truth_rows: np.ndarray | None = None
    gnss_rows: np.ndarray | None = None
    meta: dict = field(default_factory=dict)


def _seed_for(name: str, seed: int) -> np.random.Generator:
    return np.random.default_rng([seed, *map(ord, name)])


# ------------------------------------------------------------------ references
def _tilt(rng, tol_deg) -> Rotation:
    """A fixture error within ``tol_deg``: roll/pitch off by up to tol, heading off by up to tol."""
    mag = rng.uniform(0.3, 1.0) * tol_deg
    az = rng.uniform(0, 2 * np.pi)
    return motion.euler_rot(mag * np.cos(az), mag * np.sin(az), rng.uniform(-tol_deg, tol_deg))


def _seg(t0, t1, rot, **extra) -> dict:
    r, p, y = motion.rpy_deg(rot)
    return {"t0": round(float(t0), 6), "t1": round(float(t1), 6), "roll_deg": float(r),
            "pitch_deg": float(p), "yaw_deg": float(y), **extra}


FACES = [(0, 0), (180, 0), (0, -90), (0, 90), (90, 0), (-90, 0)]
"""(roll, pitch) of the six faces: z up, z down, x up, x down, y up, y down."""


OPPOSITE = {0: 1, 1: 0, 2: 3, 3: 2, 4: 5, 5: 4}


MAX_MOVE_DEG = 150.0
"""Largest move between two static attitudes: near 180 deg a move could turn either way, and static
segments cannot say which (see README), so the generator never asks for one."""


def move_angle_deg(a: Rotation, b: Rotation) -> float:
    """Angle (deg) of the rotation taking attitude ``a`` to ``b``."""
    return float(np.degrees((a.inv() * b).magnitude()))


def six_face_order(rng):
    """The six faces in a random order in which every move turns at most MAX_MOVE_DEG (at a common heading:
    e.g. z down -> x up by pitching is a 180-deg turn, so it is excluded with the opposite faces)."""
    while True:
        faces = [FACES[i] for i in rng.permutation(6)]
        rots = [motion.euler_rot(r, p, 0.0) for r, p in faces]
        if all(move_angle_deg(a, b) <= MAX_MOVE_DEG for a, b in zip(rots[:-1], rots[1:])):
            return faces


def fixture_sequence(rng, faces, dwells, move, tol_deg):
    """Attitude pieces of a fixture test and the scenario's nominal segments; ``dwells[i]`` = (lo, hi) s."""
    yaw0 = rng.choice([0.0, 90.0, 180.0, -90.0]) + rng.uniform(-5, 5)
    nominal = [motion.euler_rot(r, p, yaw0) for r, p in faces]
    true = [n * _tilt(rng, tol_deg) for n in nominal]
    pieces, segs, t = [], [], 0.0
    for i, (nom, tru) in enumerate(zip(nominal, true)):
        d = rng.uniform(*dwells[i])
        pieces.append(motion.Hold(tru, d))
        segs.append(_seg(t, t + d, nom))
        t += d
        if i + 1 < len(true):
            mv = rng.uniform(*move)
            pieces.append(motion.Move(tru, true[i + 1], mv))
            t += mv
    segs[-1]["t1"] = round(t + 1.0, 6)  # cover the last sample
    return pieces, segs, t


def updown_faces(rng, flips):
    """z up / z down ``flips`` times, each flip through a short pause on the side (y up): two 90-deg turns."""
    faces, dwells = [(0, 0)], [(30, 50)]
    for k in range(flips):
        faces += [(90, 0), (180, 0) if k % 2 == 0 else (0, 0)]
        dwells += [(1.5, 3.0), (30, 50)]
    return faces, dwells


def rate_table_sequence(rng, tol_deg):
    """Three mountings (z, x, y up) on a vertical-axis table; short dwells at +-two rates each."""
    mounts = [((0, 0), np.array([0.0, 0, 1])), ((0, -90), np.array([1.0, 0, 0])), ((90, 0), np.array([0.0, 1, 0]))]
    rates = np.radians(np.sort(rng.uniform([10, 40], [30, 120])))
    yaw = rng.uniform(-180, 180)
    pieces, segs, t = [], [], 0.0
    prev_true = None
    for (roll, pitch), axis in mounts:
        tilt = _tilt(rng, tol_deg)
        nom = motion.euler_rot(roll, pitch, yaw)
        for turn in (90.0, -90.0, 180.0):  # remount at a heading the move can reach unambiguously
            if prev_true is None or move_angle_deg(prev_true, nom) <= MAX_MOVE_DEG:
                break
            nom = motion.euler_rot(roll, pitch, yaw + turn)
        tru = nom * tilt
        if prev_true is not None:
            mv = rng.uniform(4, 8)
            pieces.append(motion.Move(prev_true, tru, mv))
            t += mv
        for k, w in enumerate([rates[0], -rates[0], rates[1], -rates[1]]):
            rest = rng.uniform(2, 5) if k else rng.uniform(6, 10)
            pieces.append(motion.Hold(tru, rest))
            segs.append(_seg(t, t + rest, nom))
            t += rest
            ramp, dwell = rng.uniform(0.8, 2.0), rng.uniform(4, 8)
            spin = motion.Spin(tru, tilt.inv().apply(axis), w, ramp, dwell)
            pieces.append(spin)
            start_nom = motion.Spin(nom, axis, w, ramp, dwell)
            segs.append(_seg(t + ramp, t + ramp + dwell, start_nom.at(np.array([ramp]))[0],
                             rate_dps=float(np.degrees(w)), axis_body=[float(a) for a in axis]))
            t += spin.duration_s
            tru = spin.end()
            nom = start_nom.end()
        rest = rng.uniform(3, 6)
        pieces.append(motion.Hold(tru, rest))
        segs.append(_seg(t, t + rest, nom))
        t += rest
        prev_true = tru
        yaw = motion.rpy_deg(nom)[2]
    segs[-1]["t1"] = round(t + 1.0, 6)
    return pieces, segs, t


def _gm_series(rng, t, sigma, tau):
    """Gauss-Markov series (one column per sigma) at arbitrary uniform times ``t``."""
    dt = t[1] - t[0]
    sig = np.atleast_1d(sigma)
    return sensor.gauss_markov(rng, len(t), dt, np.resize(sig, 3), np.resize(np.atleast_1d(tau), 3))[:, :len(sig)]


def slow_error(rng, t, sigma, periods=(20.0, 300.0), k=12):
    """A smooth low-frequency error, shape (len(t), len(sigma)): k random sinusoids with periods in
    ``periods`` (log-uniform), scaled to rms ``sigma`` per column (differentiable, unlike a Gauss-Markov)."""
    sig = np.atleast_1d(sigma)
    out = np.zeros((len(t), len(sig)))
    for j in range(len(sig)):
        f = 1.0 / np.exp(rng.uniform(np.log(periods[0]), np.log(periods[1]), k))
        a = rng.standard_normal(k)
        out[:, j] = (a[None] * np.sin(2 * np.pi * f[None] * t[:, None] + rng.uniform(0, 2 * np.pi, k))).sum(1)
        out[:, j] *= sig[j] / np.sqrt(0.5 * np.sum(a**2))
    return out


def drive_reference(rng, mot, t_rows, datum, error_scale=1.0):
    """Reference truth rows (t, lat, lon, h, roll, pitch, yaw) from a smoothed noisy GNSS track.

    The smoothing is modelled by its result: the IMU path + a slow error (what smoothing leaves of a
    float/PPK solution's multipath: rms 5-30 cm, periods 30-600 s). Attitude: truth rotated by a slow
    error (roll/pitch rms 0.005-0.03 deg, yaw 0.02-0.1 deg, periods 30-300 s), as from a smoother."""
    enu = np.stack(pymap3d.geodetic2enu(np.degrees(mot.lat), np.degrees(mot.lon), mot.h, *datum), -1)
    sig = rng.uniform(0.05, 0.3) * np.array([1, 1, 2]) * error_scale
    ref = np.stack([np.interp(t_rows, mot.t, enu[:, i]) for i in range(3)], -1)
    ref += slow_error(rng, t_rows, sig, periods=(30.0, 600.0))
    lat, lon, h = pymap3d.enu2geodetic(ref[:, 0], ref[:, 1], ref[:, 2], *datum)
    idx = np.rint(np.interp(t_rows, mot.t, np.arange(len(mot.t)))).astype(int)
    att_sig = np.array([rng.uniform(0.005, 0.03), rng.uniform(0.005, 0.03), rng.uniform(0.02, 0.1)]) * error_scale
    att_err = slow_error(rng, t_rows, np.radians(att_sig), periods=(30.0, 300.0))
    rot = mot.rot[idx] * Rotation.from_rotvec(att_err)
    rows = np.column_stack([t_rows, lat, lon, h, motion.rpy_deg(rot)])
    meta = {"ref_pos_rms_m": sig.tolist(), "ref_att_rms_deg": att_sig.tolist()}
    return rows, meta, enu


# ------------------------------------------------------------------ the sensor and its model
def temperature(rng, t, chamber: bool):
    """Logged sensor temperature (deg C): self-heating after power-on, or a thermal-chamber cycle."""
    room = rng.uniform(19, 26)
    self_heat = rng.uniform(2, 8) * (1 - np.exp(-t / rng.uniform(100, 600)))
    temp = room + self_heat
    if chamber:  # ramp up, hold, ramp down at 0.5-2 deg C/min
        span = rng.uniform(10, 25)
        tri = np.interp(t, [0, 0.1 * t[-1], 0.45 * t[-1], 0.55 * t[-1], 0.9 * t[-1], t[-1]],
                        [0, 0, span, span, 0, 0])
        temp = temp + tri - span / 2
    return np.round(temp + 0.02 * rng.standard_normal(len(t)), 3)


def model_dict(terms, bias, rate_hz, physics, rng) -> dict:
    """The sensor-model YAML a user would have: deterministic terms as calibrated, noise within +-10 %."""
    out = {"sensor_model_version": 1, "sample_rate_hz": float(rate_hz),
           "provenance": {"tool": "benchmarks/blind (blind validation generator)",
                          "source": "calibration of the same unit"}}
    for tri in ("gyro", "accel"):
        tt = terms[tri]
        def jitter(x):
            return (np.asarray(x) * rng.uniform(0.9, 1.1, np.shape(x))).tolist()
        sf, mis, rrw = tt["sf"], tt["mis"], jitter(tt["rrw"])
        out[tri] = {"bias": {"value": np.asarray(bias[tri]).tolist()}, "scale_factor": {"value": sf.tolist()},
                    "misalignment": {"value": mis.tolist()}, "white_noise": {"value": jitter(tt["white"])},
                    "bias_instability": {"value": jitter(tt["flicker"])},
                    "bias_correlation_time": {"value": [0.0, 0.0, 0.0]},
                    "rate_random_walk": {"value": rrw}}
    out["physics"] = physics
    return out


def _location(rng, need_gravity_gap=False):
    """A test site (lat, lon deg, h m); with ``need_gravity_gap`` one where normal gravity is >= 0.01 m/s^2
    away from 9.80665 (else leaving the gravity model out would change nothing measurable)."""
    while True:
        lat, lon, h = rng.uniform(-60, 65), rng.uniform(-180, 180), rng.uniform(0, 2500)
        gap = abs(earth.normal_gravity(np.radians(lat), h) - earth.STANDARD_GRAVITY)
        if not need_gravity_gap or gap >= 0.01:
            return float(lat), float(lon), float(h)


BASE_PHYSICS = ("earth_rotation", "gravity_model", "coriolis")


def _inject(effect, rng, grade, t, dt, ideal_g, ideal_a, temp):
    """Additive signal of ``effect`` on (gyro, accel), shape (n, 3) each, and its true parameters."""
    g = sensor.GRADES[grade]
    add_g, add_a = np.zeros_like(ideal_g), np.zeros_like(ideal_a)
    if effect == "gyro_g_sensitivity":
        coef = sensor.signed(rng, g["g_sens"])
        add_g = ideal_a * coef
        return add_g, add_a, {"gyro_coeff_rad_per_s_per_mps2": coef}
    if effect == "temperature_bias":
        cg, ca = sensor.signed(rng, g["gyro_temp"]), sensor.signed(rng, g["accel_temp"])
        # scaled up to 3-10x the compensated residual: an uncompensated unit of the class
        cg, ca = cg * rng.uniform(3, 10), ca * rng.uniform(3, 10)
        dtemp = (temp - 25.0)[:, None]
        return dtemp * cg, dtemp * ca, {"gyro_coeff_rad_per_s_per_degc": cg, "accel_coeff_mps2_per_degc": ca}
    if effect == "warmup_drift":
        tau = rng.uniform(40, 200)
        amp_g = sensor.signed(rng, g["gyro_flicker"]) * rng.uniform(5, 20)
        amp_a = sensor.signed(rng, g["accel_flicker"]) * rng.uniform(5, 20)
        # interval mean of exp(-t/tau) over (t - dt, t]
        shape = (tau / dt * (np.exp(-(t - dt) / tau) - np.exp(-t / tau)))[:, None]
        return shape * amp_g, shape * amp_a, {"gyro_amplitude_rad_per_s": amp_g, "accel_amplitude_mps2": amp_a,
                                              "time_constant_s": tau}
    if effect == "vibration":
        freq = rng.uniform(6.0, 0.42 / dt)
        sg = np.sqrt(np.mean(g["gyro_white"]) ** 2 / dt)
        sa = np.sqrt(np.mean(g["accel_white"]) ** 2 / dt)
        amp_a = sa * rng.uniform(0.05, 0.4, 3)
        amp_g = sg * rng.uniform(0.02, 0.3, 3)
        phase = rng.uniform(0, 2 * np.pi)
        s = sensor.sine_interval_means(t, dt, freq, phase)[:, None]
        return s * amp_g, s * amp_a, {"frequency_hz": freq, "gyro_amplitude_rad_per_s": amp_g,
                                      "accel_amplitude_mps2": amp_a}
    if effect == "gauss_markov_bias":
        tau_g, tau_a = rng.uniform(2, 60), rng.uniform(2, 60)
        sig_g = np.mean(g["gyro_flicker"]) * rng.uniform(3, 10) * np.ones(3)
        sig_a = np.mean(g["accel_flicker"]) * rng.uniform(3, 10) * np.ones(3)
        n = len(t)
        return (sensor.gauss_markov(rng, n, dt, sig_g, [tau_g] * 3),
                sensor.gauss_markov(rng, n, dt, sig_a, [tau_a] * 3),
                {"gyro_sigma_rad_per_s": sig_g[0], "gyro_correlation_time_s": tau_g,
                 "accel_sigma_mps2": sig_a[0], "accel_correlation_time_s": tau_a})
    if effect == "bias_random_walk":
        kg = np.mean(g["gyro_rrw"]) * rng.uniform(5, 20)
        ka = np.mean(g["accel_rrw"]) * rng.uniform(5, 20)
        n = len(t)
        return (np.cumsum(rng.standard_normal((n, 3)) * kg * np.sqrt(dt), 0),
                np.cumsum(rng.standard_normal((n, 3)) * ka * np.sqrt(dt), 0),
                {"gyro_rad_per_s_per_sqrt_s": kg, "accel_mps2_per_sqrt_s": ka})
    return add_g, add_a, {}


def _base(name, seed):
    cls, eff = name.split("/")
    effect = None if eff == "null" else eff
    if cls not in CLASSES or effect not in CLASSES[cls]:
        raise KeyError(f"unknown case {name!r}; known: {case_names()}")
    rng = _seed_for(name, seed)
    grade = str(rng.choice(CLASSES[cls][effect]))
    return cls, effect, rng, grade


def build_case(name: str, seed: int, perfect_reference: bool = False) -> Case:
    """Build the case ``name`` ('class/effect') for ``seed``: deterministic in (name, seed).

    ``perfect_reference``: the control - fixtures exactly at their nominal attitudes, a drive's truth
    without its slow error (every other draw the same)."""
    cls, effect, rng, grade = _base(name, seed)
    terms = sensor.draw_triads(rng, grade)
    tol = float(rng.choice([0.25, 0.5, 1.0]))
    tol_true = 0.0 if perfect_reference else tol
    long_effect = effect in ("warmup_drift", "temperature_bias", "gauss_markov_bias", "bias_random_walk")
    rate = 100.0 if cls == "rate_table" else float(rng.choice([50.0, 64.0]))
    if cls == "drive":
        rate = 50.0
    dt = 1.0 / rate
    lat, lon, h = _location(rng, need_gravity_gap=(effect == "gravity_model"))
    scenario = {"name": f"blind {name} seed {seed}", "latitude_deg": lat, "longitude_deg": lon, "height_m": h,
                "rate_hz": rate}
    meta = {"grade": grade, "rate_hz": rate, "perfect_reference": perfect_reference}
    truth_rows = gnss_rows = None
    if cls in ("fixture", "updown", "rate_table"):
        if cls == "fixture":
            faces = six_face_order(rng)
            dwell = (45, 75) if long_effect else (20, 35)
            pieces, segs, total = fixture_sequence(rng, faces, [dwell] * 6, (3, 6), tol_true)
        elif cls == "updown":
            faces, dwells = updown_faces(rng, int(rng.integers(2, 4)))
            pieces, segs, total = fixture_sequence(rng, faces, dwells, (2, 4), tol_true)
        else:
            pieces, segs, total = rate_table_sequence(rng, tol_true)
        n = int(np.floor(total / dt))
        fine_t = np.arange(n * M_FINE + 1) * dt / M_FINE
        mot = motion.fixed_point(pieces, lat, lon, h, fine_t)
        scenario.update({"gps": False, "attitude_tolerance_deg": tol, "static_segments": segs})
        meta["fixture_tolerance_deg"] = tol
    else:
        total = rng.uniform(200, 260)
        n = int(np.floor(total / dt))
        fine_t = np.arange(n * M_FINE + 1) * dt / M_FINE
        mot, desc = motion.road_drive(rng, lat, lon, h, fine_t, rng.uniform(0.3, 0.8))
        meta.update(desc)
        t_rows = np.arange(0, fine_t[-1] + 0.05, 0.1)
        t_rows[-1] = max(t_rows[-1], fine_t[-1])
        t_rows = np.minimum(t_rows, fine_t[-1])
        truth_rows, ref_meta, enu = drive_reference(rng, mot, t_rows, (lat, lon, h),
                                                    0.0 if perfect_reference else 1.0)
        meta.update(ref_meta)
        scenario.update({"trajectory": "truth.csv"})
    t = np.arange(1, n + 1) * dt
    ideal_g, ideal_a = ideal.ideal_imu(mot, M_FINE)
    temp = temperature(rng, t, chamber=(effect == "temperature_bias"))
    add_g, add_a, params = _inject(effect, rng, grade, t, dt, ideal_g, ideal_a, temp)
    model_bias = {tri: sensor.signed(rng, (0.1, 1.0)) * np.mean(sensor.GRADES[grade][f"{tri}_bias_rep"])
                  for tri in ("gyro", "accel")}
    rec = {}
    for tri, ideal_x, add in (("gyro", ideal_g, add_g), ("accel", ideal_a, add_a)):
        bias = model_bias[tri] + terms[tri]["bias_rep"]
        x = sensor.apply_triad(ideal_x, terms[tri], bias) + add + sensor.noise(rng, n, dt, terms[tri])
        rec[tri] = sensor.quantize(x, terms[tri]["lsb"])
    if effect == "scale_factor" or effect == "axis_misalignment":
        key = "sf" if effect == "scale_factor" else "mis"
        params = {"gyro": terms["gyro"][key]}
    if effect == "bias_random_walk":  # the unit walks (its own small walk + the injected one); the model: none
        params = {"gyro_rad_per_s_per_sqrt_s": np.hypot(params["gyro_rad_per_s_per_sqrt_s"], terms["gyro"]["rrw"]),
                  "accel_mps2_per_sqrt_s": np.hypot(params["accel_mps2_per_sqrt_s"], terms["accel"]["rrw"])}
        for tri in ("gyro", "accel"):
            terms[tri]["rrw"] = np.zeros(3)
    physics = {e: {} for e in BASE_PHYSICS}
    if grade == "consumer":
        physics["quantization"] = {"gyro_lsb_rad": [terms["gyro"]["lsb"] * dt] * 3,
                                   "accel_lsb_mps": [terms["accel"]["lsb"] * dt] * 3}
        if effect == "quantization":
            params = {"gyro_step_rad_per_s": terms["gyro"]["lsb"], "accel_step_mps2": terms["accel"]["lsb"],
                      "gyro_lsb_rad": terms["gyro"]["lsb"] * dt, "accel_lsb_mps": terms["accel"]["lsb"] * dt}
    if effect == "earth_rotation" or effect == "coriolis":
        params = {"earth_rate_rad_s": earth.EARTH_RATE_RAD_S}
    if effect == "gravity_model":
        params = {"gravity_mps2": float(earth.normal_gravity(np.radians(lat), h))}
    if cls == "drive":
        gnss_rows, gps_scen, gps_phys, gps_params = _gnss(rng, effect, mot, enu, (lat, lon, h))
        scenario.update(gps_scen)
        physics.update(gps_phys)
        params.update(gps_params)
    model = model_dict(terms, model_bias, rate, physics, rng)
    if effect in ("scale_factor", "axis_misalignment"):
        key = "scale_factor" if effect == "scale_factor" else "misalignment"
        model["gyro"][key]["value"] = (np.zeros(3) if key == "scale_factor" else np.zeros((3, 3))).tolist()
    if effect is not None and effect in model["physics"]:
        del model["physics"][effect]
    imu = np.column_stack([t, rec["gyro"], rec["accel"], temp])
    answer = {"case": name, "seed": seed, "class": cls, "effect": effect, "grade": grade,
              "params": {k: np.asarray(v).tolist() for k, v in params.items()}}
    return Case(name=name, seed=seed, imu=imu, imu_header=["t", "gx", "gy", "gz", "ax", "ay", "az", "temp_c"],
                scenario=scenario, model=model, answer=answer, truth_rows=truth_rows, gnss_rows=gnss_rows,
                meta=meta)


def _gnss(rng, effect, mot, enu, datum):
    """1-Hz fixes of the antenna: lever arm, white noise, and the concealed GPS effect if any."""
    lever = np.array([rng.uniform(-1.5, 1.5), rng.uniform(-0.5, 0.5), rng.uniform(0.8, 1.8)])
    sigma = rng.uniform(0.3, 1.2) * np.array([1.0, 1.0, 1.6])
    tf = np.arange(1.0, np.floor(mot.t[-1]) + 1e-9)
    latency = rng.uniform(0.08, 0.4) if effect == "gps_latency" else 0.0
    ts = tf - latency
    idx = np.interp(ts, mot.t, np.arange(len(mot.t)))
    pos = np.stack([np.interp(ts, mot.t, enu[:, i]) for i in range(3)], -1)
    rot = mot.rot[np.rint(idx).astype(int)]
    pos = pos + rot.apply(lever)
    pos += rng.standard_normal(pos.shape) * sigma
    params, phys = {}, {"gps_lever_arm": {"lever_arm_m": lever.tolist()}}
    scen = {"gps": {"rate_hz": 1, "sigma_m": sigma.tolist()}, "gps_lever_arm_m": lever.tolist()}
    if effect == "gps_lever_arm":
        params["lever_arm_m"] = lever
        del phys["gps_lever_arm"]
        del scen["gps_lever_arm_m"]
    elif effect == "gps_latency":
        params["latency_s"] = latency
    elif effect == "colored_gps_noise":
        csig = rng.uniform(0.5, 2.0) * np.array([1.0, 1.0, 1.5])
        ctau = rng.uniform(20, 200)
        pos += _gm_series(rng, tf, csig, [ctau] * 3)
        params.update({"sigma_m": csig, "correlation_time_s": ctau})
    lat, lon, h = pymap3d.enu2geodetic(pos[:, 0], pos[:, 1], pos[:, 2], *datum)
    rows = np.column_stack([tf, lat, lon, h, np.tile(sigma, (len(tf), 1))])
    return rows, scen, phys, params
