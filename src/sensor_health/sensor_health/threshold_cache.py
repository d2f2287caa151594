"""The monitor's Monte Carlo results cached on disk per sensor model: a node or CLI that starts again on the same
model reads its gates instead of spending ~6 s of CPU on them.

The key is a SHA-256 of the model's content (every number of its YAML but the provenance), the call's other
arguments, the source of this package and of ``nav_core`` (a change to any test or to the noise simulation is a new
key) and the numpy, scipy and numba versions (their random streams and kernels). The entry holds its own key and is
read back bit for bit (arrays in an ``.npz`` without pickle, scalars as JSON, whose floats round-trip exactly), so a
cached start gives the events of a computed one: CLI and node stay equal whatever each found in the cache. An entry
that cannot be read or whose key differs (truncated, edited, from another version) is recomputed and rewritten, with
a warning in the log; a cache directory that cannot be written costs only the time. Written atomically (a temporary
file renamed), so processes that start side by side never read half an entry.

Location: ``$SENSOR_HEALTH_CACHE_DIR``; else ``$XDG_CACHE_HOME/mems-nav/sensor_health`` (``~/.cache/...``);
``SENSOR_HEALTH_CACHE_DIR=off`` turns it off. No ROS.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import os
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from nav_core.sensor_model import SensorModel

LOG = logging.getLogger("sensor_health.threshold_cache")
ENV = "SENSOR_HEALTH_CACHE_DIR"
OFF = "off"
FORMAT = 1
"""Entry layout version (part of the key)."""


def cache_dir() -> Path | None:
    """Where entries live, or None when caching is off."""
    env = os.environ.get(ENV)
    if env is not None:
        return None if env.strip().lower() in (OFF, "") else Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mems-nav" / "sensor_health"


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """SHA-256 of the source of this package and nav_core, and of the numerical libraries' versions."""
    import numba
    import scipy
    import nav_core
    h = hashlib.sha256(f"{FORMAT} {np.__version__} {scipy.__version__} {numba.__version__}".encode())
    for pkg in (Path(__file__).parent, Path(nav_core.__file__).parent):
        for path in sorted(pkg.rglob("*.py")):
            h.update(path.name.encode() + path.read_bytes())
    return h.hexdigest()


def canonical(obj):
    """A repr-able canonical form of a key part: a model by its content (provenance left out), arrays by dtype,
    shape and bytes, dataclasses by field, floats by their exact repr."""
    if isinstance(obj, SensorModel):
        content = obj.to_dict()
        content.pop("provenance", None)
        return ("SensorModel", canonical(content))
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return (type(obj).__name__,) + tuple((f.name, canonical(getattr(obj, f.name)))
                                             for f in dataclasses.fields(obj))
    if isinstance(obj, np.ndarray):
        arr = np.ascontiguousarray(obj)
        return ("ndarray", arr.dtype.str, arr.shape, hashlib.sha256(arr.tobytes()).hexdigest())
    if isinstance(obj, dict):
        return tuple(sorted((str(k), canonical(v)) for k, v in obj.items()))
    if isinstance(obj, (list, tuple)):
        return tuple(canonical(v) for v in obj)
    if isinstance(obj, np.generic):
        return canonical(obj.item())
    return repr(obj)


def key_of(kind: str, parts) -> str:
    """The entry's key: kind, the parts' canonical form and the code version."""
    return hashlib.sha256(repr((kind, canonical(parts), code_version())).encode()).hexdigest()


def _encode(value) -> dict:
    """Arrays (name -> ndarray) for an .npz: a dataclass's array fields as they are, the rest as JSON."""
    if dataclasses.is_dataclass(value):
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    else:
        fields = {"__value__": value}
    arrays = {f"a_{k}": v for k, v in fields.items() if isinstance(v, np.ndarray)}
    rest = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in fields.items()
            if not isinstance(v, np.ndarray)}
    numpy_scalars = {k: v.dtype.str for k, v in fields.items() if isinstance(v, np.generic)}
    arrays["__json__"] = np.array(json.dumps({"fields": rest, "numpy_scalars": numpy_scalars}))
    return arrays


def _decode(data, cls):
    stored = json.loads(str(data["__json__"]))
    fields = stored["fields"]
    for k, dtype in stored["numpy_scalars"].items():  # a numpy scalar comes back as one, not as a float
        fields[k] = np.dtype(dtype).type(fields[k])
    fields.update({k[2:]: data[k] for k in data.files if k.startswith("a_")})
    return cls(**fields) if cls is not None else fields["__value__"]


def _read(path: Path, key: str, cls):
    with np.load(path, allow_pickle=False) as data:
        if str(data["__key__"]) != key:
            raise ValueError("its key differs")
        return _decode(data, cls)


def _write(path: Path, key: str, value) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp.npz")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, __key__=np.array(key), **_encode(value))
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def cached(kind: str, parts, compute: Callable, cls=None):
    """``compute()``, or its result stored under ``kind`` and ``parts`` (the arguments it depends on; a model among
    them by its content). ``cls``: the dataclass it returns (None: a JSON-able scalar)."""
    folder = cache_dir()
    if folder is None:
        return compute()
    key = key_of(kind, parts)
    path = folder / f"{kind}-{key[:32]}.npz"
    if path.exists():
        try:
            return _read(path, key, cls)
        except Exception as exc:  # any unreadable entry is recomputed: the cache must never stop the monitor
            LOG.warning("sensor_health: cached %s at %s unusable (%s: %s); recomputing", kind, path,
                        type(exc).__name__, exc)
    value = compute()
    try:
        _write(path, key, value)
    except OSError as exc:
        LOG.warning("sensor_health: cannot write the %s cache at %s (%s); it is recomputed at each start", kind,
                    path, exc)
    return value
