"""The report's figures: the frequency layer's plots of the analysed loop, with the margins marked.

Each channel is shown as its loop-at-a-time return ratio (that channel cut at the plant input,
the other loops closed), the same transfer function whose margins the tables list.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from linflex.frequency import (
    bode_plot,
    frequency_response,
    nichols_plot,
    nyquist_plot,
    nyquist_response,
    root_locus,
    root_locus_plot,
    transfer_function,
)

from ._analysis import SceneAnalysis

ROOT_LOCUS_GAINS = np.concatenate([[0.0], np.geomspace(0.01, 20.0, 80)])  # multiples of the nominal gain


def _channels(analysis: SceneAnalysis):
    """Per channel: name, loop-at-a-time return ratio and its frequency response (computed once)."""
    loop = analysis.loop
    out = []
    for actuator in loop.actuators:
        L = transfer_function(loop, "quasi_open_loop", opened=[actuator])
        out.append((actuator, L, frequency_response(L)))
    return out


def _bode(analysis, channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, (ax_mag, ax_phase) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6))
        for (name, _, response), margins in zip(channels, analysis.margins.loops):
            handle = bode_plot(response, ax=(ax_mag, ax_phase))
            handle.lines[0].set_label(name)
            color = handle.lines[0].get_color()
            for w, pm in zip(margins.gain_crossovers, margins.phase_margins):
                ax_mag.plot(w, 0.0, "o", color=color)
                ax_mag.annotate(f"PM {pm:.1f}°", (w, 0.0), textcoords="offset points", xytext=(4, 6),
                                fontsize=8, color=color)
            for w, gm in zip(margins.phase_crossovers, margins.gain_margins):
                ax_mag.plot(w, -20 * np.log10(gm), "s", color=color)
        ax_mag.axhline(0.0, color="k", lw=0.6)
        ax_mag.legend(title="loop broken at", fontsize=8)
        ax_mag.set_title("Bode: loop-at-a-time return ratios (gain crossovers ●, phase crossovers ■)")
        return fig

    return draw


def _nichols(channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 5.5))
        for name, _, response in channels:
            nichols_plot(response, ax=ax).lines[0].set_label(name)
        ax.legend(title="loop broken at", fontsize=8)
        return fig

    return draw


def _nyquist(channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.5, 6))
        for name, L, _ in channels:
            nyquist_plot(nyquist_response(L), ax=ax, max_magnitude=5.0).lines[0].set_label(name)
        # The margins live near -1; the rigid-body indentation's large arc is off this window.
        ax.set_xlim(-3.0, 1.5)
        ax.set_ylim(-2.5, 2.5)
        ax.set_aspect("equal")
        ax.legend(title="loop broken at", fontsize=8)
        return fig

    return draw


def _root_locus(analysis) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 5.5))
        # Gains as multiples of the nominal controller, 0.01 to 20: the design's neighbourhood,
        # with the nominal closed-loop poles marked.
        root_locus_plot(root_locus(analysis.loop, gains=ROOT_LOCUS_GAINS), ax=ax)
        nominal = analysis.closed_loop_modes.eigenvalues
        ax.plot(nominal.real, nominal.imag, "rx", label="nominal gain")
        ax.plot(nominal.real, -nominal.imag, "rx")
        ax.legend(fontsize=8)
        return fig

    return draw


def report_figures(analysis: SceneAnalysis) -> Iterator[tuple[str, Callable]]:
    """(title, draw) for each figure of the report; drawing happens when called."""
    channels = _channels(analysis)
    yield "Bode diagram with margins", _bode(analysis, channels)
    yield "Nichols chart", _nichols(channels)
    yield "Nyquist diagram near -1", _nyquist(channels)
    yield "Root locus over the loop gain", _root_locus(analysis)
