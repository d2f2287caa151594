"""The workspace's structure: dependencies point one way, no import cycles, modules of a readable size."""
import ast
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

SRC = Path(__file__).resolve().parents[1] / "src"
RUNTIME = ("nav_core", "imu_driver", "imu_calib", "wmra_filter", "ins_gps_kf")
TOOLS = ("imu_sim", "nav_bringup", "nav_eval", "nav_batch")
MAX_LINES = 500


def _modules() -> dict[str, Path]:
    """Every Python module of the workspace packages, by dotted name."""
    found = {}
    for pkg_dir in sorted(SRC.glob("*/*/__init__.py")):
        root = pkg_dir.parent.parent
        for path in sorted(pkg_dir.parent.rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The workspace module a dotted import name lands in (the longest known prefix), or None if foreign."""
    parts = name.split(".")
    for n in range(len(parts), 0, -1):
        candidate = ".".join(parts[:n])
        if candidate in MODULES:
            return candidate
    return None


def _imports(module: str, path: Path) -> set[str]:
    """Workspace modules that `module` imports anywhere in its body, function-level imports included."""
    is_package = path.name == "__init__.py"
    base = module.split(".") if is_package else module.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            prefix = ".".join(base[: len(base) - node.level + 1]) if node.level else ""
            src = ".".join(p for p in (prefix, node.module or "") if p)
            # `from pkg import sub` imports the submodule when there is one, else an attribute of pkg
            names = [f"{src}.{a.name}" if f"{src}.{a.name}" in MODULES else src for a in node.names]
        else:
            continue
        out.update(m for m in map(_resolve, names) if m and m != module)
    return out


GRAPH = {m: _imports(m, p) for m, p in MODULES.items()}


def _package(module: str) -> str:
    return module.split(".")[0]


@pytest.mark.parametrize("package", RUNTIME)
def test_runtime_packages_import_no_simulator_or_bringup(package):
    bad = sorted(f"{m} -> {d}" for m, deps in GRAPH.items() if _package(m) == package
                 for d in deps if _package(d) in TOOLS)
    assert not bad, "runtime package imports a tool package: " + "; ".join(bad)


def test_there_are_no_import_cycles_among_modules():
    names = sorted(GRAPH)
    index = {m: i for i, m in enumerate(names)}
    edges = [(index[m], index[d]) for m, deps in GRAPH.items() for d in deps]
    rows, cols = np.array(edges, int).T if edges else (np.zeros(0, int), np.zeros(0, int))
    adjacency = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(names), len(names)))
    _, labels = connected_components(adjacency, directed=True, connection="strong")
    cycles = [sorted(names[i] for i in np.flatnonzero(labels == c)) for c in np.unique(labels)
              if np.sum(labels == c) > 1]
    assert not cycles, "import cycles: " + " | ".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_check_sees_function_level_imports(tmp_path):
    # the checker itself: an import inside a function body counts as an edge
    path = tmp_path / "mod.py"
    path.write_text("def f():\n    from nav_core import units\n    return units\n")
    assert _imports("nav_core.fake", path) == {"nav_core.units"}


def test_no_module_is_over_500_lines_without_a_reason_at_its_top():
    long = []
    for module, path in MODULES.items():
        lines = path.read_text().splitlines()
        head = "\n".join(lines[:15]).lower()
        if len(lines) > MAX_LINES and "longer than 500 lines because" not in head:
            long.append(f"{path.relative_to(SRC)} ({len(lines)} lines)")
    assert not long, "modules over 500 lines with no reason at the top: " + ", ".join(long)
