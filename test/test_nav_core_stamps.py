"""Stamp conversions (nav_core.units: ns_from_s, sec_nanosec, s_from_sec_nanosec), the one home every reader,
writer and node uses: scalars and arrays give the same stamp, and a stamp survives the round trip."""
import numpy as np
from hypothesis import given, strategies as st

from nav_core import units
from nav_core.imu_cdr import stamps_from_s


@given(st.floats(min_value=0.0, max_value=2.0e9, allow_nan=False))
def test_a_stamp_round_trips_to_the_nanosecond_scalar_and_array_alike(t):
    ns = units.ns_from_s(t)
    sec, nanosec = units.sec_nanosec(ns)
    assert 0 <= nanosec < units.NS_PER_S and sec * units.NS_PER_S + nanosec == ns
    arr_sec, arr_nanosec = stamps_from_s(np.array([t]))
    assert (int(arr_sec[0]), int(arr_nanosec[0])) == (sec, nanosec)
    assert abs(units.s_from_sec_nanosec(sec, nanosec) - t) <= 1e-9 + abs(t) * 1e-15
