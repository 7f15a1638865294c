"""Smoke run: every benchmark still executes in its --quick mode and prints its table.

Benchmarks are not tests (they assert nothing about speed); this only proves they still run.
"""

import subprocess
import sys
from pathlib import Path

import pytest

from .mor import MOR_DIR

ROOT = Path(__file__).resolve().parents[1]
NEEDS_SHARED_MODELS = {"reduction", "frequency"}


@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "benchmarks").glob("[a-z]*.py")))
def test_benchmark_runs_quick(name):
    if name in NEEDS_SHARED_MODELS and not MOR_DIR.exists():
        pytest.skip(f"{name} needs the benchmark models of {MOR_DIR}")
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / f"{name}.py"), "--quick"],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "|---|" in result.stdout  # a Markdown table was printed
