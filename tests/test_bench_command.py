"""Tests of ``linflex bench``: table parsing, accuracy-against-time plots, RESULTS.md."""

import subprocess
import sys
from pathlib import Path

from linflex.cli import bench_tool, main

_bench = bench_tool()
accuracy_time_plot, accuracy_time_points, markdown_tables = (
    _bench.accuracy_time_plot, _bench.accuracy_time_points, _bench.markdown_tables)

# the shape of benchmarks/linearization.py's first table (values from its README section)
SAMPLE = """Flexible spacecraft: time and accuracy
| states | method | median time [s] | max rel. error vs autodiff | estimated |
|---|---|---|---|---|
| 14 | python-control linearize (forward, step 1e-6) | 0.0039 | 2.5e-09 | - |
| 14 | linflex perturbation | 0.0119 | 2.8e-16 | 1.4e-06 |
| 14 | linflex autodiff: graph build (once) | 0.0017 | - | - |
| 14 | linflex autodiff: evaluation | 0.0004 | 0.0e+00 | 0.0e+00 |

| grid | points |
|---|---|
| log | 1000 |
"""


def test_tables_and_accuracy_time_points_are_read_from_benchmark_output():
    tables = markdown_tables(SAMPLE)
    assert [t.header[0] for t in tables] == ["states", "grid"]
    assert len(tables[0].rows) == 4 and tables[1].rows == (("log", "1000"),)
    time_label, error_label, points = accuracy_time_points(tables[0])
    assert (time_label, error_label) == ("median time [s]", "max rel. error vs autodiff")
    # the graph-build row has no error ("-") and is left out; labels keep the first column and the method
    assert points == [
        ("14 / python-control linearize (forward, step 1e-6)", 0.0039, 2.5e-09),
        ("14 / linflex perturbation", 0.0119, 2.8e-16),
        ("14 / linflex autodiff: evaluation", 0.0004, 0.0),
    ]
    assert accuracy_time_points(tables[1]) is None  # no time or error column


def test_accuracy_time_plot_is_written(tmp_path):
    _, _, points = accuracy_time_points(markdown_tables(SAMPLE)[0])
    path = accuracy_time_plot("linearization", "time [s]", "error", points, tmp_path / "plot.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_bench_runs_a_benchmark_and_writes_results(tmp_path, capsys):
    # the lightest benchmark (each one's --quick run is tests/test_benchmarks.py's business)
    out = tmp_path / "RESULTS.md"
    assert main(["bench", "--quick", "--only", "formulations", "-o", str(out)]) == 0
    text = out.read_text()
    assert "## formulations" in text and "| N | formulation | states |" in text
    assert "cores" in text and "numpy " in text and "BLAS threads pinned to 1" in text
    assert "ran in" in text and ": ok." in text
    assert "wrote" in capsys.readouterr().out


def test_bench_refuses_unknown_names(capsys):
    assert main(["bench", "--only", "nonexistent"]) == 2
    assert "no benchmark ['nonexistent']" in capsys.readouterr().err


def test_python_m_benchmarks_is_the_bench_command():
    done = subprocess.run([sys.executable, "-m", "benchmarks", "--only", "nonexistent"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert done.returncode == 2 and "no benchmark ['nonexistent']" in done.stderr


def test_progress_rows_printed_before_a_table_are_left_out_of_the_results():
    _without_orphan_rows = _bench._without_orphan_rows

    text = "| a | 1 |\n| b | 2 |\n\n| name | value |\n|---|---|\n| a | 1 |\n| b | 2 |\nafter"
    assert _without_orphan_rows(text) == "\n| name | value |\n|---|---|\n| a | 1 |\n| b | 2 |\nafter"


def test_only_keeps_the_other_sections(tmp_path):
    # An --only run replaces its own section and keeps the others with their dates.
    BenchmarkRun, results_sections, write_results = _bench.BenchmarkRun, _bench.results_sections, _bench.write_results

    out = tmp_path / "RESULTS.md"
    old = [BenchmarkRun("alpha", "A.", "| a [s] |\n|---|\n| 1 |\n", "", 0, 1.0),
           BenchmarkRun("beta", "B.", "old beta\n", "", 0, 2.0)]
    write_results(old, out, quick=False)
    new = [BenchmarkRun("beta", "B.", "new beta\n", "", 0, 3.0)]
    write_results(new, out, quick=False, keep=results_sections(out.read_text()))
    sections = results_sections(out.read_text())
    assert list(sections) == ["alpha", "beta"]
    assert "| 1 |" in sections["alpha"] and "ran in 1.0 s" in sections["alpha"]
    assert "new beta" in sections["beta"] and "old beta" not in sections["beta"]
    assert "the other sections are kept from earlier runs" in out.read_text()
    # beta's stale plot (a table it no longer prints) goes; alpha's, not run now, stays
    plots = tmp_path / "results"
    (plots / "alpha-1.png").write_bytes(b"alpha's")
    (plots / "beta-3.png").write_bytes(b"stale")
    write_results(new, out, quick=False, keep=results_sections(out.read_text()))
    assert not (plots / "beta-3.png").exists() and (plots / "alpha-1.png").exists()


def test_a_failed_benchmark_never_replaces_its_previous_results():
    sections_to_keep, BenchmarkRun = _bench.sections_to_keep, _bench.BenchmarkRun

    def run(name, code):
        return BenchmarkRun(name, "summary", "| a |\n|---|\n| 1 |\n", "boom" if code else "", code, 1.0)

    existing = {"frequency": "## frequency\nold numbers", "margins": "## margins\nold margins"}
    to_write, keep = sections_to_keep([run("frequency", 1), run("margins", 0)], existing, only=False)
    assert [r.name for r in to_write] == ["margins"] and keep == {"frequency": existing["frequency"]}
    # with --only, the benchmarks that did not run keep their sections too
    to_write, keep = sections_to_keep([run("frequency", 1)], existing, only=True)
    assert to_write == [] and keep == existing
    # a failure with no earlier results is written (nothing is lost)
    to_write, keep = sections_to_keep([run("reduction", 1)], existing, only=True)
    assert [r.name for r in to_write] == ["reduction"] and keep == existing
