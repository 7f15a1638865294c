"""Results in a notebook: short reprs (a few lines, under 600 characters) and compact HTML tables
(``_repr_html_``) that parse, escape their text and show the key numbers (linflex/system/_display.py)."""

from __future__ import annotations

import html.parser
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, NonlinearModel, parameter_grid, simulate, sweep
from linflex.frequency import frequency_response, nyquist_response, root_locus
from linflex.stability import modes, stability_margins
from linflex.stability.report import analyse_scene, analyse_sweep, stability_report
from linflex.system import display_value, html_summary, short_repr

SCENE = Path(__file__).resolve().parents[1] / "examples" / "attitude_control.toml"
LIMIT = 600  # [characters]


class Page(html.parser.HTMLParser):
    """Checks that every tag closes in order (void elements aside) and collects the text."""

    VOID = {"br", "hr", "img", "meta"}

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.open: list[str] = []
        self.text: list[str] = []
        self.tags = 0
        self.feed(text)
        self.close()
        assert not self.open, f"unclosed tags {self.open}"

    def handle_starttag(self, tag, attrs):
        self.tags += 1
        if tag not in self.VOID:
            self.open.append(tag)

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, f"</{tag}> closes {self.open[-1:]}"
        self.open.pop()

    def handle_data(self, data):
        self.text.append(data)

    @property
    def cells(self) -> list[str]:
        return [t for t in self.text if t.strip()]


@pytest.fixture(scope="module")
def analysis():
    return analyse_scene(SCENE)


def _results(analysis):
    loop = analysis.channels[0].return_ratio
    decay = NonlinearModel(lambda x, u, t: -x, states=["x<1>"])
    model = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0]]), states=["x"], params={"a": 1.0})

    def rate(m):
        return {"pole": -m.param_values[0]}

    return {
        "SceneAnalysis": analysis,
        "ModeTable": analysis.plant_modes,
        "FrequencyResponse": frequency_response(loop),
        "NyquistResponse": nyquist_response(loop),
        "RootLocus": root_locus(loop, np.geomspace(0.1, 10, 9)),
        "StabilityMargins": analysis.margins,
        "Linearization": analysis.plant,
        "TimeResponse": simulate(decay, np.linspace(0, 1, 11), [1.0], method="scipy-RK45"),
        "SweepResult": sweep(model, parameter_grid({"a": [1.0, 2.0, 3.0]}), rate, processes=1),
        "LinearSystem": analysis.open_loop,
        "SecondOrderSystem": analysis.plant.second_order,
        "StabilityReport": stability_report(analysis),
    }


def test_every_result_has_a_short_repr_and_an_html_table_that_parses(analysis):
    assert len(repr(analysis)) < LIMIT  # was 73,500 characters
    for name, result in _results(analysis).items():
        text = repr(result)
        assert text.startswith(name + "(") and len(text) <= LIMIT, (name, len(text))
        assert text.count("\n") <= 4
        page = Page(result._repr_html_())
        assert page.tags > 4 and page.cells[0].startswith(name), name
        assert len(result._repr_html_()) < 20_000, name  # compact: rows are cut after a dozen or two


def test_the_key_numbers_are_in_the_tables(analysis):
    results = _results(analysis)
    independent = stability_margins(analysis.open_loop)  # recomputed, not read from the analysis
    for name in ("SceneAnalysis", "StabilityMargins"):
        cells = Page(results[name]._repr_html_()).cells
        for loop in independent.loops:
            row = cells[cells.index(loop.channel):]
            assert row[1] == f"{loop.min_phase_margin:.4g}" and row[4] == f"{loop.delay_margin:.4g}"
        assert f"min_phase_margin={independent.min_phase_margin:.4g} deg" in repr(results[name])
    table = modes(analysis.loop.plant)
    cells = Page(results["ModeTable"]._repr_html_()).cells
    assert cells[cells.index("n_modes") + 1] == str(len(table.modes))
    assert cells[cells.index("n_rigid") + 1] == str(table.n_rigid)
    r = results["TimeResponse"]
    cells = Page(r._repr_html_()).cells
    row = cells[cells.index("x<1>"):]  # the name shown as text, escaped in the HTML
    assert row[1:4] == ["state", "1", f"{np.exp(-1.0):.4g}"]  # x(t) = exp(-t), to the integrator's rtol
    assert abs(r.x[-1, 0] - np.exp(-1.0)) < 1e-3
    assert "x&lt;1&gt;" in r._repr_html_()
    cells = Page(results["SweepResult"]._repr_html_()).cells
    assert cells[cells.index("pole"):][1:5] == ["metric", "-3", "-2", "-1"]  # -a over a = 1, 2, 3
    response = results["FrequencyResponse"]
    peak = np.max(np.abs(response.response[:, 0, 0]))
    assert f"{20 * np.log10(peak):.4g}" in Page(response._repr_html_()).cells


def test_sweep_analysis_and_report_reprs_stay_short():
    s = analyse_sweep(SCENE, [{"controllers.attitude_pd.kp[0]": k} for k in (20.0, 40.0)])
    assert len(repr(s)) <= LIMIT and repr(s).startswith("SweepAnalysis(n_cases=2, n_failed=0")
    Page(s._repr_html_())


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.text(max_size=30), st.one_of(st.text(max_size=120), st.floats(), st.integers(),
                                                          st.lists(st.text(max_size=8), max_size=9))), max_size=8),
       st.lists(st.lists(st.one_of(st.text(max_size=20), st.floats()), min_size=2, max_size=2), max_size=30))
def test_any_text_is_escaped_and_any_repr_is_bounded(fields, rows):
    page = Page(html_summary("<title & 'quotes'>", fields, ("a", "b"), rows, max_rows=12))
    shown = "".join(page.text)
    assert "<title & 'quotes'>" in shown  # escaped in the HTML, the same text once parsed
    for _, value in fields:
        assert display_value(value, width=240) in shown
    if len(rows) > 12:
        assert f"... {len(rows) - 12} more rows" in shown
    assert len(short_repr("Result", fields)) <= LIMIT
    assert len(repr(LinearSystem(np.zeros((0, 0)), np.zeros((0, 40)), np.zeros((40, 0)), np.zeros((40, 40)),
                                 inputs=[f"in{i}" for i in range(40)], outputs=[f"out{i}" for i in range(40)]))) < LIMIT
