"""REP-105 transform tree without ROS: map -> odom carries every correction, odom -> base_link stays continuous."""
import numpy as np
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from nav_core.tf_tree import OdomChain, Pose, static_mounts

finite = st.floats(-1e4, 1e4, allow_nan=False)
poses = st.builds(lambda p, q: Pose.from_xyzw(p, q),
                  st.lists(finite, min_size=3, max_size=3),
                  st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1))


def _close(a: Pose, b: Pose, tol=1e-6):
    return np.allclose(a.position, b.position, atol=tol * (1 + np.abs(b.position).max())) and \
        (a.rotation.inv() * b.rotation).magnitude() < tol


@given(a=poses, b=poses)
def test_compose_with_inverse_is_identity_and_between_recovers_the_motion(a, b):
    assert _close(a.compose(a.inverse()), Pose.identity())
    assert _close(a.compose(a.between(b)), b)


@settings(max_examples=50)
@given(start=poses, steps=st.lists(st.tuples(poses, poses), min_size=1, max_size=8),
       segments=st.lists(st.integers(0, 1), min_size=8, max_size=8))
def test_map_odom_times_odom_base_is_the_filter_pose_at_every_epoch(start, steps, segments):
    chain = OdomChain()
    chain.update(0.0, start, None, 0)
    for k, ((pose, predicted), seg) in enumerate(zip(steps, segments)):
        out = chain.update(0.5 * (k + 1), pose, predicted, seg)
        assert _close(out.map_odom.compose(out.odom_base), pose)


def _drive(n, rng):
    """A smooth 2 Hz path: the INS prediction of each epoch, and the filter's pose = prediction + correction."""
    yaw = np.cumsum(rng.normal(0, 0.05, n))
    pos = np.cumsum(np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(n)]) * 5.0, axis=0)
    return [Pose(p, Rotation.from_euler("z", y)) for p, y in zip(pos, yaw)]


def test_odom_moves_only_by_the_prediction_and_map_odom_takes_the_corrections():
    rng = np.random.default_rng(3)
    truth = _drive(40, rng)
    chain = OdomChain()
    filtered = truth[0]
    chain.update(0.0, filtered, None)
    odom_prev = Pose.identity()
    for k in range(1, len(truth)):
        predicted = filtered.compose(truth[k - 1].between(truth[k]))  # the INS carries the true motion on
        jump = Pose(np.r_[rng.normal(0, 0.3, 2), 0.0] if k != 20 else np.array([40.0, -25.0, 0.0]),
                    Rotation.from_euler("z", rng.normal(0, 0.01) if k != 20 else 0.8))
        filtered = jump.compose(predicted)  # the update moves the pose, at k = 20 by 47 m and 46 deg
        out = chain.update(0.5 * k, filtered, predicted)
        if k > 1:
            step = odom_prev.between(out.odom_base)
            assert _close(step, truth[k - 1].between(truth[k]), 1e-9)  # exactly the predicted motion
        odom_prev = out.odom_base
        assert _close(out.map_odom.compose(out.odom_base), filtered)
    assert np.linalg.norm(out.map_odom.position) > 40.0  # the big jump sits in map -> odom, not in odom


def test_without_corrections_odom_stays_on_map():
    truth = _drive(10, np.random.default_rng(1))
    chain = OdomChain()
    for k, pose in enumerate(truth):
        out = chain.update(0.5 * k, pose, pose if k else None)
        assert _close(out.map_odom, Pose.identity(), 1e-9) and _close(out.odom_base, pose, 1e-9)


def test_a_filter_restart_or_a_time_jump_holds_odom_still_and_map_odom_takes_the_jump():
    a, b = Pose(np.array([1.0, 2.0, 0.0]), Rotation.identity()), Pose(np.array([500.0, 0, 0]), Rotation.from_euler("z", 1))
    chain = OdomChain()
    chain.update(10.0, a, None, segment=0)
    restarted = chain.update(60.0, b, b, segment=1)  # new segment: the prediction belongs to another chain
    assert _close(restarted.odom_base, a) and _close(restarted.map_odom.compose(a), b)
    back = chain.update(5.0, a, a, segment=1)  # stamp went back (bag loop)
    assert _close(back.odom_base, a)


def test_static_mounts_put_the_gps_antenna_at_the_lever_arm():
    mounts = {child: (parent, pose) for parent, child, pose in static_mounts([0.5, -0.2, 1.1])}
    parent, gps = mounts["gps_link"]
    assert parent == "base_link" and np.allclose(gps.position, [0.5, -0.2, 1.1]) and gps.rotation.magnitude() == 0
    assert _close(mounts["imu_link"][1], Pose.identity())
    body = Pose(np.array([10.0, 20.0, 0.0]), Rotation.from_euler("z", np.pi / 2))  # heading north
    assert np.allclose(body.compose(gps).position, [10.2, 20.5, 1.1])  # antenna: 0.5 m north, 0.2 m east


def test_odom_is_gravity_aligned_so_map_odom_is_a_planar_transform():
    """Height, roll and pitch of odom -> base_link are the filter's: map -> odom has no z, roll or pitch."""
    rng = np.random.default_rng(5)
    chain = OdomChain()
    pose = Pose(np.zeros(3), Rotation.identity())
    for k in range(30):
        tilt = Rotation.from_euler("ZYX", [0.1 * k, rng.normal(0, 0.05), rng.normal(0, 0.05)])
        predicted = Pose(pose.position + [5.0, 1.0, rng.normal(0, 0.5)], tilt)
        pose = Pose(predicted.position + rng.normal(0, 0.5, 3), tilt * Rotation.from_rotvec(rng.normal(0, 0.02, 3)))
        out = chain.update(0.5 * k, pose, predicted if k else None)
        assert abs(out.map_odom.position[2]) < 1e-9 and out.odom_base.position[2] == pose.position[2]
        roll, pitch, _ = out.map_odom.rotation.as_euler("ZYX")[::-1]
        assert abs(roll) < 1e-9 and abs(pitch) < 1e-9
        assert _close(out.map_odom.compose(out.odom_base), pose)
