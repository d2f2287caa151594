"""Where an evaluation finds the workspace's files (scenario YAML) without source-tree paths.

``$MEMS_NAV_ROOT`` if set, else the current folder or the nearest parent holding the file:
an installed package has no source tree to climb, so the workspace is named, not guessed.
"""
from __future__ import annotations

import os
from pathlib import Path

from nav_core.recording import RecordingError

ROOT_ENV = "MEMS_NAV_ROOT"
PAPER_DRIVE = "config/scenarios/paper_drive.yaml"


def workspace_file(relative: str) -> Path:
    """``relative`` (a path inside the workspace) under ``$MEMS_NAV_ROOT`` or the current folder or a parent."""
    root = os.environ.get(ROOT_ENV)
    bases = [Path(root)] if root else [Path.cwd(), *Path.cwd().parents]
    for base in bases:
        if (base / relative).is_file():
            return base / relative
    where = f"${ROOT_ENV}={root}" if root else f"{Path.cwd()} or its parents"
    raise RecordingError(f"{relative}: not found under {where}; run from the workspace or set {ROOT_ENV}")
