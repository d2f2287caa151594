"""nav_core.imu_cdr: batch CDR Imu encoding equals rclpy's serialisation, decoding inverts both."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import Imu

from nav_core.imu_cdr import ImuCdrError, decode_imu, encode_imu, stamps_from_s
from nav_core.ros_node import imu_from_arrays

finite = st.floats(-1e6, 1e6, allow_nan=False)
frame_ids = st.text(st.characters(min_codepoint=33, max_codepoint=126), max_size=40)


def _message_fields(msg: Imu) -> tuple:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id,
            tuple(getattr(msg.orientation, k) for k in "xyzw"), tuple(msg.orientation_covariance),
            tuple(getattr(msg.angular_velocity, k) for k in "xyz"), tuple(msg.angular_velocity_covariance),
            tuple(getattr(msg.linear_acceleration, k) for k in "xyz"), tuple(msg.linear_acceleration_covariance))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 12), frame_id=frame_ids, seed=st.integers(0, 2**31), var=st.floats(0, 10))
def test_encoded_messages_deserialise_to_what_rclpy_would_build(n, frame_id, seed, var):
    rng = np.random.default_rng(seed)
    sec, nanosec = rng.integers(0, 2**31 - 1, n), rng.integers(0, 10**9, n)
    gyro, accel = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 10
    blobs = encode_imu(sec, nanosec, gyro, accel, frame_id, gyro_var=var, accel_var=2 * var)
    from builtin_interfaces.msg import Time
    for i, blob in enumerate(blobs):
        expected = imu_from_arrays(0.0, gyro[i], accel[i], frame_id, var, 2 * var,
                                   stamp=Time(sec=int(sec[i]), nanosec=int(nanosec[i])))
        assert len(blob) == len(serialize_message(expected))
        assert _message_fields(deserialize_message(blob, Imu)) == _message_fields(expected)


@settings(max_examples=60, deadline=None)
@given(rows=st.lists(st.tuples(st.integers(-2**31, 2**31 - 1), st.integers(0, 10**9 - 1), frame_ids,
                               st.lists(finite, min_size=6, max_size=6)), min_size=1, max_size=10))
def test_decode_inverts_rclpy_serialisation_for_any_frame_ids(rows):
    from builtin_interfaces.msg import Time
    msgs = [imu_from_arrays(0.0, v[:3], v[3:], fid, stamp=Time(sec=s, nanosec=ns)) for s, ns, fid, v in rows]
    batch = decode_imu([serialize_message(m) for m in msgs])
    assert batch.sec.tolist() == [r[0] for r in rows]
    assert batch.nanosec.tolist() == [r[1] for r in rows]
    assert batch.frame_ids == [r[2] for r in rows]
    np.testing.assert_array_equal(np.hstack([batch.gyro, batch.accel]), np.array([r[3] for r in rows]))


def test_orientation_and_per_axis_variances_are_carried():
    q = np.array([[0.1, 0.2, 0.3, 0.927]])
    cov = np.arange(9.0)[None] * 1e-4
    blob = encode_imu([5, 6], [7, 8], np.ones((2, 3)), np.ones((2, 3)), "base_link", gyro_var=[1.0, 2.0, 3.0],
                      accel_var=0.5, orientation_xyzw=np.vstack([q, q]), orientation_cov=np.vstack([cov, cov]))[1]
    msg = deserialize_message(blob, Imu)
    assert (msg.orientation.x, msg.orientation.w) == (0.1, 0.927)
    assert list(msg.orientation_covariance) == cov[0].tolist()
    assert list(msg.angular_velocity_covariance)[::4] == [1.0, 2.0, 3.0]
    assert list(msg.linear_acceleration_covariance)[::4] == [0.5, 0.5, 0.5]


def test_stamps_round_to_the_nanosecond_like_stamp_from_s():
    sec, nanosec = stamps_from_s([0.0, 1.5, 12.3456789014, 1e9 + 0.25])
    assert sec.tolist() == [0, 1, 12, 1_000_000_000]
    assert nanosec.tolist() == [0, 500_000_000, 345_678_901, 250_000_000]


@pytest.mark.parametrize("blob, words", [
    (b"\x00\x00\x00\x00" + bytes(320), "not little-endian CDR"),
    (b"\x00\x01\x00\x00" + bytes(8), "not little-endian CDR"),
    (encode_imu([1], [2], [[0, 0, 0]], [[0, 0, 0]])[0][:-8], "do not hold an Imu"),
])
def test_bad_bytes_raise_an_error_naming_the_message(blob, words):
    good = encode_imu([1], [2], [[0, 0, 0]], [[0, 0, 0]])[0]
    with pytest.raises(ImuCdrError, match=words) as err:
        decode_imu([good, good, blob])
    assert "message 2" in str(err.value)
