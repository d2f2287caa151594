"""Typed node status (nav_core.status.NodeStatus): every node with /diagnostics writes a dataclass that the report
reads back through the same type; a key is spelled once, in the dataclass."""
import dataclasses

import pytest

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


@pytest.mark.parametrize("cls", [DriverStatus, WmraStatus, ScenarioStatus, FilterStatus])
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
    assert report.node_status("allan_node: allan characterisation", 0, "ok", {}) is None
    wmra = report.node_status("wmra_node: wmra", 1, "denoising", WmraStatus(nonfinite_samples=3).to_values())
    assert wmra.summary() == "restarts 0, nonfinite_samples 3"
