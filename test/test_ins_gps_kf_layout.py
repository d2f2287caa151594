"""ins_gps_kf is the runtime filter only: the evaluations live in nav_eval, the node loads models through
ins_gps_kf.offline, and ``ins-gps-kf evaluate`` comes from nav_eval's plugin (issue 18, item 1)."""
import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
FORBIDDEN = ("imu_sim", "wmra_filter", "imu_calib", "nav_bringup", "nav_eval")


def _imports(path: Path, top_level_only: bool = False) -> set[str]:
    """Dotted names a module imports (function-level imports included unless ``top_level_only``)."""
    tree = ast.parse(path.read_text(), str(path))
    nodes = tree.body if top_level_only else ast.walk(tree)
    out = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.update([node.module] + [f"{node.module}.{a.name}" for a in node.names])
    return out


def _modules(package: str) -> dict[str, Path]:
    return {f"{package}.{p.stem}": p for p in sorted((SRC / package / package).glob("*.py"))}


@pytest.mark.parametrize("module, path", sorted(_modules("ins_gps_kf").items()))
def test_no_ins_gps_kf_module_imports_the_simulator_the_denoiser_calibration_or_evaluation(module, path):
    bad = sorted(n for n in _imports(path) if n.split(".")[0] in FORBIDDEN)
    assert not bad, f"{module} imports {bad}"


def test_the_node_loads_its_model_without_the_cli_and_offline_needs_no_progress_bar_or_plots():
    assert not any(n.startswith("ins_gps_kf.replay") for n in _imports(SRC / "ins_gps_kf/ins_gps_kf/ins_gps_kf_node.py"))
    top = _imports(SRC / "ins_gps_kf/ins_gps_kf/offline.py", top_level_only=True)
    assert not any(n.split(".")[0] in ("tqdm", "matplotlib") for n in top)


def test_ins_gps_kf_evaluate_is_offered_by_the_nav_eval_plugin(tmp_path, capsys):
    from ins_gps_kf.replay import main
    assert main(["evaluate", "--dataset", "canada", "--claims", "--out", str(tmp_path)]) == 2
    assert "--claims: only paper-sim and katwijk" in capsys.readouterr().err


def test_every_node_only_parameter_is_known_to_the_core_so_the_shared_params_file_replays():
    import re
    from ins_gps_kf import config
    node = (SRC / "ins_gps_kf/ins_gps_kf/ins_gps_kf_node.py").read_text()
    declared = set(re.findall(r'Param\(\s*"(\w+)"', node))
    assert declared and declared <= config.NODE_ONLY, sorted(declared - config.NODE_ONLY)
    params = config.load_params_yaml(SRC.parent / "config" / "navigation.yaml")
    assert not set(params) & config.NODE_ONLY
