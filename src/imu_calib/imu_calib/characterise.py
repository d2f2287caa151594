"""Stochastic characterisation of a static recording: Allan deviation per axis, noise fit, sensor model.

The one pipeline behind ``imu-calib allan`` and ``allan_node``:
``characterise(rec) -> Characterisation``, then ``write_outputs(result, out_dir)``
writes ``sensor_model.yaml``, ``imu.yaml`` (Kalibr keys) and ``allan.png``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imu_calib.allan import AllanDeviation, AllanError, log_taus, octave_taus, overlapping_adev, psd
from imu_calib import model_io, screen
from imu_calib.noise_fit import SCHEMA_NAMES, TERMS, fit_noise
from imu_calib.timeline import timeline
from nav_core import sensor_model
from nav_core.recording import ImuRecording

AXIS_NAMES = ("x", "y", "z")
MIN_CLUSTER_TIMES = 6
"""A fit needs at least this many cluster times (13 samples on an octave grid give 6)."""


@dataclass
class Characterisation:
    """Allan deviations and fits per triad and axis, the resulting sensor model."""

    adev: dict
    """Triad -> AllanDeviation with (k, 3) arrays."""
    fits: dict
    """Triad -> list of 3 NoiseFit."""
    model: sensor_model.SensorModel
    white_psd: dict
    """Triad -> (3,) white-noise level from the Welch PSD (unit*sqrt(s))."""
    timeline: dict | None = None
    """What was skipped when the recording was split at its breaks (None: the whole record was used)."""


def grid(n_samples: int, rate_hz: float, per_decade: int | None = None) -> np.ndarray:
    """Cluster times, s: octave grid, or ``per_decade`` log-spaced points per decade."""
    taus = octave_taus(n_samples, rate_hz) if not per_decade else log_taus(n_samples, rate_hz, per_decade)
    if len(taus) < MIN_CLUSTER_TIMES:
        raise AllanError(f"recording too short: {n_samples} samples ({n_samples / rate_hz:.4g} s at "
                         f"{rate_hz:g} Hz) give only {len(taus)} cluster times; the noise fit needs at least "
                         f"{MIN_CLUSTER_TIMES} (at least {2 ** MIN_CLUSTER_TIMES} samples)")
    return taus


def check_uniform(rec: ImuRecording, tolerance: float = 0.05) -> float:
    """Sample rate (Hz) of ``rec``; AllanError naming the source if its record is broken (see :func:`unbroken`)."""
    line = timeline(rec)
    if line.broken:
        raise AllanError(line.describe(rec) + SPLIT_HINT)
    return line.rate_hz


SPLIT_HINT = ("; the Allan variance needs one unbroken record: fix the recording, or analyse the longest unbroken "
              "segment with --split-at-gaps (allan_node: split_at_gaps)")


def unbroken(rec: ImuRecording, split: bool = False) -> tuple:
    """(recording, rate Hz, time-line report or None): ``rec`` itself if its time line is unbroken and has no
    exact duplicate rows; without breaks, ``rec`` less its exact duplicates and a report of them; with
    ``split`` its longest unbroken segment and what was skipped; else AllanError naming the first breaks.

    Breaks: time going back, a stamp repeated with different values, a gap, a NaN or infinite sample.
    """
    line = timeline(rec)
    dup = screen.describe_duplicates(rec, line.duplicates) if line.duplicates.any() else None
    if not line.broken:
        if dup is None:
            return rec, line.rate_hz, None
        whole = (0, len(rec))
        report = line.report(whole, rec)
        report["warning"] = dup
        return line.select(rec, whole), line.rate_hz, report
    if not split:
        raise AllanError(line.describe(rec) + SPLIT_HINT)
    used = line.longest()
    report = line.report(used, rec)
    report["warning"] = line.describe(rec) + \
        f"; analysed the longest unbroken segment only ({line.size(used)} of {len(rec)} samples, " \
        f"from sample {used[0]})" + (f" | {dup}" if dup else "")
    return line.select(rec, used), line.rate_hz, report


def characterise(rec: ImuRecording, per_decade: int | None = None, taus=None, progress=None,
                 base_model: sensor_model.SensorModel | None = None, split: bool = False) -> Characterisation:
    """Allan deviation (overlapping) and five-term fit of the six axes of a static recording.

    ``progress`` is called with a short label after each of the six axes (for tqdm).
    ``base_model`` keeps its deterministic terms (bias, scale, misalignment).
    A break (a stamp going back or repeated with other values, a gap, a NaN or infinite sample) is an
    AllanError; with ``split`` the longest unbroken segment is analysed and the provenance's ``timeline``
    records what was skipped (``Characterisation.timeline``); exact duplicate rows are dropped and counted there.
    """
    n_total = len(rec)
    rec, rate, line = unbroken(rec, split)
    taus = grid(len(rec), rate, per_decade) if taus is None else np.asarray(taus, float)
    model = base_model.copy() if base_model is not None else sensor_model.SensorModel()
    model.sample_rate_hz = rate
    adevs, fits, white = {}, {}, {}
    for triad in ("gyro", "accel"):
        data = getattr(rec, triad)
        per_axis = []
        for i in range(3):
            per_axis.append(overlapping_adev(data[:, i], rate, taus))
            if progress:
                progress(f"{triad} {AXIS_NAMES[i]}")
        adevs[triad] = _stack(per_axis)
        fits[triad] = [fit_noise(a, samples=data[:, i]) for i, a in enumerate(per_axis)]
        white[triad] = psd(data, rate).white_noise
        _write_fits(model.triad(triad), fits[triad], white[triad])
    extra = {} if line is None else {"timeline": line, "n_samples_in_file": n_total}
    if rec.damage:  # rows the reader skipped (bad cells, a cut last row): part of what was not analysed
        extra["read_damage"] = rec.damage
    sensor_model.stamp_provenance(model, "imu_calib allan", rec.source or "<memory>",
                                  n_samples=len(rec), duration_s=float(len(rec) / rate), **extra,
                                  estimator="overlapping Allan variance, 5-term IRLS WLS fit and term selection, "
                                            "maximum likelihood (exact, sine basis of the differences) where "
                                            "the model fits")
    return Characterisation(adevs, fits, model, white, line)


def _stack(per_axis) -> AllanDeviation:
    a = per_axis[0]
    col = (lambda name: np.column_stack([getattr(p, name) for p in per_axis]))
    return AllanDeviation(a.taus, col("adev"), col("lo"), col("hi"), col("edf"), a.n_samples, a.rate_hz,
                          a.confidence, a.overlapping)


def _write_fits(triad, fits, white_psd) -> None:
    """Copy fitted terms and intervals of three axes into a TriadModel.

    A term the record did not identify is written as its 95 % upper bound with ``identifiable: false``
    (never a bare 0, which consumers such as Kalibr would read as "no such noise").
    """
    for term in TERMS:
        name = SCHEMA_NAMES[term]
        setattr(triad, name, np.array([f.reported_value(term) for f in fits]))
        triad.intervals[name] = np.array([f.intervals[term] for f in fits])
        triad.identifiable[name] = np.array([f.identifiable(term) for f in fits])
    triad.bias_correlation_time = np.array([f.bias_correlation_time for f in fits])
    triad.intervals.pop("bias_correlation_time", None)
    triad.info["noise_fit"] = {AXIS_NAMES[i]: f.summary() for i, f in enumerate(fits)}
    triad.info["fit_quality"] = {AXIS_NAMES[i]: f.fit_quality.get("verdict", "good") for i, f in enumerate(fits)}
    triad.info["psd_white_noise"] = [float(v) for v in white_psd]


def write_outputs(result: Characterisation, out_dir, rostopic: str = "/imu/data_raw") -> dict:
    """Write ``sensor_model.yaml``, ``imu.yaml`` (Kalibr) and ``allan.png`` into ``out_dir``; return the paths."""
    from imu_calib.plots import plot_allan

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"sensor_model": sensor_model.save(result.model, out / "sensor_model.yaml"),
             "kalibr": model_io.save_kalibr(result.model, out / "imu.yaml", rostopic),
             "plot": plot_allan(result, out / "allan.png")}
    return paths


def warnings_of(result: Characterisation) -> list:
    """One line per axis whose fit is poor and per Kalibr key written as an upper bound."""
    out = []
    for triad in ("gyro", "accel"):
        for i, fit in enumerate(result.fits[triad]):
            if fit.fit_quality.get("verdict") == "poor":
                out.append(f"{triad} {AXIS_NAMES[i]}: {fit.fit_quality['note']}")
    out += model_io.kalibr_warnings(result.model)
    if result.timeline is not None:
        out[:0] = result.timeline["warning"].split(" | ")
    return out


def characterise_to_dir(source, out_dir, topic: str = "imu/data_raw", per_decade: int | None = None,
                        split: bool = True) -> dict:
    """Read ``source`` (an ImuRecording, or a bag/CSV path read on ``topic``), characterise it, write
    ``out_dir``; return the summary a node reports (samples, duration, paths, white noise, warnings)."""
    read_notes = []
    if isinstance(source, ImuRecording):
        rec = source
    else:
        from nav_core.bagio import is_bag

        # the node's topic parameter is also its live topic: with a CSV it is simply not used
        rec, read_notes = screen.read(source, topic=topic if is_bag(source) else None)
    result = characterise(rec, per_decade=per_decade, split=split)
    paths = write_outputs(result, out_dir, rostopic="/" + topic.lstrip("/"))
    prov = result.model.provenance
    values = {"samples": prov["n_samples"], "duration_s": prov["duration_s"],
              **{f"{k}_path": str(v) for k, v in paths.items()}}
    if result.timeline is not None:
        values["skipped_samples"] = result.timeline["skipped_samples"]
        values["non_finite_samples"] = result.timeline["non_finite_samples"]
        values["exact_duplicates_dropped"] = result.timeline["exact_duplicates_dropped"]
    for triad in ("gyro", "accel"):
        for i, n in enumerate(result.model.triad(triad).white_noise):
            values[f"{triad}_{AXIS_NAMES[i]}_white_noise"] = float(n)
    warnings = read_notes + warnings_of(result)
    if warnings:
        values["warnings"] = " | ".join(warnings)
    return values


def worker(conn, go, source, out_dir, topic, per_decade, split) -> None:
    """Process target: wait for ``go`` (the parent lowers this process's priority first), run
    :func:`characterise_to_dir`, send ``("OK", values)`` or ``("ERROR", message)`` through ``conn``."""
    go.wait(timeout=30.0)
    try:
        conn.send(("OK", characterise_to_dir(source, out_dir, topic, per_decade, split)))
    except (AllanError, ValueError) as err:  # RecordingError, SensorModelError, KalibrError are ValueErrors
        conn.send(("ERROR", str(err)))
    except Exception as err:  # noqa: BLE001 - the node must hear about any failure, not wait for ever
        conn.send(("ERROR", f"{type(err).__name__}: {err}"))
    finally:
        conn.close()
