"""The setup step compiles every package's numba kernels into their cache, so a new user's first command loads them
instead of compiling them (scripts/warm_numba.py, run by scripts/setup_env.sh)."""
import importlib.util
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _warm_numba():
    spec = importlib.util.spec_from_file_location("warm_numba", REPO / "scripts" / "warm_numba.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_setup_warms_numba_in_every_package_that_compiles_a_kernel():
    compiling = {path.relative_to(REPO / "src").parts[0] for path in REPO.glob("src/*/*/**/*.py")
                 if "njit(cache=True)" in path.read_text()}
    warmed = {name for name, _ in _warm_numba().WARMERS}
    assert compiling and compiling <= warmed, f"not warmed by setup: {sorted(compiling - warmed)}"
