"""``linflex bench`` (a tool of the source checkout, not of the installed package): run the benchmarks of a source checkout and regenerate ``benchmarks/RESULTS.md``.

Each script in ``benchmarks/`` runs in its own process with BLAS pinned to one thread and prints
Markdown tables (its peers measured in the same run). This command collects what they print,
states the machine, the versions and the date, and draws every table that has a time column and
an error column as accuracy against time (log-log PNGs beside ``RESULTS.md``).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

#: Environment of every benchmark process: one BLAS thread, a non-interactive plot backend.
BENCH_ENVIRONMENT = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}

_TIME_HEADER = re.compile(r"(\[s\]|time|seconds)", re.IGNORECASE)
_ERROR_HEADER = re.compile(r"error", re.IGNORECASE)
_NUMBER = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$")


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="run the benchmarks of a source checkout and regenerate benchmarks/RESULTS.md",
        description="Run every benchmark in benchmarks/ (BLAS pinned to one thread, peers in the same run), "
                    "then write RESULTS.md with the tables, the machine, the versions, the date, and plots of "
                    "accuracy against time.",
    )
    parser.add_argument("--quick", action="store_true", help="each benchmark's --quick smoke mode")
    parser.add_argument("--only", nargs="+", metavar="NAME", default=None,
                        help="run only these benchmarks; the results file keeps the other sections")
    parser.add_argument("-o", "--output", type=Path, default=None,
                        help="results file (default: benchmarks/RESULTS.md of the checkout)")
    parser.add_argument("--timeout", type=float, default=3600.0, help="per benchmark, in seconds (default 3600)")
    parser.set_defaults(run=run)


@dataclass(frozen=True)
class BenchmarkRun:
    """What one benchmark script printed and cost."""

    name: str
    summary: str
    stdout: str
    stderr: str
    returncode: int
    seconds: float


@dataclass(frozen=True)
class Table:
    """A Markdown table printed by a benchmark: header cells and rows of cells."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


def benchmarks_folder() -> Path:
    """The ``benchmarks/`` folder this tool lives in (the source checkout's)."""
    return Path(__file__).resolve().parent


def benchmark_names(folder: Path) -> list[str]:
    """The benchmark scripts (``benchmarks/[a-z]*.py``), by name, sorted."""
    return sorted(p.stem for p in folder.glob("[a-z]*.py"))


def run_benchmark(folder: Path, name: str, *, quick: bool, timeout: float) -> BenchmarkRun:
    """Run one benchmark script in a fresh process; never raises for the script's own failure."""
    script = folder / f"{name}.py"
    env = dict(os.environ, **BENCH_ENVIRONMENT)
    start = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, str(script), *(["--quick"] if quick else [])], capture_output=True,
                              text=True, timeout=timeout, cwd=folder.parent, env=env)
        stdout, stderr, code = done.stdout, done.stderr, done.returncode
    except subprocess.TimeoutExpired as err:
        stdout = err.stdout.decode() if isinstance(err.stdout, bytes) else (err.stdout or "")
        stderr, code = f"timed out after {timeout:g} s", -1
    return BenchmarkRun(name, _docstring_summary(script), stdout, stderr, code, time.perf_counter() - start)


def _docstring_summary(script: Path) -> str:
    """The first paragraph of a script's module docstring."""
    import ast

    try:
        doc = ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or ""
    except SyntaxError:
        return ""
    return " ".join(doc.split("\n\n")[0].split())


def markdown_tables(text: str) -> list[Table]:
    """Every Markdown table (a header row, a ``|---|`` row, then rows) in ``text``."""
    lines = text.splitlines()
    tables, i = [], 0
    while i + 1 < len(lines):
        if lines[i].lstrip().startswith("|") and re.match(r"^\s*\|(\s*:?-+:?\s*\|)+\s*$", lines[i + 1]):
            header = _cells(lines[i])
            rows = []
            j = i + 2
            while j < len(lines) and lines[j].lstrip().startswith("|"):
                cells = _cells(lines[j])
                if len(cells) == len(header):
                    rows.append(cells)
                j += 1
            tables.append(Table(header, tuple(rows)))
            i = j
        else:
            i += 1
    return tables


def _without_orphan_rows(text: str) -> str:
    """``text`` without table rows printed outside a table (progress lines before the full table)."""
    lines = text.splitlines()
    keep, in_table = [], False
    for i, line in enumerate(lines):
        is_row = line.lstrip().startswith("|")
        starts = is_row and i + 1 < len(lines) and re.match(r"^\s*\|(\s*:?-+:?\s*\|)+\s*$", lines[i + 1])
        in_table = is_row and (in_table or bool(starts))
        if not is_row or in_table:
            keep.append(line)
    return "\n".join(keep)


