"""wmra_node's stream on damaged input, without ROS: a NaN/Inf sample or stamp is dropped and counted, never let
into the wavelet window (where one NaN spoiled 91 denoised samples, 1.4 s at 64 Hz, that the filter then dropped)."""
import numpy as np
import pytest

from wmra_filter.stream_policy import StreamPolicy
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import WmraConfig

FS = 64.0


def _policy():
    return StreamPolicy(StreamingWmra(WmraConfig.for_bandwidth(FS, hop=4), 6, sample_sigma=np.full(6, 0.01)),
                        FS, 1.5, 4)


def _run(t, x, batch):
    policy, out = _policy(), []
    for a in range(0, len(t), batch):
        released, restarts = policy.push(t[a:a + batch], x[a:a + batch], list(range(a, min(a + batch, len(t)))))
        assert restarts == []
        out += released
    return policy, out + policy.flush()


@pytest.mark.parametrize("where", ["gyro_nan", "accel_inf", "stamp_nan"])
@pytest.mark.parametrize("batch", [1, 50])
def test_a_non_finite_sample_is_dropped_counted_and_filled_like_a_lost_message(where, batch):
    n, k = 400, 200
    rng = np.random.default_rng(0)
    t, x = 100.0 + np.arange(n) / FS, np.cumsum(rng.normal(size=(n, 6)), axis=0) * 0.01
    _, clean = _run(t, x, batch)
    t_bad, x_bad = t.copy(), x.copy()
    {"gyro_nan": lambda: x_bad.__setitem__((k, 0), np.nan), "accel_inf": lambda: x_bad.__setitem__((k, 4), np.inf),
     "stamp_nan": lambda: t_bad.__setitem__(k, np.nan)}[where]()
    policy, got = _run(t_bad, x_bad, batch)
    published = {tag: v for tag, v in got if tag is not None}
    assert all(np.all(np.isfinite(v)) for v in published.values())  # was: 91 non-finite outputs
    assert set(published) == set(range(n)) - {k}  # every other sample published
    assert policy.stats.nonfinite == 1 and policy.stats.filled_samples == 1 and policy.stats.restarts == 0
    ref = dict((tag, v) for tag, v in clean)
    far = [tag for tag in published if abs(tag - k) > 64]  # beyond the filter's reach the output is the clean one
    np.testing.assert_allclose([published[j] for j in far], [ref[j] for j in far], rtol=0, atol=1e-12)


@pytest.mark.parametrize("case, words", [("missing", ["nofile.csv", "not found"]), ("empty", ["car.csv", "empty"]),
                                         ("seed", ["--seed", "-1"])])
def test_wmra_report_refuses_a_bad_car_csv_or_seed_before_any_simulated_run(tmp_path, monkeypatch, capsys, case,
                                                                            words):
    from wmra_filter import evaluation, report

    def forbidden(*args, **kwargs):
        raise AssertionError("simulated before checking the inputs")
    monkeypatch.setattr(evaluation, "rate_table_run", forbidden)
    (tmp_path / "car.csv").write_text("")
    argv = {"missing": ["--balzer", str(tmp_path / "nofile.csv")], "empty": ["--balzer", str(tmp_path / "car.csv")],
            "seed": ["--seed", "-1"]}[case]
    try:
        code = report.main(["--out", str(tmp_path / "out"), *argv])  # was: a missing --balzer skipped with a note
    except SystemExit as exit_:  # argparse's usage error
        code = exit_.code
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and not (tmp_path / "out").exists()
    line = err.strip().splitlines()[-1]
    for w in words:
        assert w in line, (w, line)
