"""Configs: every field validated at load; the error names the file, the field and what is allowed."""
from __future__ import annotations

import copy
import math

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from imu_sim import scenario as scenario_mod
from imu_sim.scenario import ScenarioError
from imu_sim.simulate import simulate
from ins_gps_kf import config as kfconfig
from nav_core import sensor_model
from nav_core.sensor_model import SensorModelError

GOOD = {"latitude_deg": 30.0, "longitude_deg": 1.0, "height_m": 5.0, "rate_hz": 64, "seed": 3,
        "segments": [{"type": "stand", "duration_s": 3}, {"type": "accelerate", "duration_s": 3, "speed_mps": 2},
                     {"type": "turn", "duration_s": 2, "angle_deg": 30}],
        "gps": {"rate_hz": 1, "sigma_m": [0.5, 0.5, 1.0], "status": 0, "outages": [[1, 2]]},
        "temperature": {"start_c": 20, "end_c": 30, "time_constant_s": 100}}


def _write(tmp_path, data, name="scenario.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _with(path_value):
    data = copy.deepcopy(GOOD)
    keys, value = path_value
    node = data
    for k in keys[:-1]:
        node = node[k]
    if value is _DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


_DELETE = object()


@pytest.mark.parametrize("change, words", [
    ((("segments", 1, "speed"), 3.0), ["segments[1]", "'speed'", "did you mean 'speed_mps'"]),
    ((("segments", 0, "speed_mps"), 3.0), ["segments[0]", "speed_mps", "another segment type"]),
    ((("segments", 0, "duration_s"), _DELETE), ["segments[0].duration_s", "required"]),
    ((("segments", 0, "duration_s"), -1), ["segments[0].duration_s", "> 0"]),
    ((("segments", 2, "type"), "trun"), ["segments[2].type", "did you mean 'turn'"]),
    ((("seed",), "abc"), ["seed", "integer >= 0", "'abc'"]),
    ((("seed",), -4), ["seed", "integer >= 0"]),
    ((("gps", "sigma_m"), math.nan), ["gps.sigma_m", "finite"]),
    ((("gps", "sigma_m"), [0.5, -1, 1]), ["gps.sigma_m", ">= 0"]),
    ((("gps", "status"), 7), ["gps.status", "[-1, 0, 1, 2]"]),
    ((("gps", "sigam_m"), 1.0), ["gps", "did you mean 'sigma_m'"]),
    ((("gps", "outages"), [[3, "x"]]), ["gps.outages[0]"]),
    ((("rate_hz",), 0), ["rate_hz", "> 0"]),
    ((("rate_hz",), 1e9), ["rate_hz", "10000"]),
    ((("rate_hz",), math.inf), ["rate_hz"]),
    ((("latitude_deg",), math.nan), ["latitude_deg", "[-90, 90]"]),
    ((("temperature", "end_c"), "hot"), ["temperature.end_c"]),
    ((("temperature", "tau"), 3), ["temperature", "unknown key"]),
    ((("speed",), 3), ["unknown key", "'speed'"]),
])
def test_bad_scenario_fields_are_named_with_file_field_and_range(tmp_path, change, words):
    path = _write(tmp_path, _with(change))
    with pytest.raises(ScenarioError) as err:
        scenario_mod.load(path)
    text = str(err.value)
    assert str(path) in text and "\n" not in text
    for w in words:
        assert w in text, (w, text)


def test_the_good_scenario_loads_and_simulates(tmp_path):
    res = simulate(_write(tmp_path, GOOD), with_bytes=False)
    assert len(res.imu) == 8 * 64 and res.seed == 3


def test_rate_and_sample_count_are_checked_before_any_work(tmp_path):
    path = _write(tmp_path, GOOD)
    for rate in (0.0, -5.0, math.nan, math.inf, 1e9):
        with pytest.raises(ScenarioError, match="rate_hz"):
            simulate(path, rate_hz=rate, with_bytes=False)
    long = _with((("segments", 0, "duration_s"), 80000))
    with pytest.raises(ScenarioError, match="IMU samples"):
        simulate(_write(tmp_path, dict(long, rate_hz=5000)), with_bytes=False)


_JUNK = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=True),
                  st.text(max_size=5), st.lists(st.floats(allow_nan=True), max_size=4),
                  st.dictionaries(st.text(max_size=4), st.integers(), max_size=2))


def _paths(data, prefix=()):
    if isinstance(data, dict):
        for k, v in data.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


SCENARIO_PATHS = list(_paths(GOOD))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.sampled_from(SCENARIO_PATHS), junk=_JUNK)
def test_fuzzed_scenario_fields_load_or_raise_scenario_error(tmp_path, where, junk):
    data = _with((where, junk))
    try:
        sc = scenario_mod.from_dict(data, where="fuzz.yaml")
    except ScenarioError as err:
        assert str(err).startswith("fuzz.yaml") and "\n" not in str(err)
        return
    assert 0 < sc.rate_hz <= scenario_mod.MAX_RATE_HZ and (sc.seed is None or sc.seed >= 0)
    assert all(math.isfinite(v) for v in sc.gps.sigma_m)


