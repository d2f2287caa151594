"""wmra_node's gap policy without ROS: fill a dropped sample, restart on a gap or a time jump, batching-free."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from wmra_filter.stream_policy import StreamPolicy
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import WmraConfig

FS = 64.0
HOP = 4


def _cfg():
    return WmraConfig.for_bandwidth(FS, hop=HOP)


def _policy(fill=4):
    cfg = _cfg()
    return StreamPolicy(StreamingWmra(cfg, 6, sample_sigma=np.full(6, 0.01)), FS, 1.5, fill)


def _samples(n, seed):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=(n, 6)), axis=0) * 0.01


def _stream(segments):
    """The core's own output: one stream, restarted between ``segments`` (lists of (tag, sample))."""
    stream = StreamingWmra(_cfg(), 6, sample_sigma=np.full(6, 0.01))
    out = []
    for i, seg in enumerate(segments):
        if i:
            out += stream.restart()
        for tag, sample in seg:
            out += stream.push(sample, tag)
    return out + stream.flush()


def _run(policy, t, x, batch):
    out, restarts = [], []
    for a in range(0, len(t), batch):
        released, why = policy.push(t[a:a + batch], x[a:a + batch], list(t[a:a + batch]))
        out += released
        restarts += why
    return out + policy.flush(), restarts


def _same(got, expected):
    assert [tag for tag, _ in got] == [tag for tag, _ in expected]
    np.testing.assert_allclose(np.array([v for _, v in got]), np.array([v for _, v in expected]), rtol=0, atol=1e-12)


@pytest.mark.parametrize("batch", [1, 7, 500])
def test_a_regular_stream_is_the_core_stream_whatever_the_batching(batch):
    t, x = 100.0 + np.arange(300) / FS, _samples(300, 1)
    policy = _policy()
    got, restarts = _run(policy, t, x, batch)
    _same(got, _stream([list(zip(t, x))]))
    assert restarts == [] and policy.stats.received == 300 and policy.stats.restarts == 0


@pytest.mark.parametrize("batch", [1, 50])
def test_a_dropped_sample_is_interpolated_and_not_published(batch):
    t, x = 100.0 + np.arange(200) / FS, _samples(200, 2)
    keep = np.arange(200) != 120
    policy = _policy()
    got, restarts = _run(policy, t[keep], x[keep], batch)
    filled = x.copy()
    filled[120] = 0.5 * (x[119] + x[121])
    expected = _stream([[(None if k == 120 else t[k], filled[k]) for k in range(200)]])
    _same([o for o in got if o[0] is not None], [o for o in expected if o[0] is not None])
    assert any(tag is None for tag, _ in got)  # the fill sample went through the window, tagged unpublishable
    assert restarts == [] and policy.stats.filled_samples == 1 and policy.stats.restarts == 0


@pytest.mark.parametrize("jump_s, kind", [(7.7, "gap"), (-5.0, "time jump"), (0.0, "time jump")])
def test_a_gap_or_a_time_jump_flushes_and_restarts_the_window(jump_s, kind):
    first, second = 100.0 + np.arange(150) / FS, 100.0 + 149 / FS + jump_s + np.arange(100) / FS
    if jump_s == 0.0:
        second = second - 1 / FS  # the first sample repeats the last stamp
    x1, x2 = _samples(150, 3), _samples(100, 4)
    policy = _policy()
    got, restarts = _run(policy, np.concatenate([first, second]), np.vstack([x1, x2]), 64)
    _same(got, _stream([list(zip(first, x1)), list(zip(second, x2))]))
    assert len(restarts) == 1 and restarts[0].startswith(kind)
    assert policy.stats.restarts == 1 and policy.stats.last_restart.startswith(kind)


def test_more_missing_samples_than_fill_gap_samples_restart_instead():
    t, x = 100.0 + np.arange(200) / FS, _samples(200, 5)
    keep = (np.arange(200) < 100) | (np.arange(200) >= 106)  # 6 missing, fill up to 4
    policy = _policy(fill=4)
    _, restarts = _run(policy, t[keep], x[keep], 32)
    assert policy.stats.restarts == 1 and policy.stats.filled_samples == 0 and "gap" in restarts[0]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(1, 60), min_size=1, max_size=12), st.sets(st.integers(1, 398), max_size=6))
def test_batching_never_changes_the_output(cuts, dropped):
    t, x = 100.0 + np.arange(400) / FS, _samples(400, 6)
    keep = np.array([k not in dropped for k in range(400)])
    t, x = t[keep], x[keep]
    one, _ = _run(_policy(), t, x, 1)
    edges = np.unique(np.clip(np.cumsum(cuts) * 7, 0, len(t)))
    policy, out = _policy(), []
    for a, b in zip(np.concatenate([[0], edges]), np.concatenate([edges, [len(t)]])):
        out += policy.push(t[a:b], x[a:b], list(t[a:b]))[0]
    _same(out + policy.flush(), one)