def _cells(line: str) -> tuple[str, ...]:
    return tuple(c.strip() for c in line.strip().strip("|").split("|"))


def accuracy_time_points(table: Table):
    """``(time column, error column, [(label, seconds, error), ...])`` or None.

    The time column is the first whose header says ``[s]``, ``time`` or ``seconds``; the error
    column the first whose header says ``error``. Rows where either is not a positive number
    (``-``, ``nan``, ``diverges``) are left out; the label joins the row's cells before both columns.
    """
    t_col = next((k for k, h in enumerate(table.header) if _TIME_HEADER.search(h)), None)
    e_col = next((k for k, h in enumerate(table.header) if _ERROR_HEADER.search(h)), None)
    if t_col is None or e_col is None or t_col == e_col:
        return None
    points = []
    for row in table.rows:
        if not (_NUMBER.match(row[t_col]) and _NUMBER.match(row[e_col])):
            continue
        seconds, error = float(row[t_col]), float(row[e_col])
        if seconds <= 0:
            continue
        label = " / ".join(c for c in row[: min(t_col, e_col)] if c)
        points.append((label, seconds, error))
    return (table.header[t_col], table.header[e_col], points) if len(points) >= 2 else None


def accuracy_time_plot(title: str, time_label: str, error_label: str, points, path: Path) -> Path:
    """Log-log plot of error against time; writes ``path``.

    Rows whose labels differ only in numbers (a tolerance, a model size) form one series: one
    colour and marker, joined in the order of the table, each point annotated with its numbers.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series: dict[str, list[tuple[float, float, str]]] = {}
    for label, seconds, error in points:
        parts = label.split(" / ")
        words = [p for p in parts if not _NUMBER.match(p)]
        numbers = [p for p in parts if _NUMBER.match(p)]
        series.setdefault(" / ".join(words) or label, []).append((seconds, error, " ".join(numbers)))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    floor = min((e for _, _, e in points if e > 0), default=1e-16) / 10
    for k, (name, pts) in enumerate(series.items()):
        xs, ys = [p[0] for p in pts], [max(p[1], floor) for p in pts]
        ax.plot(xs, ys, marker="os^Dvx*P"[k % 8], color=f"C{k % 10}", label=name, linewidth=0.8)
        for x, y, note in zip(xs, ys, (p[2] for p in pts)):
            if note:
                ax.annotate(note, (x, y), textcoords="offset points", xytext=(3, 3), fontsize=6, color=f"C{k % 10}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(time_label)
    ax.set_ylabel(error_label + " (0 drawn at the floor)")
    ax.set_title(title, fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="x-small", loc="best", ncol=1 if len(series) <= 8 else 2)
    from linflex.system import atomic_write

    with atomic_write(path, "wb") as handle:  # a temporary name renamed into place
        fig.savefig(handle, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def machine_description() -> list[str]:
    """Machine, Python and library versions, as Markdown list items."""
    import importlib.metadata

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = []
    for package in ("linflex", "numpy", "scipy", "control", "casadi", "slycot", "matplotlib", "dask"):
        try:
            versions.append(f"{package} {importlib.metadata.version(package)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{package} (not installed)")
    return [
        f"- machine: {platform.system()} {platform.machine()}, {cpu}, {os.cpu_count()} cores",
        f"- Python {platform.python_version()}; {', '.join(versions)}",
        "- BLAS threads pinned to 1 in every benchmark process",
        load_line(os.getloadavg(), os.cpu_count() or 1),
    ]


def load_line(load: tuple[float, float, float], cores: int) -> str:
    """The machine's load average (1, 5 and 15 min) when the results were written, and what it means."""
    reading = (": above the core count, other jobs shared the machine and wall times are longer than an idle "
               "machine's (benchmarks that say so give CPU times)" if max(load[0], load[2]) > cores else
               ": within the core count")
    return f"- load average when this file was written: {load[0]:.1f} (1 min), {load[2]:.1f} (15 min) on {cores} cores{reading}"


def results_sections(text: str) -> dict[str, str]:
    """The ``## name`` sections of a results file, by name (each with its heading)."""
    sections: dict[str, list[str]] = {}
    current = None
    for line in text.splitlines():
        if line.startswith("## "):
            current = line[3:].strip()
            sections[current] = []
        if current is not None:
            sections[current].append(line)
    return {name: "\n".join(lines).rstrip() for name, lines in sections.items()}


