"""The report's sweep section (``linflex report SCENE --sweep SPEC``): its numbers against ``linflex sweep``'s
table computed independently (``margin_summary`` per case), in the Markdown, the HTML and the PDF text."""

import csv
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from linflex import ModelError, load_scene
from linflex.cli import main
from linflex.stability.report import analyse_scene, analyse_sweep, stability_report
from linflex.stability.report._analysis import phase_deg
from linflex.sweeps import vary_scene

SCENE = Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml"
#: 4 cases: the x axis' PD gains; kp = 60 with kd = 30 leaves about 22 deg of phase margin
SPEC = 'analysis = "margins"\n[grid]\n"controllers.attitude_pd.kp[0]" = [25.0, 60.0]\n' \
       '"controllers.attitude_pd.kd[0]" = [30.0, 70.0]\n'
REQUIRED_PM = 50.0  # [deg]


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The report with its sweep (CLI) and, independently, ``linflex sweep``'s CSV of the same spec."""
    folder = tmp_path_factory.mktemp("sweep")
    spec = folder / "spec.toml"
    spec.write_text(SPEC)
    code = main(["report", str(SCENE), "--sweep", str(spec), "--require", f"phase_margin_deg={REQUIRED_PM}",
                 "-o", str(folder / "report")])
    assert main(["sweep", str(SCENE), str(spec), "-o", str(folder / "table.csv"), "--processes", "1"]) == 0
    with open(folder / "table.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    with open(folder / "report" / "sweep.csv", newline="") as handle:  # the report's own table
        own = list(csv.DictReader(handle))
    assert [{k: v for k, v in r.items() if k != "seconds"} for r in own] == \
        [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    return code, folder / "report", rows


def _numbers(text):
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


def test_sweep_section_numbers_are_those_of_linflex_sweep(swept):
    code, report, rows = swept
    pm = np.array([float(r["phase_margin_deg"]) for r in rows])
    dm = np.array([float(r["delay_margin_s"]) for r in rows])
    passing = int(np.sum(pm >= REQUIRED_PM))
    assert 0 < passing < len(rows)  # the spec straddles the requirement
    assert code == 1  # a case fails: the exit code says so, though the nominal design passes
    worst = int(np.argmin(pm))
    markdown = (report / "report.md").read_text()
    assert f"FAIL: {passing} of {len(rows)} cases meet every requirement." in markdown
    table = markdown[markdown.index("### Sweep: margins across the cases"):markdown.index("### Sweep: worst case")]
    spread = {line.split(" | ")[0].lstrip("| "): line.split(" | ") for line in table.splitlines()
              if line.startswith(("| phase margin [deg]", "| delay margin [s]"))}
    # min, median, max over the cases (4 significant digits), from the independent table
    for name, column in (("phase margin [deg]", pm), ("delay margin [s]", dm)):
        row = spread[name]
        assert [float(row[k]) for k in (3, 4, 5)] == pytest.approx(
            [column.min(), np.median(column), column.max()], rel=1e-3)
    worst_table = markdown[markdown.index("### Sweep: worst case"):]
    worst_row = next(line for line in worst_table.splitlines() if line.startswith("| phase margin [deg] | >= 50"))
    cells = worst_row.split(" | ")
    assert cells[2] == f"{passing} of {len(rows)}" and int(cells[3]) == worst
    assert float(cells[4]) == pytest.approx(pm[worst], rel=1e-3)
    # the worst case's parameter values, named
    for name in ("controllers.attitude_pd.kp[0]", "controllers.attitude_pd.kd[0]"):
        assert f"{name} = {float(rows[worst][name]):.6g}" in cells[6]


def test_sweep_section_in_html_and_pdf(swept):
    _, report, rows = swept
    page = (report / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 7 + 3  # the nominal figures, histograms, Bode, Nichols
    sweep = page[page.index("<section id='sweep'"):page.index('<section id="details"')]
    pm = min(float(r["phase_margin_deg"]) for r in rows)
    assert f"<td>{pm:.4g}</td>" in sweep and "Sweep: Nichols chart of the loops in every case" in sweep
    if shutil.which("pdftotext") is None:
        pytest.skip("pdftotext is not installed")
    text = subprocess.run(["pdftotext", "-layout", str(report / "report.pdf"), "-"], capture_output=True,
                          text=True, check=True).stdout
    passing = sum(float(r["phase_margin_deg"]) >= REQUIRED_PM for r in rows)
    assert f"FAIL: {passing} of {len(rows)} cases meet every requirement." in " ".join(text.split())
    assert f"{pm:.4g}" in text and "Sweep over 4 cases" in text
    worst = min(rows, key=lambda r: float(r["phase_margin_deg"]))  # its parameter values, named
    flat = "".join(text.split())
    for name in ("controllers.attitude_pd.kp[0]", "controllers.attitude_pd.kd[0]"):
        assert f"{name}={float(worst[name]):.6g}" in flat
    assert "|---" not in text and "###" not in text  # printed HTML, not Markdown


def test_envelopes_hold_every_case_and_failures_are_recorded():
    cases = [{"controllers.attitude_pd.kp[0]": k, "bodies.hub.mass": m} for k, m in ((20.0, 1500.0), (45.0, -1.0),
                                                                                     (35.0, 1200.0))]
    s = analyse_sweep(SCENE, cases)
    assert s.n_cases == 3 and s.table.n_failed == 1 and s.checks[1] is None and s.responses[1] is None
    assert "mass" in s.table.errors[1]
    # each case's return ratios, recomputed from its varied scene (not read from the sweep)
    recomputed = {i: {c.channel: c.response for c in analyse_scene(vary_scene(load_scene(SCENE), cases[i]),
                                                                   stiffness_by_origin=False).channels}
                  for i in (0, 2)}
    for k, e in enumerate(s.envelopes):
        assert e.n_cases == 2
        for i in (0, 2):
            response = recomputed[i][e.channel]
            assert np.array_equal(response.omega, s.responses[i][k].omega)
            values = response.response[:, 0, 0]
            at = np.isin(e.omega, response.omega)  # the envelope's grid holds every case's own points
            assert at.sum() == response.omega.size
            mag = 20 * np.log10(np.abs(values))
            assert np.all(e.magnitude_db[at, 0] <= mag + 1e-9) and np.all(mag <= e.magnitude_db[at, 1] + 1e-9)
            ph = phase_deg(values)
            assert np.all(e.phase_deg[at, 0] <= ph + 1e-9) and np.all(ph <= e.phase_deg[at, 1] + 1e-9)
    # the Python entry: a report over the same cases; the failed case is listed and fails the count
    report = stability_report(analyse_scene(SCENE), sweep=s)
    assert not report.passed or report.sweep_checks[1] is None
    titles = [p.title for p in report.sweep_section()]
    assert "Sweep: cases that failed to run" in titles
    assert "1 case(s) failed to run" in report.sweep_section()[0].text


def test_a_spec_for_another_analysis_or_a_wrong_path_is_refused(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text('analysis = "other"\n[grid]\n"bodies.hub.mass" = [1.0]\n')
    with pytest.raises(ModelError, match="other"):
        analyse_sweep(SCENE, spec)
    with pytest.raises(ModelError, match="no_such_body"):
        analyse_sweep(SCENE, [{"bodies.no_such_body.mass": 1.0}])
    assert main(["report", str(SCENE), "--sweep", str(spec), "-o", str(tmp_path / "out")]) == 2
    assert main(["report", str(SCENE), "--processes", "2", "-o", str(tmp_path / "out")]) == 2


@pytest.mark.slow
def test_worker_processes_give_the_serial_result():
    cases = [{"controllers.attitude_pd.kd[1]": kd} for kd in (40.0, 90.0)]
    serial, parallel = analyse_sweep(SCENE, cases, processes=1), analyse_sweep(SCENE, cases, processes=2)
    assert parallel.table.backend == "processes" and serial.table.backend == "serial"
    np.testing.assert_array_equal(parallel.table.results, serial.table.results)
    assert [repr(v.checks) for v in parallel.checks] == [repr(v.checks) for v in serial.checks]  # nan == nan
    for a, b in zip(parallel.envelopes, serial.envelopes):
        np.testing.assert_array_equal(a.magnitude_db, b.magnitude_db)


def test_a_binned_envelope_still_holds_every_point_of_every_case():
    from linflex.frequency import FrequencyResponse
    from linflex.stability.report._sweep import ENVELOPE_POINTS, _envelope

    responses = []
    for i, wn in enumerate((2.0, 2.3, 2.6)):
        omega = np.geomspace(0.01 * (1 + 0.1 * i), 100.0, 1000)  # grids differ: the union has 3000 points
        s = 1j * omega
        g = 1.0 / (s**2 + 0.02 * wn * s + wn**2) / s
        responses.append(FrequencyResponse(omega, g[:, None, None], ("y",), ("u",), "direct", 0.0, "user",
                                           float("nan"), omega.size, 0.0))
    e = _envelope("u", responses)
    assert e.omega.size <= ENVELOPE_POINTS and e.n_cases == 3
    # the bins as the docstring defines them: equal widths in log frequency over the union grid
    union = np.unique(np.concatenate([r.omega for r in responses]))
    edges = np.linspace(np.log(union[0]), np.log(union[-1]), ENVELOPE_POINTS + 1)
    starts = np.unique(np.searchsorted(np.log(union), edges[:-1]))
    assert starts.size == e.omega.size
    for r in responses:
        values = r.response[:, 0, 0]
        j = np.searchsorted(starts, np.searchsorted(union, r.omega), side="right") - 1  # each point's bin
        for band, y in ((e.magnitude_db, 20 * np.log10(np.abs(values))), (e.phase_deg, phase_deg(values))):
            assert np.all(band[j, 0] <= y) and np.all(y <= band[j, 1])
