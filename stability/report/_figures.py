"""The report's figures, drawn from the analysis: Bode, Nichols, Nyquist and root locus.

Each channel is shown as its loop-at-a-time return ratio (that channel cut at the plant input,
the other loops closed), the same transfer function whose margins the tables list, with the
crossings of the margin tables marked.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from linflex.frequency import FrequencyResponse, Loop, frequency_response, transfer_function

from ._analysis import SceneAnalysis

ROOT_LOCUS_GAINS = np.geomspace(0.05, 20.0, 81)  # multiples of the nominal controller gain


def _channel_responses(analysis: SceneAnalysis) -> list[tuple[str, FrequencyResponse]]:
    """Each channel's loop-at-a-time return ratio and its frequency response (computed once)."""
    loop = analysis.loop
    return [(actuator, frequency_response(transfer_function(loop, "quasi_open_loop", opened=[actuator])))
            for actuator in loop.actuators]


def _bode(analysis, channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, (ax_mag, ax_phase) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6))
        for (name, response), margins in zip(channels, analysis.margins.loops):
            line, = ax_mag.semilogx(response.omega, 20 * np.log10(response.magnitude), label=name)
            phase = np.degrees(response.phase)
            phase -= 360 * np.round((phase[0] + 180) / 360)  # start near -180 (type-2 loops)
            ax_phase.semilogx(response.omega, phase, color=line.get_color())
            for w, pm in zip(margins.gain_crossovers, margins.phase_margins):
                ax_mag.plot(w, 0.0, "o", color=line.get_color())
                ax_phase.annotate(f"PM {pm:.1f}°", (w, -180 + pm), fontsize=8, color=line.get_color())
            for w in margins.phase_crossovers:
                ax_phase.plot(w, -180.0, "s", color=line.get_color())
        ax_mag.axhline(0.0, color="k", lw=0.6)
        ax_phase.axhline(-180.0, color="k", lw=0.6)
        ax_mag.set_ylabel("|L| [dB]")
        ax_phase.set_ylabel("phase [deg]")
        ax_phase.set_xlabel("frequency [rad/s]")
        ax_mag.legend(title="loop broken at", fontsize=8)
        ax_mag.set_title("Bode: loop-at-a-time return ratios (gain crossovers ●, phase crossovers ■)")
        return fig

    return draw


def _nichols(analysis, channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 5.5))
        for name, response in channels:
            phase = np.degrees(response.phase)
            phase -= 360 * np.round((phase[0] + 180) / 360)
            ax.plot(phase, 20 * np.log10(response.magnitude), label=name)
        ax.plot(-180, 0, "r+", markersize=14, mew=2)
        ax.set_xlabel("phase [deg]")
        ax.set_ylabel("|L| [dB]")
        ax.set_title("Nichols (critical point +)")
        ax.grid(True, lw=0.3)
        ax.legend(title="loop broken at", fontsize=8)
        return fig

    return draw


def _nyquist(analysis, channels) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.5, 6))
        for name, response in channels:
            G = response.response[:, 0, 0]
            near = np.abs(G) < 50  # the rigid-body branch leaves towards infinity: keep the window
            line, = ax.plot(G.real[near], G.imag[near], label=name)
            ax.plot(G.real[near], -G.imag[near], color=line.get_color(), ls="--", lw=0.7)
        circle = np.exp(1j * np.linspace(0, 2 * np.pi, 200))
        ax.plot(circle.real, circle.imag, color="0.7", lw=0.6)
        ax.plot(-1, 0, "r+", markersize=14, mew=2)
        ax.set_xlim(-3, 1.5)
        ax.set_ylim(-2.5, 2.5)
        ax.set_aspect("equal")
        ax.set_xlabel("Re L")
        ax.set_ylabel("Im L")
        m = analysis.margins
        ax.set_title(f"Nyquist near -1 (open-loop RHP poles {m.open_loop_rhp_poles}, "
                     f"encirclements {m.nyquist_encirclements})")
        ax.legend(title="loop broken at", fontsize=8)
        return fig

    return draw


def _root_locus(analysis) -> Callable:
    def draw():
        import matplotlib.pyplot as plt

        loop = analysis.loop
        K = loop.controller
        fig, ax = plt.subplots(figsize=(7, 5.5))
        branches = []
        for k in ROOT_LOCUS_GAINS:
            scaled = Loop(loop.plant, K.with_(C=k * K.C, D=k * K.D), sensors=loop.sensors, actuators=loop.actuators)
            branches.append(np.linalg.eigvals(transfer_function(scaled, "closed_loop").A))
        points = np.concatenate(branches)
        scatter = ax.scatter(points.real, points.imag, c=np.repeat(np.log10(ROOT_LOCUS_GAINS), len(branches[0])),
                             s=4, cmap="viridis")
        nominal = analysis.closed_loop_modes.eigenvalues
        ax.plot(nominal.real, nominal.imag, "rx", label="nominal gain")
        ax.plot(nominal.real, -nominal.imag, "rx")
        ax.axvline(0.0, color="k", lw=0.6)
        fig.colorbar(scatter, ax=ax, label="log10(gain / nominal)")
        ax.set_xlabel("Re [1/s]")
        ax.set_ylabel("Im [rad/s]")
        ax.set_title("Root locus over the controller gain")
        ax.legend(fontsize=8)
        return fig

    return draw


def report_figures(analysis: SceneAnalysis) -> Iterator[tuple[str, Callable]]:
    """(title, draw) for each figure of the report; drawing happens when called."""
    channels = _channel_responses(analysis)
    yield "Bode diagram with margins", _bode(analysis, channels)
    yield "Nichols chart", _nichols(analysis, channels)
    yield "Nyquist diagram", _nyquist(analysis, channels)
    yield "Root locus", _root_locus(analysis)
