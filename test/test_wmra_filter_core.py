"""wmra_filter core: SWT pieces, support, thresholds, batch and streaming equality (no ROS)."""
import numpy as np
import pytest
import pywt
from hypothesis import given, settings, strategies as st

from nav_core.sensor_model import SensorModel, TriadModel
from wmra_filter import levels, thresholds as thr
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import (WmraConfig, WmraConfigError, calibrate, denoise, denoise_imu, denoise_span,
                              estimate_thresholds, iswt, model_sample_sigma)


def _walk(rng, n, k=6, noise=0.3):
    """A random-walk signal with white noise, (n, k)."""
    return np.cumsum(rng.normal(size=(n, k)), axis=0) * 0.1 + rng.normal(size=(n, k)) * noise


@settings(max_examples=20, deadline=None)
@given(level=st.integers(1, 5), blocks=st.integers(1, 6), seed=st.integers(0, 2**31))
def test_fast_iswt_equals_pywt_iswt(level, blocks, seed):
    rng = np.random.default_rng(seed)
    n = 2 ** level * blocks * 2
    coeffs = [rng.normal(size=(n, 2)) for _ in range(level + 1)]
    expected = np.stack([pywt.iswt([c[:, i] for c in coeffs], "db8") for i in range(2)], axis=1)
    np.testing.assert_allclose(iswt(coeffs, "db8"), expected, rtol=0, atol=1e-13)


def test_support_of_db8_is_fifteen_times_two_to_the_level_minus_one():
    for level in (1, 2, 3, 6):
        assert levels.support("db8", level) == (15 * (2 ** level - 1),) * 2


@settings(max_examples=15, deadline=None)
@given(level=st.integers(1, 3), where=st.integers(0, 7), seed=st.integers(0, 2**31))
def test_perturbation_reaches_outputs_only_within_support(level, where, seed):
    rng = np.random.default_rng(seed)
    cfg = WmraConfig(64.0, level)
    left, right = cfg.support
    x = _walk(rng, 512, k=1)
    p = 200 + where
    bumped = x.copy()
    bumped[p] += 3.0
    lam = np.full((level, 1), 0.5)
    changed = np.flatnonzero(np.abs(denoise_span(bumped, cfg, lam) - denoise_span(x, cfg, lam))[:, 0] > 0)
    assert changed.min() >= p - right and changed.max() <= p + left


@pytest.mark.parametrize("fs, bandwidth, level", [(64.0, 5.0, 2), (1000.0, 5.0, 6), (50.0, 5.0, 2),
                                                  (100.0, 2.0, 4)])
def test_level_for_bandwidth_keeps_the_band_in_the_approximation(fs, bandwidth, level):
    assert levels.level_for_bandwidth(fs, bandwidth) == level
    assert levels.approximation_band_hz(fs, level) >= bandwidth > levels.approximation_band_hz(fs, level + 1)


def test_level_for_bandwidth_rejects_a_band_above_a_quarter_of_the_rate():
    with pytest.raises(levels.LevelError, match="fs/4"):
        levels.level_for_bandwidth(64.0, 20.0)


def test_hard_soft_is_hard_then_soft_at_a_fraction_of_the_threshold():
    d = np.array([[-3.0], [-1.0], [0.5], [1.0], [2.5]])
    np.testing.assert_allclose(thr.shrink(d, [1.5], "hard_soft", 0.5), [[-2.25], [0], [0], [0], [1.75]])
    np.testing.assert_allclose(thr.shrink(d, [1.5], "hard_soft", 0.0), thr.shrink(d, [1.5], "hard"))
    np.testing.assert_allclose(thr.shrink(d, [1.5], "hard_soft", 1.0), thr.shrink(d, [1.5], "soft"))


@settings(max_examples=20, deadline=None)
@given(ratio=st.floats(0, 1), seed=st.integers(0, 2**31))
def test_hard_soft_equals_pywt_hard_then_pywt_soft(ratio, seed):
    rng = np.random.default_rng(seed)
    d, lam = rng.normal(size=(50, 3)), rng.uniform(0.1, 2, size=3)
    expected = pywt.threshold(pywt.threshold(d, lam, "hard"), ratio * lam + 1e-300, "soft")
    np.testing.assert_allclose(thr.shrink(d, lam, "hard_soft", ratio), expected, rtol=0, atol=1e-14)


