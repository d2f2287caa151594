"""nav-demo's simulation cache: reused when fresh, replaced when stale, never deleting what nav-demo did not write."""
import os

import pytest

from nav_bringup import demo


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    scenario, model = tmp_path / "scenario.yaml", tmp_path / "model.yaml"
    scenario.write_text("trajectory: paper_drive\nduration_s: 1\n")
    model.write_text("{}\n")
    runs = []

    def fake_simulate(scenario, model, seed, out, duration_s=None, fmt="all"):
        out.mkdir(parents=True, exist_ok=True)
        (out / "bp3010.bin").write_bytes(b"\xa5" * 16)
        (out / "truth.csv").write_text(f"run {len(runs)}\n")
        (out / "bag").mkdir()
        (out / "bag" / "metadata.yaml").write_text("x\n")
        runs.append(out)

    monkeypatch.setattr(demo, "simulate_scenario", fake_simulate)
    return scenario, model, tmp_path / "out", runs


def _age(path, seconds):
    st = path.stat()
    os.utime(path, (st.st_atime - seconds, st.st_mtime - seconds))


def test_a_fresh_simulation_is_reused_and_a_stale_one_replaced_keeping_the_users_files(inputs):
    scenario, model, out, runs = inputs
    sim = demo.simulate_once(scenario, model, 1, out)
    assert (sim / "truth.csv").read_text() == "run 0\n" and (sim / demo.SIM_MARKER).is_file()
    assert demo.simulate_once(scenario, model, 1, out) == sim and len(runs) == 1  # cached
    (sim / "my_notes.txt").write_text("mine")
    _age(sim / "bp3010.bin", 100)  # older than the scenario: stale
    demo.simulate_once(scenario, model, 1, out)
    assert len(runs) == 2 and (sim / "truth.csv").read_text() == "run 1\n"
    assert (sim / "my_notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["sim_seed1"]  # no temporary folder left behind


def test_a_folder_nav_demo_did_not_write_is_refused_untouched(inputs):
    scenario, model, out, runs = inputs
    user = out / "sim_seed1"
    user.mkdir(parents=True)
    (user / "truth.csv").write_text("the user's own truth")
    with pytest.raises(demo.DemoError, match="not written by nav-demo"):
        demo.simulate_once(scenario, model, 1, out)
    assert (user / "truth.csv").read_text() == "the user's own truth" and not runs


def test_a_users_file_with_a_name_nav_demo_writes_is_not_overwritten(inputs):
    scenario, model, out, runs = inputs
    sim = demo.simulate_once(scenario, model, 1, out)
    (sim / demo.SIM_MARKER).write_text("bp3010.bin\n")  # as if truth.csv had been put there by the user
    _age(sim / "bp3010.bin", 100)
    with pytest.raises(demo.DemoError, match="not written by nav-demo"):
        demo.simulate_once(scenario, model, 1, out)
    assert (sim / "truth.csv").read_text() == "run 0\n" and (sim / "bp3010.bin").exists()  # nothing removed


def test_the_demo_exits_2_with_one_line_on_a_foreign_folder(inputs, capsys, monkeypatch):
    scenario, model, out, _ = inputs
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):  # main() sets them: restored after the test
        monkeypatch.setenv(key, os.environ.get(key, "0" if key == "ROS_DOMAIN_ID" else "LOCALHOST"))
    (out / "sim_seed1").mkdir(parents=True)
    (out / "sim_seed1" / "x").write_text("x")
    code = demo.main(["--scenario", str(scenario), "--model", str(model), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "sim_seed1" in err
