"""nav_core.outputs: --out checked before the work; results appear whole or not at all; nothing else is touched."""
import pytest

from nav_core.outputs import (OutputError, atomic_write_text, check_out_dir, check_out_file, rebase, staged_dir,
                              staged_file)


def test_check_out_dir_refuses_a_file_a_non_empty_folder_and_an_unwritable_place(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputError, match="not a folder"):
        check_out_dir(tmp_path / "f")
    with pytest.raises(OutputError, match="is a file"):
        check_out_dir(tmp_path / "f" / "sub")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "a").write_text("x")
    with pytest.raises(OutputError, match="--force"):
        check_out_dir(tmp_path / "full")
    assert check_out_dir(tmp_path / "full", force=True) == tmp_path / "full"
    assert check_out_dir(tmp_path / "full", allow_existing=True) == tmp_path / "full"
    assert check_out_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # checking creates nothing
    with pytest.raises(OutputError, match="cannot write"):
        check_out_dir("/proc/nav_core_outputs_test")


def test_a_failure_while_writing_leaves_the_old_output_and_no_temporary_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(RuntimeError):
        with staged_dir(out, force=True) as tmp:
            (tmp / "new.txt").write_text("new")
            raise RuntimeError("failed half-way")
    assert [p.name for p in out.iterdir()] == ["old.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_staged_dir_replaces_the_old_output_whole_and_rebase_names_the_final_paths(tmp_path):
    out = tmp_path / "out"
    with staged_dir(out) as tmp:
        paths = {"a": tmp / "a.txt"}
        paths["a"].write_text("1")
    assert rebase(paths, tmp, out) == {"a": out / "a.txt"} and (out / "a.txt").read_text() == "1"
    with staged_dir(out, force=True) as tmp:
        (tmp / "b.txt").write_text("2")
    assert [p.name for p in out.iterdir()] == ["b.txt"]  # no mix of two runs
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_files_are_refused_when_present_and_written_atomically(tmp_path):
    path = tmp_path / "traj.csv"
    path.write_text("keep")
    with pytest.raises(OutputError, match="--force"):
        check_out_file(path)
    with pytest.raises(OutputError, match="is a folder"):
        check_out_file(tmp_path)
    assert check_out_file(path, update=True) == path
    with pytest.raises(ValueError):
        with staged_file(path, force=True) as tmp:
            assert tmp.suffix == ".csv"
            tmp.write_text("half")
            raise ValueError("boom")
    assert path.read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == ["traj.csv"]
    with staged_file(path, force=True) as tmp:
        tmp.write_text("new")
    assert path.read_text() == "new"
    atomic_write_text(tmp_path / "m.yaml", "a: 1\n")
    assert (tmp_path / "m.yaml").read_text() == "a: 1\n"


def test_force_never_replaces_a_folder_holding_an_input_or_the_current_folder(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "scenario.yaml").write_text("mine")
    with pytest.raises(OutputError, match="holds"):
        check_out_dir(out, force=True, inputs=[out / "scenario.yaml"])
    monkeypatch.chdir(out)
    with pytest.raises(OutputError, match="current folder"):
        check_out_dir(out, force=True)
    monkeypatch.chdir(tmp_path)
    assert check_out_dir(out, force=True, inputs=[tmp_path / "elsewhere.yaml"]) == out
    assert (out / "scenario.yaml").read_text() == "mine"
