"""Where a tool finds the workspace's files (config/, the shared recordings) without source-tree paths.

The workspace is ``$MEMS_NAV_ROOT`` if set, else the current folder or the nearest parent holding
``config/navigation.yaml``: an installed package has no source tree to climb, so the workspace is
named, not guessed from ``__file__``. The public recordings are ``../shared/data`` beside it.
"""
from __future__ import annotations

import os
from pathlib import Path

ROOT_ENV = "MEMS_NAV_ROOT"
MARKER = "config/navigation.yaml"
PAPER_DRIVE = "config/scenarios/paper_drive.yaml"  # the built-in default scenario


class WorkspaceError(FileNotFoundError):
    """A workspace file was not found; the message says where it looked and how to name the workspace."""


def _bases() -> list[Path]:
    root = os.environ.get(ROOT_ENV)
    return [Path(root)] if root else [Path.cwd(), *Path.cwd().parents]


def _where() -> str:
    root = os.environ.get(ROOT_ENV)
    return f"${ROOT_ENV}={root}" if root else f"{Path.cwd()} or its parents"


def workspace_root() -> Path:
    """The workspace folder (see the module docstring); the current folder when none is found, so a default
    path built on it names the file the user then gets told is missing."""
    return next((b for b in _bases() if (b / MARKER).is_file()), Path(os.environ.get(ROOT_ENV) or Path.cwd()))


def workspace_file(relative: str) -> Path:
    """``relative`` (a path inside the workspace) under ``$MEMS_NAV_ROOT`` or the current folder or a parent;
    WorkspaceError naming where it looked when it is not there."""
    for base in _bases():
        if (base / relative).is_file():
            return base / relative
    raise WorkspaceError(f"{relative}: not found under {_where()}; run from the workspace or set {ROOT_ENV}")


def shared_data(relative: str = "") -> Path:
    """A path under the public recordings, ``../shared/data`` beside the workspace."""
    return workspace_root().parent / "shared" / "data" / relative
