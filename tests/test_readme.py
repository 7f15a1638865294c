"""The README opens with the two set-up commands, and .ci/run runs the README's test command."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def readme_commands():
    return re.findall(r"```bash\n(.*?)\n```", (ROOT / "README.md").read_text(), flags=re.S)


def test_readme_starts_with_main_job_and_test_commands():
    commands = readme_commands()
    assert len(commands) >= 2
    main_job, tests = commands[0], commands[1]
    assert "pip install" in main_job and "examples/" in main_job
    assert "pip install" in tests and '".[test]"' in tests and "pytest" in tests
    # The two commands are the first code blocks of the file.
    text = (ROOT / "README.md").read_text()
    assert text.index(main_job) < text.index(tests) < text.find("```python")


def test_ci_runs_the_readme_test_command():
    tests = readme_commands()[1]
    ci = (ROOT / ".ci" / "run").read_text()
    # the same command, character for character (its flags too: -n auto runs the suite on
    # every core, which keeps CI's run near 5 minutes on two)
    ci_line = next(line for line in ci.splitlines() if line.startswith("python3 -m venv .venv"))
    assert ci_line == tests
    assert tests.rstrip().endswith("pytest -q -n auto")


def test_main_job_script_exists():
    script = re.search(r"(examples/\S+\.(?:py|toml))", readme_commands()[0]).group(1)
    assert (ROOT / script).exists()


def readme_python_blocks():
    return re.findall(r"```python\n(.*?)\n```", (ROOT / "README.md").read_text(), flags=re.S)


@pytest.mark.parametrize("index", range(len(readme_python_blocks())))
def test_every_python_block_runs_on_its_own(index):
    # A reader copies one block into a fresh interpreter, from the clone's root.
    block = readme_python_blocks()[index]
    result = subprocess.run([sys.executable, "-c", block], cwd=ROOT, capture_output=True, text=True, timeout=300,
                            env={"MPLBACKEND": "Agg", "PATH": "", "OPENBLAS_NUM_THREADS": "1"})
    assert result.returncode == 0, f"README python block {index + 1} fails on its own:\n{block}\n{result.stderr[-2000:]}"
