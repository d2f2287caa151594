"""Inputs of a diagnosis: recording, scenario, model; the deterministic simulation and the residual.

The residual r = recorded - simulated-deterministic (bias, scale factor, misalignment
and the model's physics, no stochastic terms) holds the model's noise plus whatever
physics the model leaves out. Channels are ordered as :data:`CHANNELS`; samples are
matched by index (recording time rebased to 0, sample k <-> simulated sample k).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nav_core import recording
from nav_core.recording import GnssRecording, ImuRecording, RecordingError
from nav_core.sensor_model import SensorModel, load as load_model

from imu_sim import effects, kinematics
from imu_sim.scenario import Scenario, build_trajectory, load as load_scenario, temperature_profile
from imu_sim.simulate import _fit_length, imu_measurements, merge_physics, simulate

CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
DETERMINISTIC_TERMS = ("bias", "scale_factor", "misalignment")
MIN_SAMPLES = 256
COVER_TOL = 0.005
GAP_FACTOR = 1.5  # stamps more than this many sample periods apart (or not after the one before) break the pairing
"""Largest fraction of the recording the scenario may leave uncovered (cut with a note); beyond it: an error."""


class DiagnosisInputError(ValueError):
    """Unusable input for the diagnosis; the message names the file and what is wrong."""


@dataclass
class Case:
    """A recording matched to its scenario and model (SI units, t from 0 s)."""

    rec: ImuRecording
    scenario: Scenario
    model: SensorModel
    t: np.ndarray
    dt: float
    temp_c: np.ndarray | None
    gyro_true: np.ndarray
    accel_true: np.ndarray
    sim_t_abs: np.ndarray
    gnss: GnssRecording | None = None
    notes: list = field(default_factory=list)
    cache: dict = field(default_factory=dict)
    masked: np.ndarray | None = None
    bias_resets: list = field(default_factory=list)
    """Sample indices after a masked join: separately recorded files, each with its own turn-on bias."""
    """Samples where the truth moves but the recording does not (e.g. two files joined without the turn between
    them): residual and truth set to 0 there, so they carry no information."""
    unstated: np.ndarray | None = None
    """Samples a rate table's scenario does not state (the ramps between its dwells): truth set to 0 there and the
    residual filled with what carries no information (:func:`unstated.unstated_moves`, :func:`unstated.fill_unstated`)."""

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.t)

    @property
    def measured(self) -> np.ndarray:
        """Recorded channels (n, 6): gyro rad/s, accel m/s^2."""
        return np.column_stack([self.rec.gyro, self.rec.accel])


def load_case(rec_path, scenario_path, model_path, gnss_path=None) -> Case:
    """Read the three (four) input files; errors name the file."""
    try:
        rec = recording.read_imu(rec_path)
    except (RecordingError, OSError) as err:
        raise DiagnosisInputError(f"{rec_path}: cannot read the recording: {err}") from err
    sc = load_scenario(scenario_path)
    model = load_model(model_path)
    gnss = None
    if gnss_path is not None:
        try:
            gnss = recording.read_gnss(gnss_path)
        except (RecordingError, OSError) as err:
            raise DiagnosisInputError(f"{gnss_path}: cannot read the GNSS recording: {err}") from err
    return make_case(rec, sc, model, gnss, where=str(rec_path))


def make_case(rec: ImuRecording, sc: Scenario, model: SensorModel, gnss=None, where: str = "recording") -> Case:
    """Match a recording to a scenario at the recording's rate; the recording is cut to the scenario span."""
    if len(rec) < MIN_SAMPLES:
        raise DiagnosisInputError(f"{where}: {len(rec)} samples; the diagnosis needs at least {MIN_SAMPLES}")
    bad = ~(np.all(np.isfinite(rec.gyro), axis=1) & np.all(np.isfinite(rec.accel), axis=1))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise DiagnosisInputError(f"{where}: {int(bad.sum())} sample(s) with a NaN or infinite rate or specific force "
                                  f"(first: sample {k}, t = {rec.t[k]:.6f} s); the diagnosis needs every sample")
    _check_uniform(rec, where)
    rate = rec.rate_hz
    sc = copy.deepcopy(sc)
    sc.rate_hz = rate
    try:
        traj = build_trajectory(sc)
    except (ValueError, RecordingError, OSError) as err:
        raise DiagnosisInputError(f"{sc.where}: the simulator cannot build this scenario's trajectory: {err}") from err
    t_abs = kinematics.sample_times(traj, rate)
    n = min(len(rec), len(t_abs))
    notes = []
    if len(rec) - n > max(2, int(COVER_TOL * len(rec))):
        raise DiagnosisInputError(
            f"{where}: the recording spans {len(rec) / rate:.1f} s but the scenario ({sc.where}) only "
            f"{traj.duration:.1f} s: the truth must cover the recording (cut the recording or extend the truth)")
    if n < len(rec):
        notes.append(f"recording cut from {len(rec)} to {n} samples (the scenario spans {traj.duration:.1f} s)")
    if n < MIN_SAMPLES:
        raise DiagnosisInputError(f"{where}: only {n} samples overlap the scenario ({traj.duration:.1f} s)")
    rec = rec.select(slice(0, n))
    t = rec.t - rec.t[0] + 1.0 / rate
    temp = rec.temp_c if rec.temp_c is not None else temperature_profile(sc, t_abs[:n])
    dth, dv = kinematics.increments(traj, t_abs[:n], 1.0 / rate, kinematics.FULL)
    gyro_true, accel_true = dth * rate, dv * rate
    _check_accel_unit(rec, accel_true, where)
    masked = _unrecorded_motion(rec, gyro_true, where, sc.where)
    if masked is not None:
        gyro_true[masked], accel_true[masked] = 0.0, 0.0
        notes.append(f"{int(masked.sum())} samples where the scenario turns the IMU faster than anything recorded "
                     f"(at t = {', '.join(f'{x:.2f}' for x in t[masked][:5])} s; files joined without the move?) "
                     "carry no information (residual and truth set to 0 there)")
    from imu_sim.diagnose.unstated import unstated_moves
    unstated = unstated_moves(sc, t_abs[:n], 1.0 / rate)
    if unstated is not None:
        gyro_true[unstated], accel_true[unstated] = 0.0, 0.0
        notes.append(f"{int(unstated.sum())} samples between the rate table's stated dwells (its ramps, whose profile "
                     "the scenario does not give) carry no information: a reference error, not sensor physics")
    from imu_sim.diagnose.dwell_edges import unsettled_edges
    edges = unsettled_edges(sc, t_abs[:n], rec.gyro, unstated)
    if edges is not None:
        unstated = edges if unstated is None else unstated | edges
        gyro_true[edges], accel_true[edges] = 0.0, 0.0
        notes.append(f"{int(edges.sum())} samples at the edges of the rate table's stated segments, where the recorded "
                     "rate about the spin axis has not settled at the segment's level (the table still ramping), "
                     "carry no information either")
    resets = [] if masked is None else [int(i) + 1 for i in np.flatnonzero(masked[:-1] & ~masked[1:])]
    if resets:
        notes.append("a separate turn-on bias per joined file (a step on every channel at each join is a nuisance)")
    return Case(rec, sc, model, t, 1.0 / rate, temp, gyro_true, accel_true, t_abs[:n], gnss, notes, masked=masked,
                bias_resets=resets, cache={"traj": traj}, unstated=unstated)


