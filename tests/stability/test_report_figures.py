"""The report's figures: drawn from stored data, every crossing labelled without overlaps."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex.stability.report import analyse_scene, stability_report

ARRAYS = Path(__file__).resolve().parents[2] / "examples" / "spacecraft_arrays.toml"


@pytest.fixture(scope="module")
def report():
    return stability_report(analyse_scene(ARRAYS))


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(st.floats(min_value=1e-3, max_value=1e3), min_size=1, max_size=12))
def test_labels_closer_than_the_spacing_never_share_a_slot(frequencies):
    from linflex.stability.report._figures import _label_slots

    frequencies = sorted(frequencies)
    slots = _label_slots(frequencies, min_decades=0.45)
    for i in range(len(frequencies)):
        for j in range(i):
            if abs(np.log10(frequencies[i] / frequencies[j])) < 0.45:
                assert slots[i] != slots[j]


def test_bode_marks_every_crossing_with_its_own_unoverlapping_label_and_the_critical_line(report):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title, draw = report.figures[0]
    assert title.startswith("Bode")
    fig = draw()
    try:
        fig.canvas.draw()
        ax_mag, ax_phase = fig.axes[:2]
        labels = [t for t in ax_mag.texts if ":" in t.get_text()]
        n_crossings = sum(lm.gain_crossovers.size + lm.phase_crossovers.size for lm in report.analysis.margins.loops)
        assert len(labels) == n_crossings == 11
        from matplotlib.text import Text

        renderer = fig.canvas.get_renderer()
        boxes = [Text.get_window_extent(t, renderer) for t in labels]  # the text, without its leader line
        for i in range(len(boxes)):
            for j in range(i):
                assert not boxes[i].overlaps(boxes[j]), (labels[i].get_text(), labels[j].get_text())
        # the -180 deg line is drawn on the phase plot
        assert any(np.allclose(line.get_ydata(), -180.0) for line in ax_phase.lines)
    finally:
        plt.close(fig)


def test_each_figure_is_drawn_once_per_written_report(report, tmp_path, monkeypatch):
    import dataclasses

    calls = []

    def counted(draw, title):
        def wrapper():
            calls.append(title)
            return draw()
        return wrapper

    fresh = dataclasses.replace(report, figures=tuple((t, counted(d, t)) for t, d in report.figures))
    fresh.write(tmp_path / "r")  # HTML, Markdown and the PDF printed from the HTML
    assert sorted(calls) == sorted(t for t, _ in report.figures)
    # Nyquist, root loci and responses are data of the analysis: drawing computes none
    import linflex.frequency as frequency

    for name in ("frequency_response", "nyquist_response", "root_locus"):
        monkeypatch.setattr(frequency, name, lambda *a, **k: pytest.fail("computed while drawing"))
    for _, draw in report.figures:
        import matplotlib.pyplot as plt

        plt.close(draw())


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(st.floats(min_value=-50, max_value=50), min_size=3, max_size=40),
       st.floats(min_value=0.1, max_value=20))
def test_peaks_and_prominences_are_those_of_scipy(values, prominence):
    import scipy.signal

    from linflex.stability.report._summary import _prominent_peaks

    values = np.asarray(values)
    expected, _ = scipy.signal.find_peaks(values, prominence=prominence, plateau_size=(1, 1))
    ours = [k for k in _prominent_peaks(values, prominence) if values[k] > values[k + 1]]  # plateaus aside
    assert ours == [int(k) for k in expected if values[k] > values[k - 1] and values[k] > values[k + 1]]