def test_sample_calibrator_equals_batch_calibrate():
    from wmra_filter.wmra import Calibrator
    rng = np.random.default_rng(14)
    model = SensorModel(gyro=TriadModel(bias=rng.normal(size=3), scale_factor=rng.normal(size=3) * 0.01),
                        accel=TriadModel(bias=rng.normal(size=3)))
    g, a = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    np.testing.assert_allclose(np.array([Calibrator(model)(gi, ai) for gi, ai in zip(g, a)]),
                               calibrate(g, a, model), rtol=0, atol=1e-13)


def test_model_noise_sigma_matches_the_mad_estimate_on_white_noise():
    rng = np.random.default_rng(3)
    fs, density = 64.0, np.array([8.7e-4, 1.2e-3])
    sigma = thr.white_noise_sigma(density, fs)
    x = rng.normal(size=(40000, 2)) * sigma
    cfg = WmraConfig(fs, 3)
    from wmra_filter.wmra import swt_details
    np.testing.assert_allclose(thr.mad_level_sigmas(swt_details(x, cfg)),
                               thr.model_level_sigmas(sigma, "db8", 3), rtol=0.05)


def test_universal_threshold_removes_almost_all_pure_noise():
    rng = np.random.default_rng(4)
    cfg = WmraConfig(64.0, 2, mode="hard")
    x = rng.normal(size=(4096, 1))
    y = denoise(x, cfg, estimate_thresholds(cfg, [1.0]))
    assert np.std(y) < 0.5 * np.std(x)


def test_sure_threshold_minimises_the_risk_over_candidate_thresholds():
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.normal(size=900), rng.normal(size=100) + 6.0])
    t = thr.sure_threshold(x, 1.0)

    def risk(lam):
        return len(x) - 2 * np.sum(np.abs(x) <= lam) + np.sum(np.minimum(x ** 2, lam ** 2))
    grid = np.linspace(0.0, np.sqrt(2 * np.log(len(x))), 400)
    assert risk(t) <= min(risk(g) for g in grid) + 1e-9
    assert 0 < t < np.sqrt(2 * np.log(len(x)))


