"""Output paths of the command-line tools: checked before any computation, written whole or not at all.

Every CLI that takes ``--out`` uses this module, so they all behave alike:

* an ``--out`` that is a file where a folder is wanted (or the reverse), that cannot be
  created or written, or an existing non-empty folder or existing file, is refused with
  :class:`OutputError` *before* the computation starts (``--force`` allows replacing);
* results are written under a temporary name next to the target and renamed into place
  when everything was written (:func:`staged_dir`, :func:`staged_file`), so a failure
  half-way never leaves a folder that mixes two runs, and a replaced output is only
  removed once its replacement is complete.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path


class OutputError(ValueError):
    """An output path cannot be used; the message names it and says what to do."""


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists():
        if p.parent == p:
            break
        p = p.parent
    return p


def check_writable(folder) -> Path:
    """Raise OutputError unless ``folder`` (or, when missing, its nearest existing parent) is a writable folder."""
    folder = Path(folder)
    base = _nearest_existing(folder.absolute())
    if not base.is_dir():
        raise OutputError(f"{folder}: cannot create it, {base} is a file")
    try:  # os.access is not enough (read-only mounts, ACLs): try a real file
        fd, probe = tempfile.mkstemp(prefix=".write-test-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise OutputError(f"{folder}: cannot write in {base}: {err.strerror or err}") from None
    return folder


def check_out_dir(path, force: bool = False, allow_existing: bool = False, inputs=()) -> Path:
    """Check an output folder before computing: not a file, writable, and new or empty unless ``force``.

    ``allow_existing`` accepts a non-empty folder that the tool adds new entries to (a run cache).
    ``force`` replaces the whole folder, so it is refused for a folder holding the current directory,
    the home folder or one of ``inputs`` (paths the command reads).
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{path}: exists and is not a folder; give a folder for --out")
    if path.is_dir() and not (force or allow_existing) and any(path.iterdir()):
        raise OutputError(f"{path}: folder exists and is not empty; choose a new --out or pass --force to replace it")
    if force and path.is_dir() and not allow_existing:
        _check_replaceable(path, inputs)
    return check_writable(path)


def _check_replaceable(path: Path, inputs) -> None:
    """Refuse to replace a folder that holds what must not go with it."""
    target = path.resolve()
    protected = [(Path.cwd(), "the current folder"), (Path.home(), "the home folder")]
    protected += [(Path(p), str(p)) for p in inputs if p is not None]
    for other, name in protected:
        other = Path(other).resolve()
        if other == target or target in other.parents:
            raise OutputError(f"{path}: --force would replace this folder, which holds {name}; choose another --out")


def check_out_file(path, force: bool = False, update: bool = False) -> Path:
    """Check an output file before computing: not a folder, parent writable, new unless ``force`` (or ``update``)."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; give a file name for --out")
    if path.exists() and not (force or update):
        raise OutputError(f"{path}: exists; choose a new --out or pass --force to overwrite it")
    check_writable(path.parent)
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputError(f"{path}: exists and is not writable")
    return path


@contextmanager
def staged_dir(path, force: bool = False, inputs=()):
    """Yield a temporary folder next to ``path``; on success it replaces ``path`` (renamed into place).

    On an exception the temporary folder is removed and ``path`` is left as it was.
    """
    path = Path(path)
    check_out_dir(path, force, inputs=inputs)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-", dir=path.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    _replace_dir(tmp, path)


def _replace_dir(tmp: Path, path: Path) -> None:
    if not path.exists():
        os.rename(tmp, path)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-", dir=path.parent))
    os.rename(path, old / path.name)  # the old output goes only once the new one is in place
    try:
        os.rename(tmp, path)
    except OSError:
        os.rename(old / path.name, path)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextmanager
def staged_file(path, force: bool = False, update: bool = False):
    """Yield a temporary file name next to ``path`` (same suffix); on success it replaces ``path`` atomically."""
    path = Path(path)
    check_out_file(path, force, update)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.partial-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.partial-", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(name, path)
    except BaseException:
        Path(name).unlink(missing_ok=True)
        raise
    return path


def rebase(paths: dict, tmp, final) -> dict:
    """``paths`` (name -> path inside the staging folder ``tmp``) as paths inside ``final``."""
    tmp, final = Path(tmp), Path(final)
    return {k: final / Path(v).relative_to(tmp) if Path(v).is_relative_to(tmp) else Path(v)
            for k, v in paths.items()}