def _check_uniform(rec: ImuRecording, where: str) -> None:
    """DiagnosisInputError naming the first sample where the stamps are not one sample period (+-50 %) apart:
    the recording is paired with the simulation by sample index, so a gap, a repeat or a step back would shift
    every sample after it against the truth (a 5-s gap gave no finding at all, silently)."""
    period = float(np.median(np.abs(np.diff(rec.t))))
    check = recording.check_timestamps(rec.t, where, max_gap_s=GAP_FACTOR * period)
    if not check.ok:
        raise DiagnosisInputError(
            f"{check.summary()}: the diagnosis pairs samples with the scenario by index, so everything after it "
            f"would be compared with the wrong time; cut the recording there (or repair it)")


def _check_accel_unit(rec: ImuRecording, accel_true, where: str) -> None:
    """DiagnosisInputError when the recorded specific force is not about the scenario's (median |f| ratio outside
    [0.5, 2]): another unit (g, mg), which the per-channel turn-on bias would otherwise absorb without a finding."""
    f_rec = float(np.median(np.linalg.norm(rec.accel, axis=1)))
    f_true = float(np.median(np.linalg.norm(accel_true, axis=1)))
    if f_true > 0 and not 0.5 <= f_rec / f_true <= 2.0:
        raise DiagnosisInputError(f"{where}: accelerometer columns: median |specific force| {f_rec:.4g}, the "
                                  f"scenario's {f_true:.4g} m/s^2 ({f_rec / f_true:.3g} x): recorded in another unit "
                                  "(g? mg?)")