# -- sensor model ----------------------------------------------------------------------------------------


def _model_dict():
    return sensor_model.SensorModel().to_dict()


@pytest.mark.parametrize("change, words", [
    ((("gyro", "white_noise", "value"), [1e-3, math.nan, 1e-3]), ["gyro.white_noise.value", "finite"]),
    ((("gyro", "white_noise", "value"), [1e-3, -1e-3, 1e-3]), ["gyro.white_noise.value", ">= 0"]),
    ((("accel", "scale_factor", "value"), [0.0, -1.0, 0.0]), ["accel.scale_factor.value", "> -1"]),
    ((("gyro", "white_nosie"), {"value": [0, 0, 0]}), ["gyro", "did you mean 'white_noise'"]),
    ((("gyro", "bias", "valeu"), 1), ["gyro.bias", "unknown key"]),
    ((("sample_rate_hz",), math.inf), ["sample_rate_hz", "(0, 100000]"]),
    ((("sample_rate_hz",), True), ["sample_rate_hz"]),
    ((("sampel_rate_hz",), 64), ["did you mean 'sample_rate_hz'"]),
    ((("gyro", "bias", "interval_95"), [[0, 1]]), ["gyro.bias.interval_95", "shape"]),
])
def test_bad_sensor_model_fields_are_named(tmp_path, change, words):
    data = _model_dict()
    keys, value = change
    node = data
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    path = tmp_path / "model.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(SensorModelError) as err:
        sensor_model.load(path)
    text = str(err.value)
    assert str(path) in text
    for w in words:
        assert w in text, (w, text)


MODEL_PATHS = list(_paths(_model_dict()))


@settings(max_examples=150, deadline=None)
@given(where=st.sampled_from(MODEL_PATHS), junk=_JUNK)
def test_fuzzed_sensor_models_load_or_raise_sensor_model_error(where, junk):
    data = _model_dict()
    node = data
    for k in where[:-1]:
        node = node[k]
    node[where[-1]] = junk
    try:
        model = sensor_model.from_dict(data, where="fuzz.yaml")
    except SensorModelError as err:
        assert str(err).startswith("fuzz.yaml")
        return
    assert 0 < model.sample_rate_hz <= sensor_model.MAX_SAMPLE_RATE_HZ


def test_unreadable_yaml_is_one_line(tmp_path):
    path = tmp_path / "model.yaml"
    path.write_bytes(b"gyro: [\xff\xfe")
    with pytest.raises(SensorModelError, match="not valid YAML") as err:
        sensor_model.load(path)
    assert "\n" not in str(err.value)
    with pytest.raises(ScenarioError, match="not valid YAML"):
        scenario_mod.load(path)



@pytest.mark.parametrize("damage, words", [
    ("missing", "file not found"), ("folder", "is a folder, expected a"), ("binary", "not valid YAML")])
def test_every_yaml_reader_names_the_file_and_its_damage(tmp_path, damage, words):
    path = tmp_path / "in.yaml"
    if damage == "folder":
        path.mkdir()
    elif damage == "binary":
        path.write_bytes(b"a: [\xff\xfe")
    readers = [(sensor_model.load, SensorModelError), (scenario_mod.load, ScenarioError),
               (kfconfig.read_params_file, kfconfig.FilterConfigError)]
    for read, error in readers:
        with pytest.raises(error) as err:
            read(path)
        assert str(err.value).startswith(f"{path}: ") and words in str(err.value)
        assert "\n" not in str(err.value)

# -- params files -------------------------------------------------------------------------------------------


def _params(tmp_path, **values):
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump({"ins_gps_kf_node": {"ros__parameters": values}}))
    return path


@pytest.mark.parametrize("values, words", [
    ({"filter_rate_hz": math.nan}, ["filter_rate_hz", "[0.1, 100]"]),
    ({"filter_rate_hz": "fast"}, ["filter_rate_hz"]),
    ({"gps_rate_hz": -1.0}, ["gps_rate_hz"]),
    ({"alignment_mode": "sideways"}, ["alignment_mode", "one of"]),
    ({"filter_rate_hs": 2.0}, ["did you mean 'filter_rate_hz'"]),
])
def test_bad_params_file_values_are_named_at_load(tmp_path, values, words):
    path = _params(tmp_path, **values)
    with pytest.raises(kfconfig.FilterConfigError) as err:
        kfconfig.load_params_yaml(path)
    for w in [str(path)] + words:
        assert w in str(err.value), (w, str(err.value))


def test_nan_stays_allowed_where_it_means_unset(tmp_path):
    params = kfconfig.load_params_yaml(_params(tmp_path, datum_lat_deg=math.nan, filter_rate_hz=2))
    assert math.isnan(params["datum_lat_deg"]) and params["filter_rate_hz"] == 2.0