def write_results(runs: list[BenchmarkRun], output: Path, *, quick: bool,
                  keep: dict[str, str] | None = None) -> list[Path]:
    """Write ``output`` (Markdown) and its plots beside it; returns every file written.

    ``keep``: sections of an earlier results file (:func:`results_sections`) for benchmarks that
    did not run now (``linflex bench --only``); they stay, in name order, with their own dates,
    and so do their plots. A section written now loses the plots of its earlier run that this
    run did not draw again (``results/NAME-K.png``: numbered by table, so they go stale when
    tables are added or removed).
    """
    output.parent.mkdir(parents=True, exist_ok=True)
    plots_dir = output.parent / "results"
    plots_dir.mkdir(exist_ok=True)
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    kept = {name: text for name, text in (keep or {}).items() if name not in {r.name for r in runs}}
    lines = [
        "# Benchmark results",
        "",
        f"Regenerated by `linflex bench{' --quick' if quick else ''}` on {stamp}"
        + (f" (this run: {', '.join(r.name for r in runs)}; the other sections are kept from earlier runs, each "
           "with its date)" if kept else "")
        + ". Times are medians of the repetitions each benchmark states; ratios compare tools measured in the same "
        "process. The reading of each table is in `benchmarks/README.md`.",
        "",
        *machine_description(),
        "",
    ]
    written = []
    for name in sorted([r.name for r in runs] + list(kept)):
        if name in kept:
            lines += [kept[name], ""]
            continue
        run = next(r for r in runs if r.name == name)
        status = "ok" if run.returncode == 0 else f"**failed (exit {run.returncode})**"
        lines += [f"## {run.name}", "", run.summary, "",
                  f"`benchmarks/{run.name}.py` ran in {run.seconds:.1f} s on {stamp}"
                  f"{' (--quick)' if quick else ''}: {status}.", ""]
        lines += [_without_orphan_rows(run.stdout).rstrip(), ""]
        if run.returncode != 0:
            lines += ["```", run.stderr.strip()[-3000:], "```", ""]
        for k, table in enumerate(markdown_tables(run.stdout)):
            found = accuracy_time_points(table)
            if found is None:
                continue
            time_label, error_label, points = found
            path = accuracy_time_plot(f"{run.name}: {error_label} against {time_label}", time_label, error_label,
                                      points, plots_dir / f"{run.name}-{k + 1}.png")
            written.append(path)
            lines += [f"![{run.name}: accuracy against time, table {k + 1}](results/{path.name})", ""]
    from linflex.system import atomic_write

    with atomic_write(output) as handle:  # a killed run leaves the previous results whole
        handle.write("\n".join(lines) + "\n")
    # the plots of a section written now that this run did not draw (its tables moved or went)
    for run in runs:
        for stale in set(plots_dir.glob(f"{run.name}-*.png")) - set(written):
            stale.unlink()
    return [output, *written]


def run(args: argparse.Namespace) -> int:
    try:
        folder = benchmarks_folder()
    except FileNotFoundError as err:
        print(f"linflex bench: {err}", file=sys.stderr)
        return 2
    names = benchmark_names(folder)
    if args.only:
        unknown = sorted(set(args.only) - set(names))
        if unknown:
            print(f"linflex bench: no benchmark {unknown}; there are {names}", file=sys.stderr)
            return 2
        names = [n for n in names if n in args.only]
    runs = []
    for k, name in enumerate(names, start=1):
        print(f"[{k}/{len(names)}] {name} ...", flush=True)
        result = run_benchmark(folder, name, quick=args.quick, timeout=args.timeout)
        print(f"    {'ok' if result.returncode == 0 else 'FAILED'} in {result.seconds:.1f} s", flush=True)
        runs.append(result)
    output = args.output or folder / "RESULTS.md"
    existing = results_sections(output.read_text(encoding="utf-8")) if output.exists() else {}
    to_write, keep = sections_to_keep(runs, existing, only=bool(args.only))
    written = write_results(to_write, output, quick=args.quick, keep=keep)
    print(f"wrote {written[0]} and {len(written) - 1} plot(s)")
    failed = [r.name for r in runs if r.returncode != 0]
    if failed:
        kept = [name for name in failed if name in keep]
        print(f"linflex bench: failed: {', '.join(failed)}"
              + (f"; the previous results of {', '.join(kept)} are kept" if kept else ""), file=sys.stderr)
        return 1
    return 0


def sections_to_keep(runs: list[BenchmarkRun], existing: dict[str, str], *, only: bool):
    """``(runs to write, sections to keep)``: a failed run never replaces a section that has results.

    With ``--only`` the sections of the benchmarks that did not run stay as they were; a failed
    run keeps its previous section when there is one (its failure is printed, not written).
    """
    failed_with_results = {r.name for r in runs if r.returncode != 0 and r.name in existing}
    to_write = [r for r in runs if r.name not in failed_with_results]
    ran = {r.name for r in runs}
    keep = {name: text for name, text in existing.items() if name in failed_with_results or (only and name not in ran)}
    return to_write, keep