def _unrecorded_motion(rec, gyro_true, where, sc_where):
    """Mask of samples whose true rate exceeds 10x the recorded rates + 1 rad/s; None when there are none.

    More than 1 % of such samples: the truth does not belong to this recording (an input error)."""
    recorded = float(np.percentile(np.linalg.norm(rec.gyro, axis=1), 99.9))
    bad = np.linalg.norm(gyro_true, axis=1) > 10.0 * recorded + 1.0
    if not bad.any():
        return None
    if bad.mean() > 0.01:
        raise DiagnosisInputError(
            f"{where}: the scenario ({sc_where}) turns the IMU at up to "
            f"{np.max(np.linalg.norm(gyro_true, axis=1)):.3g} "
            f"rad/s in {int(bad.sum())} samples where the recording shows at most {recorded:.3g} rad/s: the truth "
            "does not match this recording")
    return bad


def trajectory(case: Case):
    """The case's truth trajectory, built once (a truth CSV's read and spline fit take seconds)."""
    if "traj" not in case.cache:
        case.cache["traj"] = build_trajectory(case.scenario)
    return case.cache["traj"]


def deterministic(case: Case, model: SensorModel, stochastic: bool = False, seed: int = 0) -> np.ndarray:
    """Simulated channels (n, 6) of ``model`` in the case's scenario; noise-free unless ``stochastic``.

    What :func:`imu_sim.simulate.simulate` computes for the IMU, on the case's trajectory and exact increments
    built once per case (the simulator rebuilt them on every call: 3/4 of a diagnosis' time on a truth CSV)."""
    sc = case.scenario
    terms = sc.error_terms if stochastic else DETERMINISTIC_TERMS
    temp_c = case.temp_c if _needs_temp(model) else None
    if sc.faults:  # a faulty unit's output: the simulator's own path
        res = simulate(sc, model, seed=seed, terms=terms, with_bytes=False, temp_c=temp_c)
        return np.column_stack([res.imu.gyro, res.imu.accel])[:case.n]
    base = model.copy()
    base.physics = merge_physics(base.physics, sc.physics)
    mdl = effects.apply_model_overrides(base)
    traj = trajectory(case)
    rate = float(sc.rate_hz)
    dt = 1.0 / rate
    key = ("increments", kinematics.Physics.from_effects(mdl.physics))
    if key not in case.cache:
        t = kinematics.sample_times(traj, rate)
        case.cache[key] = (t, *kinematics.increments(traj, t, dt, key[1]))
    t, dth0, dv0 = case.cache[key]
    temp = temperature_profile(sc, t) if temp_c is None else _fit_length(np.asarray(temp_c, float), len(t))
    dtheta, dv = imu_measurements(t, dt, dth0.copy(), dv0.copy(), mdl, mdl.physics, temp, int(seed), terms)
    return np.column_stack([dtheta / dt, dv / dt])[:case.n]


def _needs_temp(model: SensorModel) -> bool:
    return model.has_physics("temperature_bias")


def residual(case: Case, model: SensorModel) -> np.ndarray:
    """Recorded minus simulated-deterministic, (n, 6); 0 at masked samples."""
    out = case.measured - deterministic(case, model)
    if case.masked is not None:
        out[case.masked] = 0.0
    if case.unstated is not None:
        from imu_sim.diagnose.unstated import fill_unstated
        out = fill_unstated(out, case.unstated)
    return out


def kinematic_difference(case: Case, model: SensorModel, effect: str) -> np.ndarray:
    """True channels (n, 6) with ``effect`` switched on minus without, under the model's other physics."""
    base = dict(model.physics or {})
    base.pop(effect, None)
    with_effect = dict(base, **{effect: {}})
    out = []
    for phys in (with_effect, base):
        key = kinematics.Physics.from_effects(phys)
        if key not in case.cache:
            traj = trajectory(case)
            dth, dv = kinematics.increments(traj, case.sim_t_abs, case.dt, key)
            case.cache[key] = np.column_stack([dth, dv]) / case.dt
            for mask in (case.masked, case.unstated):
                if mask is not None:
                    case.cache[key][mask] = 0.0
        out.append(case.cache[key])
    return out[0] - out[1]


def effective_model(model: SensorModel) -> SensorModel:
    """The model with its physics overrides applied to the triads (what the simulator uses)."""
    return effects.apply_model_overrides(model)


def scenario_path_base(path) -> Path:
    """The folder relative paths in a scenario resolve against."""
    return Path(path).resolve().parent
