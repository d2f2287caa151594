"""Every benchmark script runs to the end in its --quick mode and prints figures (no timing is asserted)."""
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = sorted((Path(__file__).resolve().parents[1] / "benchmarks").glob("bench_*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("bench", BENCHMARKS, ids=[b.stem for b in BENCHMARKS])
def test_benchmark_runs_in_quick_mode_and_prints_figures(bench, ros_env):
    result = subprocess.run([sys.executable, str(bench), "--quick"], capture_output=True, text=True,
                            timeout=600, env=ros_env)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert any(ch.isdigit() for ch in result.stdout), "a benchmark must print its figures"