def test_calibrate_inverts_the_sensor_model():
    rng = np.random.default_rng(6)
    model = SensorModel(gyro=TriadModel(bias=np.array([0.01, -0.02, 0.0055]), scale_factor=np.array([0.01, 0, -0.007])),
                        accel=TriadModel(bias=np.array([0.1, 0, 0.133]), misalignment=np.array(
                            [[0, 1e-3, 0], [-1e-3, 0, 2e-3], [0, -2e-3, 0]])))
    gyro, accel = rng.normal(size=(50, 3)), rng.normal(size=(50, 3)) + [0, 0, 9.8]
    out = calibrate(model.gyro.apply(gyro), model.accel.apply(accel), model)
    np.testing.assert_allclose(out, np.hstack([gyro, accel]), atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(hop=st.integers(1, 40), extra=st.integers(0, 3), n=st.integers(1, 900), level=st.integers(1, 3),
       mode=st.sampled_from(thr.MODES), seed=st.integers(0, 2**31))
def test_streaming_equals_batch_sample_for_sample(hop, extra, n, level, mode, seed):
    rng = np.random.default_rng(seed)
    cfg = WmraConfig(64.0, level, hop=hop, mode=mode)
    cfg = cfg.with_(window=cfg.window_samples + extra * 2 ** level)
    x = _walk(rng, n)
    stream = StreamingWmra(cfg, 6, sample_sigma=np.full(6, 0.3))
    out = stream.push_many(x) + stream.flush()
    assert [tag for tag, _ in out] == list(range(n))
    np.testing.assert_allclose(np.array([v for _, v in out]), denoise(x, cfg, stream.thresholds),
                               rtol=0, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(hop=st.integers(1, 300), n=st.integers(1, 1500), cuts=st.lists(st.integers(0, 1500), max_size=8),
       mode=st.sampled_from(("model", "mad")), seed=st.integers(0, 2**31))
def test_pushing_blocks_equals_pushing_sample_by_sample(hop, n, cuts, mode, seed):
    x = _walk(np.random.default_rng(seed), n)
    cfg = WmraConfig(64.0, 2, hop=hop, noise=mode)
    one, blocks = StreamingWmra(cfg, 6, sample_sigma=np.full(6, 0.3)), StreamingWmra(cfg, 6, sample_sigma=np.full(6, 0.3))
    singles = [out for i in range(n) for out in one.push(x[i], tag=i)]
    edges = [0, *sorted(c for c in cuts if c < n), n]
    batched = [out for a, b in zip(edges, edges[1:]) for out in blocks.push_many(x[a:b], tags=range(a, b))]
    assert [tag for tag, _ in batched] == [tag for tag, _ in singles]
    if singles:
        np.testing.assert_array_equal(np.array([v for _, v in batched]), np.array([v for _, v in singles]))


def test_streaming_releases_one_output_per_input_at_the_fixed_delay():
    cfg = WmraConfig(64.0, 2, hop=8)
    stream = StreamingWmra(cfg, 1, sample_sigma=[0.1])
    released = [stream.push([float(i)], tag=i) for i in range(300)]
    delay = cfg.delay_samples
    assert delay == 45 + 8 - 1
    assert all(r == [] for r in released[:delay])
    assert all(len(r) == 1 and r[0][0] == i - delay for i, r in enumerate(released) if i >= delay)


def test_streaming_with_estimated_thresholds_freezes_them_and_equals_batch_with_them():
    rng = np.random.default_rng(7)
    cfg = WmraConfig(64.0, 2, hop=4, noise="mad", rule="sure")
    x = _walk(rng, 600)
    stream = StreamingWmra(cfg, 6)
    out = stream.push_many(x[:100])
    frozen = stream.thresholds.copy()
    out += stream.push_many(x[100:], tags=range(100, 600)) + stream.flush()
    np.testing.assert_array_equal(stream.thresholds, frozen)
    np.testing.assert_allclose(np.array([v for _, v in out]), denoise(x, cfg, frozen), rtol=0, atol=1e-12)


def test_streaming_restart_equals_batch_on_each_segment():
    rng = np.random.default_rng(8)
    cfg = WmraConfig(64.0, 2, hop=8)
    a, b = _walk(rng, 400), _walk(rng, 300) + 5.0
    lam = estimate_thresholds(cfg, np.full(6, 0.3))
    stream = StreamingWmra(cfg, 6, thresholds=lam)
    out = stream.push_many(a) + stream.restart() + stream.push_many(b, tags=range(400, 700)) + stream.flush()
    assert stream.restarts == 1
    np.testing.assert_allclose(np.array([v for _, v in out]),
                               np.vstack([denoise(a, cfg, lam), denoise(b, cfg, lam)]), rtol=0, atol=1e-12)


def test_batch_result_does_not_depend_on_the_block_size(monkeypatch):
    rng = np.random.default_rng(9)
    cfg = WmraConfig(64.0, 2)
    x = _walk(rng, 1000)
    lam = estimate_thresholds(cfg, np.full(6, 0.3))
    whole = denoise(x, cfg, lam)
    monkeypatch.setattr("wmra_filter.wmra.BLOCK", 97)
    np.testing.assert_allclose(denoise(x, cfg, lam), whole, rtol=0, atol=1e-12)


def test_denoise_imu_uses_the_white_noise_of_the_sensor_model():
    fs = 64.0
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, 8.7e-4)),
                        accel=TriadModel(white_noise=np.full(3, 1.2e-3)), sample_rate_hz=fs)
    cfg = WmraConfig(fs, 2)
    np.testing.assert_allclose(model_sample_sigma(model, fs)[[0, 3]], [8.7e-4 * 8, 1.2e-3 * 8])
    rng = np.random.default_rng(10)
    res = denoise_imu(rng.normal(size=(256, 3)), rng.normal(size=(256, 3)), model, cfg)
    np.testing.assert_allclose(res.thresholds, estimate_thresholds(cfg, model_sample_sigma(model, fs)))
    assert res.gyro.shape == res.accel.shape == (256, 3)


@pytest.mark.parametrize("changes, message", [({"wavelet": "db99"}, "wavelet"), ({"mode": "firm"}, "mode"),
                                              ({"window": 64}, "window"), ({"hop": 0}, "hop"),
                                              ({"soft_ratio": 2.0}, "soft_ratio")])
def test_bad_settings_raise_a_clear_error(changes, message):
    with pytest.raises(WmraConfigError, match=message):
        WmraConfig(64.0, 2).with_(**changes)


def test_nav_core_corrector_equals_triad_correct():
    from nav_core.sensor_model import corrector
    rng = np.random.default_rng(13)
    tri = TriadModel(bias=rng.normal(size=3), scale_factor=rng.normal(size=3) * 0.01,
                     misalignment=(rng.normal(size=(3, 3)) * 1e-3) * (1 - np.eye(3)))
    x = rng.normal(size=(20, 3))
    np.testing.assert_allclose(corrector(tri)(x), tri.correct(x), rtol=0, atol=1e-13)
    np.testing.assert_allclose(corrector(tri)(x[0]), tri.correct(x[0]), rtol=0, atol=1e-13)
