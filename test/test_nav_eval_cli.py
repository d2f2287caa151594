"""``ins-gps-kf evaluate`` outputs: checked before the work, written under a temporary name and renamed into place,
so a failure half-way leaves ``--out`` as it was (issue 16, outputs)."""
import json

import pytest

from ins_gps_kf.replay import main
from nav_eval import paper_sim
from nav_eval.metrics import write_report


class HalfWay(RuntimeError):
    """The evaluation failing after it wrote part of its output."""


def _evaluation(fail: bool):
    """An evaluation that writes a report and a plot into its folder, then fails (``fail``) or returns figures."""
    calls = []

    def run(out_dir, seed=0, scenario=None):
        calls.append(out_dir)
        write_report(out_dir / "paper_sim.json", {"seed": seed})
        if fail:
            raise HalfWay("disk full")
        (out_dir / "paper_sim_clean.png").write_bytes(b"png")
        return {"seed": seed, "largest_error_m": 1.5}
    return run, calls


def _leftovers(parent, out):
    return sorted(p.name for p in parent.iterdir() if p.name != out.name)


def test_evaluate_writes_through_a_temporary_folder_renamed_into_place(tmp_path, monkeypatch, capsys):
    run, calls = _evaluation(fail=False)
    monkeypatch.setattr(paper_sim, "paper_sim", run)
    out = tmp_path / "eval"
    assert main(["evaluate", "--dataset", "paper-sim", "--out", str(out), "--seed", "3"]) == 0
    assert calls and calls[0] != out and calls[0].parent == tmp_path  # written next to --out, elsewhere
    assert sorted(p.name for p in out.iterdir()) == ["paper_sim.json", "paper_sim_clean.png"]
    assert json.loads((out / "paper_sim.json").read_text()) == {"seed": 3}
    assert json.loads(capsys.readouterr().out)["largest_error_m"] == 1.5
    assert _leftovers(tmp_path, out) == []


@pytest.mark.parametrize("existing", [False, True], ids=["new_out", "forced_over_an_old_out"])
def test_an_evaluation_failing_half_way_leaves_no_half_written_output(tmp_path, monkeypatch, existing):
    run, calls = _evaluation(fail=True)
    monkeypatch.setattr(paper_sim, "paper_sim", run)
    out = tmp_path / "eval"
    if existing:
        out.mkdir()
        (out / "paper_sim.json").write_text("old run")
    args = ["evaluate", "--dataset", "paper-sim", "--out", str(out)] + (["--force"] if existing else [])
    with pytest.raises(HalfWay):
        main(["--debug", *args])  # --debug: the error itself, not its one-line form
    assert calls  # it got half-way
    if existing:  # the old output is untouched
        assert [p.name for p in out.iterdir()] == ["paper_sim.json"]
        assert (out / "paper_sim.json").read_text() == "old run"
    else:
        assert not out.exists()
    assert _leftovers(tmp_path, out) == []  # no temporary folder left behind
    assert main(args) == 1  # without --debug: one line, exit 1 (a failure that is not the user's)


def test_an_existing_output_is_refused_before_the_work_without_force(tmp_path, monkeypatch, capsys):
    run, calls = _evaluation(fail=False)
    monkeypatch.setattr(paper_sim, "paper_sim", run)
    out = tmp_path / "eval"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    assert main(["evaluate", "--dataset", "paper-sim", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--force" in err and str(out) in err and "Traceback" not in err
    assert not calls and [p.name for p in out.iterdir()] == ["mine.txt"]
    assert main(["evaluate", "--dataset", "paper-sim", "--out", str(out), "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["paper_sim.json", "paper_sim_clean.png"]
    assert _leftovers(tmp_path, out) == []
