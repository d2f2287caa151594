"""Typed node status (nav_core.status.NodeStatus): every node with /diagnostics writes a dataclass that the report
reads back through the same type; a key is spelled once, in the dataclass."""
import dataclasses
from pathlib import Path

import pytest

from imu_calib.status import AllanStatus
from imu_driver.status import DriverStatus
from ins_gps_kf.status import FilterStatus
from nav_bringup import report
from nav_bringup.status import ScenarioStatus
from wmra_filter.status import WmraStatus


def _filled(cls):
    """An instance with every scalar field set away from its default."""
    kwargs = {"level": "WARN", "message": "m"}
    for k, f in enumerate(dataclasses.fields(cls)):
        if f.name in kwargs or f.default is dataclasses.MISSING:
            continue
        d = f.default
        kwargs[f.name] = (not d if isinstance(d, bool) else d + k + 1 if isinstance(d, int)
                          else 0.25 * (k + 1) if isinstance(d, float) or d is None else f"text {k}")
    return cls(**kwargs)


@pytest.mark.parametrize("cls", [DriverStatus, WmraStatus, ScenarioStatus, FilterStatus, AllanStatus])
def test_a_status_round_trips_through_its_diagnostics_strings(cls):
    st = _filled(cls)
    values = st.to_values()
    assert all(isinstance(v, str) for v in values.values()) and "level" not in values
    assert cls.from_values(values, st.level, st.message) == st
    assert set(cls.SUMMARY) <= set(values)


def test_the_report_reads_each_node_s_status_through_its_type():
    for node, cls in report.STATUS_TYPES.items():
        st = _filled(cls)
        parsed = report.node_status(f"{node}: x", 1, "m", st.to_values())
        assert type(parsed) is cls and parsed == dataclasses.replace(st, level="WARN")
    assert report.node_status("bag_record: x", 0, "ok", {}) is None
    wmra = report.node_status("wmra_node: wmra", 1, "denoising", WmraStatus(nonfinite_samples=3).to_values())
    assert wmra.summary() == "restarts 0, nonfinite_samples 3"


def test_the_allan_node_s_result_fits_its_status(tmp_path):
    """Every key of the characterisation summary the worker sends has a field (AllanStatus.of refuses others)."""
    import numpy as np

    from imu_calib import characterise, synthetic
    from nav_core.sensor_model import load

    model = load(Path(__file__).resolve().parents[1] / "config" / "sensor_models" / "bp3010.yaml")
    rec = synthetic.static_recording(model, 30.0, np.random.default_rng(0))
    values = characterise.characterise_to_dir(rec, tmp_path, "imu/data_raw")
    st = AllanStatus.of("OK", "wrote", values)
    assert st.sensor_model_path.endswith("sensor_model.yaml") and st.gyro_x_white_noise > 0
    back = AllanStatus.from_values(st.to_values(), "OK", "wrote")  # floats written to 6 significant digits
    for f in dataclasses.fields(AllanStatus):
        a, b = getattr(back, f.name), getattr(st, f.name)
        assert (np.isclose(a, b, rtol=1e-5) if isinstance(b, float) else a == b), f.name
