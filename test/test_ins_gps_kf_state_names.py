"""Error states are indexed only by name (error_model's DP, DV, PHI, YAW, BG, BA, SG, SA and em.index): a literal
state index outside error_model.py fails here, so adding states (NHC mounting, odometer scale) cannot shift one."""
import ast
from pathlib import Path

import numpy as np

from ins_gps_kf import error_model as em

SRC = Path(__file__).resolve().parents[1] / "src" / "ins_gps_kf" / "ins_gps_kf"
STATE_ARRAYS = {"cov", "dx", "h", "f_cont", "jac", "cov_prior"}
"""Names that hold error-state vectors or matrices (covariance, correction, Jacobians) in the filter modules."""
MEASUREMENT_ROWS = {"h", "jac"}
"""Jacobians (m, n): their rows are measurement components, only the columns are states."""
OWNERS = {"self", "est", "e", "f", "filt", "corr", "state"}


def _holds_state(node) -> bool:
    if isinstance(node, ast.Name):
        return node.id in STATE_ARRAYS
    return (isinstance(node, ast.Attribute) and node.attr in STATE_ARRAYS and isinstance(node.value, ast.Name)
            and node.value.id in OWNERS)


def _has_int_literal(node) -> bool:
    return any(isinstance(n, ast.Constant) and type(n.value) is int for n in ast.walk(node))


def literal_state_indices(source: str, name: str = "<src>") -> list[str]:
    """Places in ``source`` that index a state array with an integer literal, or build np.r_ from literals."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Subscript):
            continue
        r_ = isinstance(node.value, ast.Attribute) and node.value.attr == "r_"
        index = node.slice
        if _holds_state(node.value) and getattr(node.value, "id", getattr(node.value, "attr", "")) in MEASUREMENT_ROWS:
            index = ast.Tuple(elts=index.elts[1:]) if isinstance(index, ast.Tuple) else ast.Tuple(elts=[])
        if (r_ or _holds_state(node.value)) and _has_int_literal(index):
            found.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
    return found


def test_no_module_indexes_an_error_state_by_a_literal():
    found = []
    for path in sorted(SRC.glob("*.py")):
        if path.name != "error_model.py":  # the one place the layout is written down
            found += literal_state_indices(path.read_text(), path.name)
    assert not found, "index error states by name (ins_gps_kf.error_model), not literals:\n" + "\n".join(found)


def test_the_check_catches_the_literals_it_is_for():
    old = ("self._reset_block(np.r_[0:6, 8], v)\n"
           "dx[em.PHI.start + 2] = 0.0\n"
           "idx = np.r_[0:3, 6:9]\n"
           "self.cov[8, 8] += 1.0\n"
           "h[:, 3:6] = np.eye(3)\n")
    assert len(literal_state_indices(old)) == 5
    named = "h[:3]\nh[:3, em.DP]\ndx[em.YAW] = 0.0\nself.cov[em.YAW, em.YAW] += 1.0\nh[:, em.DV] = np.eye(3)\nfix.cov[0, 0]\nt[0]\n"
    assert literal_state_indices(named) == []


def test_named_blocks_cover_the_state_once_in_order():
    idx = em.index(em.DP, em.DV, em.PHI, em.BG, em.BA)
    np.testing.assert_array_equal(idx, np.arange(em.N_STATES))
    np.testing.assert_array_equal(em.index(em.DP, em.DV, em.PHI, em.BG, em.BA, em.SG, em.SA), np.arange(em.N_STATES_SF))
    assert em.index(em.YAW).tolist() == [em.STATES.index("phiu")]
