"""The stability-margin report: content, files, the command line, and a real browser."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex.cli import main
from linflex.stability import stability_margins
from linflex.stability.report import analyse_scene, stability_report

SCENE = Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", str(SCENE), "-o", str(out)]) == 0  # exit 0: the closed loop is stable
    return out


def test_cli_writes_html_markdown_and_pdf(report_dir):
    assert (report_dir / "report.pdf").read_bytes().startswith(b"%PDF")
    markdown = (report_dir / "report.md").read_text()
    assert "### Margins per loop" in markdown and "| tx | 65.16 |" in markdown
    html = (report_dir / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 7  # Bode, Nichols, Nyquist, sensitivity, 3 root loci


def test_report_numbers_are_those_of_stability_margins():
    analysis = analyse_scene(SCENE)
    report = stability_report(analysis)
    independent = stability_margins(analysis.open_loop)  # recomputed, not read from the analysis
    table = next(t for t in report.tables() if t.title == "Margins per loop")
    for row, loop in zip(table.rows, independent.loops):
        assert row[0] == loop.channel
        assert float(row[1]) == pytest.approx(loop.min_phase_margin, rel=1e-3)  # 4 significant digits
        assert float(row[4]) == pytest.approx(loop.delay_margin, rel=1e-3)


def test_cli_reports_a_bad_scene(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\neffects = ["no_such_effect"]\n')
    assert main(["report", str(bad), "-o", str(tmp_path / "out")]) == 2
    assert "no_such_effect" in capsys.readouterr().err


def _chromium(*args, user_data):
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={user_data}"]
    return subprocess.run([CHROMIUM, *flags, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"), reason="chromium is not installed (.ci/run installs it)")
def test_report_renders_in_a_real_browser(report_dir, tmp_path):
    assert CHROMIUM is not None, "CI must have chromium: .ci/run installs it"
    page = (report_dir / "report.html").as_uri()
    dom = _chromium("--dump-dom", page, user_data=tmp_path / "profile1").stdout
    # The rendered DOM holds the margin table with the computed numbers.
    assert re.search(r"<h3>Margins per loop</h3>", dom)
    analysis = analyse_scene(SCENE)
    pm = analysis.margins.loops[0].min_phase_margin
    assert f"<td>{pm:.4g}</td>" in dom
    assert dom.count("<img") == 7
    # A screenshot of the page is not blank, and the plots' line colour is on it.
    shot = tmp_path / "page.png"
    _chromium(f"--screenshot={shot}", "--window-size=1280,4000", "--hide-scrollbars", page,
              user_data=tmp_path / "profile2")
    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)[..., :3]
    assert pixels.std() > 0.05  # not a blank page
    # The figures' coloured curves and markers are on it (tables and text are grey scale).
    coloured = (pixels.max(axis=-1) - pixels.min(axis=-1)) > 0.3
    assert coloured.sum() > 2000


def test_a_report_that_fails_while_rendering_leaves_the_previous_one_whole(report_dir, tmp_path):
    import dataclasses

    folder = tmp_path / "report"
    shutil.copytree(report_dir, folder)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}

    def broken():
        raise RuntimeError("a figure that cannot be drawn")

    report = stability_report(analyse_scene(SCENE))
    failing = dataclasses.replace(report, figures=(*report.figures, ("broken", broken)))
    with pytest.raises(RuntimeError, match="cannot be drawn"):
        failing.write(folder)  # fails while the figures are drawn, before anything is swapped in
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert not list(tmp_path.glob(".report.*-*"))  # no temporary folder left behind
    # a run without the PDF replaces the whole folder: no PDF of the previous run stays beside it
    assert [p.name for p in report.write(folder, pdf=False)] == ["report.html", "report.md"]
    assert sorted(p.name for p in folder.iterdir()) == ["report.html", "report.md"]


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(st.text(alphabet="ab|\\\n -", min_size=0, max_size=8), min_size=2, max_size=2))
def test_markdown_tables_keep_their_columns_whatever_the_names(cells):
    # A name with '|' (or a backslash, or a newline) must not split or merge the table's cells:
    # GitHub-flavoured Markdown splits a row at every unescaped '|'.
    from linflex.stability.report._table import Table

    markdown = Table("t", ("a", "b"), (tuple(cells),)).to_markdown()
    row = markdown.strip().splitlines()[-1]
    assert "\n" not in row
    unescaped = re.findall(r"(?<!\\)(?:\\\\)*\|", row)
    assert len(unescaped) == 3  # the row's two cells: | x | y |
