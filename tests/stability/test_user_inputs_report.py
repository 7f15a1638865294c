"""What a review board and a hurried user meet in the stability report: odd requirements through the
Python API, an unstable loop, a margin at its bound, a poorly damped loop's figures.

References: the attitude example's PD design (its three axes tie at PM 65.156 deg, the value of
``test_report_analysis``), and the scene's ``[requirements]`` rules (linflex/scene/_requirements.py),
which the CLI's ``--require`` already applies.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import matplotlib
import numpy as np
import pytest

from linflex import ModelError
from linflex.scene import Requirements
from linflex.stability.report import analyse_scene, stability_report, verdicts

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ATTITUDE = EXAMPLES / "attitude_control.toml"
KP = "kp = [25.0, 30.0, 20.0]"
KD = "kd = [70.0, 84.0, 56.0]"


@pytest.fixture(scope="module")
def attitude():
    return analyse_scene(ATTITUDE)


def _variant(tmp_path_factory, name: str, old: str, new: str):
    scene = tmp_path_factory.mktemp(name) / f"{name}.toml"
    text = ATTITUDE.read_text()
    assert old in text
    scene.write_text(text.replace(old, new))
    return analyse_scene(scene)


@pytest.fixture(scope="module")
def sampled():
    # a 10 Hz controller with a 0.02 s computational delay: the loop is analysed in z up to pi/T = 31.42 rad/s
    return analyse_scene(EXAMPLES / "spacecraft_sampled.toml")


@pytest.fixture(scope="module")
def unstable(tmp_path_factory):
    # positive feedback on the attitude: three unstable modes (Nyquist Z = 3)
    return _variant(tmp_path_factory, "unstable", KP, "kp = [-25.0, -30.0, -20.0]")


@pytest.fixture(scope="module")
def underdamped(tmp_path_factory):
    # rate gains cut 23-fold: PM 3.4 deg, Ms 24.4 dB at 0.50 rad/s (stable)
    return _variant(tmp_path_factory, "underdamped", KD, "kd = [3.0, 3.6, 2.4]")


def _row(markdown: str, label: str) -> list[str]:
    line = next(r for r in markdown.splitlines() if r.startswith(f"| {label}"))
    return [c.strip() for c in line.strip("|").split(" | ")]


@pytest.mark.parametrize("requirements, fragment", [
    (Requirements(phase_margin_deg=-30.0), "requirements.phase_margin_deg: must be positive [deg], got -30"),
    (Requirements(delay_margin_s=math.nan), "requirements.delay_margin_s: not finite (nan) [s]"),
    (Requirements(loops={"motor_x": {"phase_margin_deg": 40.0}}), "requirements.loops.motor_x: unknown actuator"),
    (Requirements(loops={"tx": {"phase_margn_deg": 40.0}}), "did you mean 'phase_margin_deg'?"),
    (Requirements(phase_margin_deg="thirty"), "expected a number [deg], got 'thirty'"),
])
def test_requirements_given_to_the_api_are_checked_as_the_scene_table(attitude, requirements, fragment):
    # before: a misspelled loop or name required nothing and the report said "No requirements given", a
    # negative bound passed, nan failed with "(>= -)"; the CLI refuses all of them (--require)
    with pytest.raises(ModelError, match="invalid requirements") as err:
        stability_report(attitude, requirements=requirements)
    assert fragment in str(err.value)
    with pytest.raises(ModelError, match="invalid requirements"):
        verdicts(attitude, requirements)


def test_a_mapping_of_requirements_is_read_as_the_scene_table(attitude):
    v = verdicts(attitude, {"phase_margin_deg": 60.0})
    assert isinstance(v.requirements, Requirements) and v.passed
    assert v.limiting("phase_margin_deg").required == 60.0


def test_an_unstable_loop_fails_its_sensitivity_requirements_everywhere(unstable):
    # before: the Ms and Mt rows said PASS (the peaks of unstable S and T on the imaginary axis,
    # -0.04 dB) under a verdict that counted them as failing
    assert not unstable.closed_loop_stable
    report = stability_report(unstable, requirements=Requirements(sensitivity_peak_db=6.0,
                                                                  complementary_sensitivity_peak_db=6.0))
    markdown = report.to_markdown()
    for label in ("sensitivity peak Ms [dB]", "compl. sensitivity peak Mt [dB]"):
        row = _row(markdown, label)
        assert row[4] == "none (unstable)" and row[5] == "FAIL (4 of 4)"  # 3 loops and all loops at once
    assert "FAIL: the closed loop is UNSTABLE, so no margin holds (8 required checks fail)." in markdown
    assert not report.passed and all(c.passed is False for c in report.verdicts.checks if c.required is not None)
    # the detail tables say none, not a disk margin of 0 or a peak that bounds nothing
    assert _row(markdown, "tx")[4:9] == ["none"] * 5
    assert _row(markdown, "balanced, each loop independently (diagonal)")[1:4] == ["none"] * 3
    assert "largest gain on the imaginary axis" in markdown and "H-infinity norm |" not in markdown


def test_an_unstable_crossing_has_no_delay_margin_and_no_unit_for_it(unstable):
    markdown = stability_report(unstable).to_markdown()
    crossing = _row(markdown, "1 | tx | gain crossover")
    assert crossing[6] == "none"   # before: "none s"
    assert "none s" not in markdown


@pytest.mark.parametrize("quantity", ["phase_margin_deg", "disk_margin", "complementary_sensitivity_peak_db"])
def test_a_value_that_rounds_to_its_bound_shows_the_digits_that_decide(attitude, quantity):
    value = verdicts(attitude).limiting(quantity).value
    # exactly at the bound: a margin "at least" its bound passes, a peak "at most" its bound too
    exact = verdicts(attitude, Requirements(**{quantity: value}))
    assert exact.passed and exact.limiting(quantity).slack == 0.0
    # the bound as printed (4 digits), just on the wrong side: it fails, and says so with the digits
    # that show why (before: "65.16 deg (>= 65.16)" next to FAIL)
    printed = float(f"{value:.4g}")
    report = stability_report(attitude, requirements=Requirements(**{quantity: printed}))
    check = report.verdicts.limiting(quantity)
    assert check.passed is False and check.value != printed
    label = next(label for label, _ in report.summary() if label.startswith("limiting") and quantity.split("_")[0]
                 in label.replace("compl.", "complementary"))
    text = dict(report.summary())[label]
    shown, bound = text.split(",")[0], text.split("required ")[1].split(":")[0]
    assert shown != f"{printed:g}" and float(shown) == pytest.approx(value, rel=1e-4)  # 5+ digits: within 1e-4
    assert bound.split()[1] == f"{printed:g}"
    assert f"{shown}" in report.front()[0].text  # the verdict line shows the same digits


def test_the_verdict_counts_one_requirement_and_one_body_in_the_singular(attitude):
    markdown = stability_report(attitude, requirements=Requirements(phase_margin_deg=30.0)).to_markdown()
    assert "PASS: all 3 checks of 1 requirement (phase margin) hold" in markdown
    assert "Plant: 1 body: hub" in markdown


def test_a_sensitivity_peak_above_15_db_and_its_bound_are_inside_the_figure(underdamped):
    # before: the axes ended at 15 dB, so the 24.4 dB peak, its label and a 20 dB requirement were cut off
    report = stability_report(underdamped, requirements=Requirements(sensitivity_peak_db=20.0))
    draw = dict(report.figures)["Sensitivity and complementary sensitivity"]
    fig = draw()
    try:
        ax_s, ax_t = fig.axes[:2]
        ms_db = 20 * np.log10(underdamped.peaks[0][0])
        mt_db = 20 * np.log10(underdamped.peaks[1][0])
        assert ms_db == pytest.approx(24.44, abs=0.01) and mt_db == pytest.approx(24.46, abs=0.01)
        top = ax_s.get_ylim()[1]
        assert top >= max(ms_db, mt_db) + 3.0  # room for the marker's label above it
        assert ax_t.get_ylim()[1] == top
        assert any(t.get_text() == f"Ms {ms_db:.2f} dB" for t in ax_s.texts)
        assert any(line.get_label() == "required ≤ 20 dB" for line in ax_s.lines)
    finally:
        plt.close(fig)


def test_nichols_legend_names_only_the_margins_required(attitude):
    report = stability_report(attitude, requirements=Requirements(phase_margin_deg=30.0))
    fig = dict(report.figures)["Nichols chart with the requirements' exclusion zone"]()
    try:
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert "excluded: |PM| < 30°" in labels  # before: "excluded: |PM| < 30°, |GM| < 0 dB"
        assert not any("GM" in label for label in labels)
    finally:
        plt.close(fig)


def test_bode_phase_note_sits_clear_of_the_critical_line(underdamped):
    # the phase stays just above -180 deg: before, the axes ended at -180 and the note sat on its line
    fig = dict(stability_report(underdamped).figures)["Bode diagram of each loop with every crossing and its margin"]()
    try:
        ax_phase = fig.axes[1]
        bottom, top = ax_phase.get_ylim()
        assert bottom <= -180.0 - 0.1 * (top - bottom)
    finally:
        plt.close(fig)


PDFTOTEXT = shutil.which("pdftotext")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(PDFTOTEXT is None or CHROMIUM is None, reason="needs pdftotext (poppler-utils) and chromium")
def test_no_pdf_page_ends_with_a_title_whose_table_is_on_the_next(sampled, tmp_path):
    # before: the sampled spacecraft's page 1 ended with the heading "Figures" and page 7 with the title
    # "What each step cost", each followed by its content on the next page
    report = stability_report(sampled)
    pdf = report.to_pdf(tmp_path / "report.pdf")
    text = subprocess.run([PDFTOTEXT, "-layout", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    pages = [page for page in text.split("\f") if page.strip()]
    titles = {t.title for t in report.tables()} | {"Figures", "Details"}
    assert len(pages) >= 6
    for k, page in enumerate(pages[:-1]):
        last = page.strip().splitlines()[-1].strip()
        assert last not in titles, f"page {k + 1} ends with the title {last!r}"


def test_z_plane_damping_labels_do_not_pile_up():
    # the sampled spacecraft's root-locus zoom (dt = 0.1 s, up to 1.1 x its 27.63 rad/s mode): the lightly
    # damped lines end together near z = -1; before, "ζ 0.005", "ζ 0.01", "ζ 0.02", "ζ 0.05" overprinted there
    from linflex.stability.report._figures import _z_damping_lines

    fig, ax = plt.subplots()
    try:
        _z_damping_lines(ax, 0.1, 1.1 * 27.63)
        spots = [complex(*t.get_position()) for t in ax.texts]
        assert len(ax.lines) == 8 and "ζ 0.005" in [t.get_text() for t in ax.texts]  # every line drawn
        assert min(abs(a - b) for i, a in enumerate(spots) for b in spots[:i]) > 0.1  # [z]: ~ a label's width
    finally:
        plt.close(fig)


def test_a_sampled_loop_bode_diagram_names_its_nyquist_frequency(sampled):
    # before: the curves stopped at 31.42 rad/s unexplained, with phase crossovers there (rows 8, 10, 16)
    assert sampled.loop.dt == 0.1
    fig = dict(stability_report(sampled).figures)["Bode diagram of each loop with every crossing and its margin"]()
    try:
        ax_mag, ax_phase = fig.axes[:2]
        labels = [t.get_text() for t in ax_mag.get_legend().get_texts()]
        assert "Nyquist frequency π/T = 31.42 rad/s (T = 0.1 s)" in labels
        for ax in (ax_mag, ax_phase):
            assert any(np.allclose(line.get_xdata(), np.pi / 0.1) for line in ax.lines if len(line.get_xdata()) == 2)
    finally:
        plt.close(fig)


def test_the_first_screen_says_how_unstable_the_closed_loop_is(unstable):
    # before: the HTML and Markdown said UNSTABLE but not how (the Nyquist count and the growing modes were in
    # the CLI's summary and a figure's panel titles only). Each axis: I s^2 + 70 s - 25 with I = 100, 120, 80 kg m^2
    # gives the same root s = (-70 + sqrt(70^2 + 4 * 25 * 100)) / 200 = 0.2603 1/s (kd and kp scale with I)
    root = (-70 + np.sqrt(70**2 + 4 * 25 * 100)) / 200
    markdown = stability_report(unstable).to_markdown()
    front = markdown.split("### Requirements")[0]
    assert "### Closed loop" in front
    assert (f"UNSTABLE, 3 unstable mode(s) (Nyquist: Z = N + P = 3 + 0); unstable eigenvalues {root:.4g}, "
            f"{root:.4g}, {root:.4g} [1/s].") in front
    html = stability_report(unstable).html_page()
    assert html.index("Nyquist: Z = N + P = 3 + 0") < html.index("<h2>Figures</h2>")


def test_a_scene_path_given_for_the_analysis_is_refused_with_the_way_out():
    # before: AttributeError: 'str' object has no attribute 'margins'
    with pytest.raises(TypeError, match=r"analysis must be a SceneAnalysis \(analyse_scene\(scene\)\), got str"):
        stability_report(str(ATTITUDE))


def test_detail_tables_speak_to_a_reviewer_not_to_the_code(attitude):
    # before: "open-loop RHP poles", a column named "[Hz]", and a note naming the function hinf_norm and "the engine's adaptive grid"
    tables = {t.title: t for t in stability_report(attitude).tables()}
    assert tables["Margins per loop"].header[-1] == "open-loop unstable poles"
    assert tables["Every crossing"].header[3:5] == ("frequency [rad/s]", "f [Hz]")  # before: a bare "[Hz]"
    note = tables["Sensitivity peaks (all loops)"].note
    assert "the H-infinity norm (the peak over every frequency, within 1e-6 of its certified bound)" in note
    assert "hinf_norm" not in note and "engine" not in note


def test_sweep_nichols_shows_the_same_zone_as_the_nominal_chart(attitude):
    # one drawing of the zone for both charts: before, the sweep's legend read "|PM| < 30°, |GM| < 0 dB"
    # and its chart left out the required Ms contour that the nominal chart draws
    from linflex.stability.report._sweep_figures import draw_sweep_nichols

    required = {"phase_margin_deg": 30.0, "sensitivity_peak_db": 6.0}
    curves = tuple((c.channel, (c.response,)) for c in attitude.channels)  # the nominal loop as a single case
    fig = draw_sweep_nichols(curves, attitude.channels, required)
    try:
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert "excluded: |PM| < 30°" in labels and "Ms = 6 dB contour" in labels
        assert not any("GM" in label for label in labels)
    finally:
        plt.close(fig)
