"""The report a review board reads: requirements and verdicts, the first screen, the printed PDF."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import linflex
from linflex.cli import main
from linflex.scene import Requirements
from linflex.stability import stability_margins
from linflex.stability.report import analyse_scene, stability_report, verdicts

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ARRAYS = EXAMPLES / "spacecraft_arrays.toml"
ATTITUDE = EXAMPLES / "attitude_control.toml"
PDFTOTEXT = shutil.which("pdftotext")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def arrays():
    return analyse_scene(ARRAYS)


@pytest.fixture(scope="module")
def arrays_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("arrays") / "report"
    assert main(["report", str(ARRAYS), "-o", str(out)]) == 0  # stable, every requirement of the scene met
    return out


def test_limiting_items_are_the_extremes_of_an_independent_margin_computation(arrays):
    independent = stability_margins(arrays.open_loop)  # recomputed from the loop, not read from the analysis
    v = verdicts(arrays)
    # delay margin: the least over every crossing of every loop (the 10.48 rad/s flexible crossing of motor_x)
    dm = [(d, lm.channel, w) for lm in independent.loops for w, d in zip(lm.gain_crossovers, lm.delay_margins)]
    best = min(dm)
    limiting = v.limiting("delay_margin_s")
    assert (limiting.channel, limiting.where) == (best[1], "gain crossover")
    assert limiting.value == pytest.approx(best[0], rel=1e-9) and limiting.frequency == pytest.approx(best[2])
    assert limiting.channel == "motor_x" and limiting.frequency == pytest.approx(10.48, abs=0.01)
    # phase margin: the least |PM| (not the most negative PM: -143.6 deg is 143.6 deg from -180)
    pm = min(abs(p) for lm in independent.loops for p in lm.phase_margins)
    assert v.limiting("phase_margin_deg").value == pytest.approx(pm, rel=1e-9)
    assert v.passed and all(c.passed for c in v.checks if c.required is not None)


def test_a_requirement_fails_exactly_where_the_margin_is_below_it(arrays):
    # 0.3 s of delay: only crossings with a smaller delay margin fail (the 10.4-10.5 rad/s flexible ones)
    v = verdicts(arrays, Requirements(delay_margin_s=0.3))
    failed = sorted((c.channel, round(c.frequency, 2)) for c in v.failed)
    expected = sorted((lm.channel, round(float(w), 2)) for lm in arrays.margins.loops
                      for w, d in zip(lm.gain_crossovers, lm.delay_margins) if d < 0.3)
    assert failed == expected and len(failed) == 2 and not v.passed
    # a loop's own requirement replaces the global one for that loop only
    v = verdicts(arrays, Requirements(delay_margin_s=0.3, loops={"motor_x": {"delay_margin_s": 0.1},
                                                                  "motor_z": {"delay_margin_s": 0.1}}))
    assert v.passed


def test_phase_stabilized_flexible_modes_are_flagged(arrays):
    from linflex.stability.report._document import flexible_resonances

    resonances = flexible_resonances(arrays)
    phase = [r for r in resonances if r.kind == "phase-stabilized"]
    # motor_x: the 2.85 rad/s bending resonance peaks near +25 dB and is crossed at 2.46 and 3.46 rad/s
    first = min((r for r in phase if r.channel == "motor_x"), key=lambda r: r.frequency)
    assert first.peak_db == pytest.approx(25.6, abs=0.3) and first.mode_frequency == pytest.approx(2.851, abs=1e-3)
    lm = next(lm for lm in arrays.margins.loops if lm.channel == "motor_x")
    assert first.clearance == pytest.approx(min(abs(lm.phase_margins[1]), abs(lm.phase_margins[2])), rel=1e-12)
    # the peak of |L| is the one of the response evaluated independently at that frequency
    mag = abs(linflex.frequency.frequency_response(arrays.channels[0].return_ratio, [first.frequency]).response[0, 0, 0])
    assert 20 * np.log10(mag) == pytest.approx(first.peak_db, abs=1e-9)
    assert all(r.peak_db < 0 for r in resonances if r.kind == "gain-stabilized")
    assert "WARNING" in stability_report(arrays).to_markdown()


def test_unstable_closed_loop_has_no_delay_margin_and_fails(tmp_path, capsys):
    scene = tmp_path / "unstable.toml"
    scene.write_text(ATTITUDE.read_text().replace("kp = [25.0, 30.0, 20.0]", "kp = [-25.0, -30.0, -20.0]"))
    analysis = analyse_scene(scene)
    assert not analysis.closed_loop_stable
    markdown = stability_report(analysis, requirements=Requirements(delay_margin_s=0.01)).to_markdown()
    assert "FAIL: the closed loop is UNSTABLE" in markdown and "none (unstable)" in markdown
    assert "6.283" not in markdown
    from linflex.stability.report import margin_summary

    summary = margin_summary(scene)
    assert summary["closed_loop_stable"] == 0.0 and np.isnan(summary["delay_margin_s"])
    assert main(["report", str(scene), "-o", str(tmp_path / "out"), "--no-pdf"]) == 1


def test_require_on_the_command_line_sets_the_exit_code(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["report", str(ATTITUDE), "-o", str(out), "--no-pdf", "--require", "phase_margin_deg=60"]) == 0
    assert main(["report", str(ATTITUDE), "-o", str(out), "--no-pdf", "--require", "tx.phase_margin_deg=70"]) == 1
    text = (out / "report.md").read_text()
    assert "| phase margin [deg] | >= 70 | tx |" in text and "FAIL (1 of 1)" in text
    for bad, message in (["phase_margin=3", "unknown requirement"], ["phase_margin_deg=abc", "not a number"],
                         ["nope.disk_margin=0.5", "unknown actuator 'nope'"], ["disk_margin=-1", "must be positive"]):
        assert main(["report", str(ATTITUDE), "-o", str(out), "--no-pdf", "--require", bad]) == 2
        assert message in capsys.readouterr().err


def test_requirements_table_reads_back_and_is_validated():
    scene = linflex.load_scene(ARRAYS)
    assert scene.requirements.for_loop("motor_x")["delay_margin_s"] == 0.05
    assert linflex.Scene.from_dict(scene.to_dict()) == scene
    bad = scene.replace(requirements={"phase_margin_deg": "thirty", "loops": {"motor_q": {"x": 1}}})
    problems = "\n".join(bad.problems())
    assert "requirements.phase_margin_deg: expected a number [deg]" in problems
    assert "requirements.loops.motor_q: unknown actuator" in problems and "requirements.loops.motor_q.x" in problems


def test_rigid_body_rows_name_the_rates_of_their_jordan_chains():
    report = stability_report(analyse_scene(ATTITUDE))
    table = next(t for t in report.tables() if t.title.startswith("Plant modes"))
    names = [row[-1].split(" ")[0] for row in table.rows]
    # a double integrator per axis: the attitude, then the rate that drives it (not the attitude twice)
    assert names == ["attitude.qx", "attitude.qy", "attitude.qz", "attitude.wx", "attitude.wy", "attitude.wz"]


def test_markdown_and_html_lead_with_the_verdict(arrays_report):
    markdown = (arrays_report / "report.md").read_text()
    first = markdown.split("### Plant and controller")[0]
    # 0.1918 s since the arrays' sixth mode is the third bending pair's member in a fixed basis
    # (structures/_beam.py: a cut through a repeated pair no longer follows LAPACK's choice)
    assert "PASS: all" in first and "| delay margin [s] | >= 0.05 | motor_x | gain crossover at 10.48 rad/s | 0.1918 |" \
        in first
    assert "control" not in re.search(r"Effects in the plant[^;]*;", markdown).group(0)
    html = (arrays_report / "report.html").read_text()
    assert html.index("PASS: all") < html.index("<h2>Figures</h2>") < html.index("<h3>Every crossing</h3>")


def _words(pdf: Path):
    """(page width, page height, [(xMin, xMax, word)]) of each page, from pdftotext -bbox."""
    out = subprocess.run([PDFTOTEXT, "-bbox", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    pages = []
    for page in re.finditer(r'<page width="([\d.]+)" height="([\d.]+)">(.*?)</page>', out, re.S):
        words = [(float(a), float(b), w) for a, b, w in
                 re.findall(r'<word xMin="([\d.]+)" yMin="[\d.]+" xMax="([\d.]+)" yMax="[\d.]+">([^<]*)</word>',
                            page.group(3))]
        pages.append((float(page.group(1)), float(page.group(2)), words))
    return pages


@pytest.mark.skipif(PDFTOTEXT is None or CHROMIUM is None, reason="needs pdftotext (poppler-utils) and chromium")
def test_pdf_is_the_printed_page_with_the_numbers_and_nothing_cut_off(arrays_report, arrays):
    pdf = arrays_report / "report.pdf"
    text = subprocess.run([PDFTOTEXT, "-layout", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    first_page = text.split("\f")[0]
    assert "PASS: all" in first_page and "Requirements and the limiting loop" in first_page
    # the limiting delay margin and its crossing, as an independent margin computation gives them
    loop = next(lm for lm in stability_margins(arrays.open_loop).loops if lm.channel == "motor_x")
    assert f"{loop.delay_margin:.4g}" in first_page and f"{loop.gain_crossovers[-1]:.4g} rad/s" in first_page
    for lm in arrays.margins.loops:  # every crossing's phase margin is in the text
        for pm in lm.phase_margins:
            assert f"PM {pm:.4g} deg" in text
    # no Markdown syntax: no heading marks, no table rules, no escaped pipes
    assert "### " not in text and "# Stability margins" not in text and "|---" not in text and "\\|" not in text
    # nothing cut off: every word lies inside its page
    pages = _words(pdf)
    assert len(pages) >= 3
    for width, _, words in pages:
        assert words and all(0 <= x0 and x1 <= width for x0, x1, _ in words)


@pytest.mark.skipif(PDFTOTEXT is None, reason="needs pdftotext (poppler-utils)")
def test_without_chromium_the_pdf_is_a_fallback_that_says_so(monkeypatch, tmp_path):
    import linflex.stability.report._document as document

    monkeypatch.setattr(document, "chromium", lambda: None)
    report = stability_report(analyse_scene(ATTITUDE))
    pdf = report.to_pdf(tmp_path / "fallback.pdf")
    text = subprocess.run([PDFTOTEXT, str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    assert "Chromium was not found" in text and "plain fallback" in text
    assert f"{analyse_scene(ATTITUDE).margins.loops[0].min_phase_margin:.4g}" in text


@pytest.mark.skipif(PDFTOTEXT is None or CHROMIUM is None, reason="needs pdftotext (poppler-utils) and chromium")
def test_a_browser_started_early_prints_over_its_pipe_and_ends_with_its_context(tmp_path, monkeypatch):
    import linflex.stability.report._pdf as pdf
    from linflex.stability.report import PdfPrinter

    monkeypatch.setattr(pdf, "print_pdf", lambda *a, **k: pytest.fail("fell back to --print-to-pdf"))
    report = stability_report(analyse_scene(ATTITUDE))
    with PdfPrinter() as printer:
        process = printer._process
        out = report.to_pdf(tmp_path / "r.pdf", printer=printer)
    assert process.poll() is not None  # the browser ended with the context
    text = subprocess.run([PDFTOTEXT, str(out), "-"], capture_output=True, text=True, check=True).stdout
    assert report.title in text and "Requirements and the limiting loop" in text


def test_margin_summary_searches_the_multi_loop_disk_margin_only_and_agrees_with_the_full_analysis():
    # margin_summary (what a sweep runs) leaves each loop's and the unstructured disk margins out:
    # its numbers are the full analysis's to rounding (the flexible example, three loops).
    from linflex.stability.report import margin_summary
    from linflex.stability.report._analysis import summary_metrics

    full = analyse_scene(ARRAYS, stiffness_by_origin=False, figures=False)
    assert np.isfinite(full.margins.loops[0].disk_margin.alpha)
    summary, want = margin_summary(ARRAYS), summary_metrics(full)
    assert summary.keys() == want.keys()
    for key, value in want.items():
        assert summary[key] == pytest.approx(value, rel=1e-12, nan_ok=True), key
    # a report of such an analysis is refused (its loop disk margins would read as failed checks)
    partial = analyse_scene(ARRAYS, stiffness_by_origin=False, figures=False, disk_margins="multi-loop")
    with pytest.raises(linflex.ModelError, match="disk_margins='all', the default, for a report"):
        stability_report(partial)
    # a report of an analysis without figures says so where they would be (Markdown and HTML)
    from linflex.stability.report._document import NO_FIGURES

    bare = stability_report(full)
    assert bare.figures == () and NO_FIGURES in bare.to_markdown()
    assert "analyse_scene(..., figures=False)" in bare.html_page()
