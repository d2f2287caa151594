"""One rule for the workspace's files (nav_core.workspace): $MEMS_NAV_ROOT, else the current folder or a parent
holding config/navigation.yaml; never a path climbed from a module's __file__."""
from pathlib import Path

import pytest

from nav_core import workspace

SRC = Path(__file__).resolve().parents[1] / "src"


def _ws(tmp_path):
    (tmp_path / "ws" / "config" / "scenarios").mkdir(parents=True)
    (tmp_path / "ws" / "config" / "navigation.yaml").write_text("{}\n")
    (tmp_path / "ws" / "config" / "scenarios" / "paper_drive.yaml").write_text("{}\n")
    return tmp_path / "ws"


def test_the_workspace_is_the_named_root_or_the_nearest_parent_holding_the_marker(tmp_path, monkeypatch):
    ws = _ws(tmp_path)
    monkeypatch.delenv(workspace.ROOT_ENV, raising=False)
    (ws / "deep" / "er").mkdir(parents=True)
    monkeypatch.chdir(ws / "deep" / "er")
    assert workspace.workspace_root() == ws
    assert workspace.workspace_file(workspace.PAPER_DRIVE) == ws / workspace.PAPER_DRIVE
    assert workspace.shared_data("balzer_car") == tmp_path / "shared" / "data" / "balzer_car"
    monkeypatch.chdir(tmp_path)
    with pytest.raises(workspace.WorkspaceError, match=workspace.ROOT_ENV):
        workspace.workspace_file(workspace.PAPER_DRIVE)
    monkeypatch.setenv(workspace.ROOT_ENV, str(ws))
    assert workspace.workspace_file(workspace.PAPER_DRIVE) == ws / workspace.PAPER_DRIVE


def test_no_module_climbs_its_own_path_to_the_workspace():
    found = [f"{p.relative_to(SRC)}" for p in SRC.rglob("*.py")
             if "parents[3]" in p.read_text() or "parents[2]" in p.read_text()]
    assert not found, found
