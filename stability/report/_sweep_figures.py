"""The sweep section's figures: pure drawing functions over a stored :class:`SweepAnalysis`.

Histograms of each margin across the cases with the required bound; per loop the min/max band of
the return ratio over the cases on the Bode plane, and every case's curve on the Nichols plane (a
per-frequency band there is a phase-magnitude rectangle, which covers half the chart wherever a
resonance moves between cases); the nominal curve on top.
Nothing here computes a response.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator

import numpy as np

from linflex.scene import REQUIREMENTS

from ._analysis import SceneAnalysis, phase_deg, summary_metrics
from ._figures import _critical_lines, _exclusion_zones, _nichols_grid
from ._sweep import SweepAnalysis
from ._sweep_section import SWEEP_MARGINS
from ._verdicts import LABELS

__all__ = ["draw_sweep_bode", "draw_sweep_histograms", "draw_sweep_nichols", "sweep_figures"]


def draw_sweep_histograms(table, requirements: dict, nominal: dict):
    """One histogram per margin over the cases that ran, with the required bound (red) and the
    nominal value (black); infinite values (no crossing) are counted in the title."""
    import matplotlib.pyplot as plt

    quantities = [q for q in SWEEP_MARGINS if q in table.metrics]
    fig, axes = plt.subplots(1, len(quantities), figsize=(3.1 * len(quantities), 3.3), squeeze=False)
    ok = np.array([e is None for e in table.errors], dtype=bool)
    for ax, q in zip(axes[0], quantities):
        column = table.column(q)[ok]
        finite = column[np.isfinite(column)]
        bound = requirements.get(q)
        if finite.size:
            lo, hi = float(finite.min()), float(finite.max())
            if bound is not None:
                lo, hi = min(lo, bound), max(hi, bound)
            pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi) * 0.05, 1e-3)
            ax.hist(finite, bins=min(30, max(5, int(np.sqrt(finite.size)) + 1)), range=(lo - pad, hi + pad),
                    color="C0", alpha=0.75)
        if bound is not None:
            failing = int(np.sum(~(column >= bound))) if REQUIREMENTS[q][1] == ">=" else int(np.sum(~(column <= bound)))
            ax.axvline(bound, color="red", lw=1.6, ls="-.", label=f"required ≥ {bound:g} ({failing} below)")
        if nominal.get(q) is not None and np.isfinite(nominal[q]):
            ax.axvline(nominal[q], color="k", lw=1.2, label=f"nominal {nominal[q]:.4g}")
        if not finite.size:
            ax.text(0.5, 0.5, f"{int(np.sum(np.isinf(column)))} of {column.size} cases: inf\n(no crossing)"
                    if np.isinf(column).any() else "no value", ha="center", va="center", transform=ax.transAxes,
                    fontsize=9)
        extra = [f"{int(np.sum(np.isinf(column)))} inf"] if np.isinf(column).any() else []
        extra += [f"{int(np.sum(np.isnan(column)))} none"] if np.isnan(column).any() else []
        ax.set_title(f"{LABELS[q]}" + (f" ({', '.join(extra)})" if extra else ""), fontsize=9)
        ax.set_xlabel(f"[{REQUIREMENTS[q][0]}]")
        ax.grid(True, alpha=0.25)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6.5, loc="upper right")
    axes[0][0].set_ylabel("cases")
    fig.suptitle(f"Margins over {int(ok.sum())} cases (smallest over the loops per case)", fontsize=10)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.82, bottom=0.16, wspace=0.28)
    return fig


def draw_sweep_bode(envelopes, channels):
    """Per loop: the band of |L_k| [dB] and its phase [deg] over the cases, the nominal curve on top."""
    import matplotlib.pyplot as plt

    fig, (ax_mag, ax_phase) = plt.subplots(2, 1, sharex=True, figsize=(9, 7))
    nominal = {c.channel: c for c in channels}
    lo, hi = np.inf, -np.inf
    for k, e in enumerate(envelopes):
        color = f"C{k}"
        ax_mag.fill_between(e.omega, e.magnitude_db[:, 0], e.magnitude_db[:, 1], color=color, alpha=0.25, lw=0,
                            label=f"{e.channel}: band over {e.n_cases} cases")
        ax_phase.fill_between(e.omega, e.phase_deg[:, 0], e.phase_deg[:, 1], color=color, alpha=0.25, lw=0)
        finite = e.phase_deg[np.isfinite(e.phase_deg)]
        lo, hi = min(lo, finite.min(initial=-180)), max(hi, finite.max(initial=-180))
        if e.channel in nominal:
            r = nominal[e.channel].response
            values = r.response[:, 0, 0]
            ax_mag.semilogx(r.omega, 20 * np.log10(np.abs(values)), color=color, lw=1.0, label=f"{e.channel}: nominal")
            ax_phase.semilogx(r.omega, phase_deg(values), color=color, lw=1.0)
    ax_mag.set_xscale("log")
    ax_mag.axhline(0.0, color="k", lw=0.8)
    ax_mag.set_ylabel("magnitude [dB]")
    ax_mag.grid(True, which="both", alpha=0.25)
    ax_mag.legend(fontsize=7, loc="lower left", ncol=2)
    resolution = max((e.resolution_db for e in envelopes if np.isfinite(e.resolution_db)), default=float("nan"))
    ax_mag.set_title("Bode envelopes: loop-at-a-time return ratios, min/max over the cases (shaded) and nominal (line)"
                     + (f";\npeaks of every case resolved to {resolution:.2g} dB" if np.isfinite(resolution) else ""),
                     fontsize=9)
    _critical_lines(ax_phase, lo, hi)
    ax_phase.set_yticks(np.arange(90 * np.floor(lo / 90), 90 * np.ceil(hi / 90) + 1, 90))
    ax_phase.set_ylabel("phase [deg]")
    ax_phase.set_xlabel("frequency [rad/s]")
    ax_phase.grid(True, which="both", alpha=0.25)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.07, hspace=0.06)
    return fig


def draw_sweep_nichols(curves, channels, requirements: dict):
    """Every case's return ratio of each loop on the Nichols plane (thin), the nominal one on top, with
    the closed-loop grid and the requirements' exclusion zone.

    ``curves``: per loop, ``(channel, responses)`` with one stored response per case that ran. A
    per-frequency min/max band would cover whole phase-magnitude rectangles wherever a resonance
    moves between cases (the phase turns by 180 deg across it), so the cases' curves are drawn.
    """
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.patheffects import withStroke

    fig, ax = plt.subplots(figsize=(9, 6.5))
    nominal = {c.channel: c for c in channels}
    lo, hi = np.inf, -np.inf
    for k, (channel, responses) in enumerate(curves):
        lines = []
        for r in responses:
            values = r.response[:, 0, 0]
            phase, mag = phase_deg(values), 20 * np.log10(np.abs(values))
            keep = np.abs(mag) < 40
            if keep.any():
                lo, hi = min(lo, phase[keep].min()), max(hi, phase[keep].max())
            lines.append(np.stack([phase, mag], axis=1))
        # fainter as the cases grow, so that a dense family still shows where most curves run
        ax.add_collection(LineCollection(lines, colors=f"C{k}", linewidths=0.5,
                                         alpha=float(np.clip(8.0 / max(len(lines), 1), 0.05, 0.35)), zorder=1))
        ax.plot([], [], color=f"C{k}", lw=0.6, alpha=0.5, label=f"{channel}: {len(responses)} cases")
        if channel in nominal:
            values = nominal[channel].response.response[:, 0, 0]
            ax.plot(phase_deg(values), 20 * np.log10(np.abs(values)), color=f"C{k}", lw=1.6, zorder=3,
                    label=f"{channel}: nominal", path_effects=[withStroke(linewidth=3.2, foreground="white")])
    lo, hi = 45 * np.floor(min(lo, -200) / 45), 45 * np.ceil(max(hi, -160) / 45)
    ax.set_xlim(lo, hi)
    ax.set_ylim(-40, 40)
    _nichols_grid(ax, lo, hi)
    _exclusion_zones(ax, _critical_lines(ax, lo, hi, horizontal=False), requirements)
    ax.set_xlabel("phase [deg]")
    ax.set_ylabel("magnitude [dB]")
    ax.set_title("Nichols: each loop's return ratio in every case (thin) and nominal (bold); "
                 "dotted: closed-loop |L/(1+L)| [dB]", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    fig.subplots_adjust(left=0.08, right=0.98, top=0.94, bottom=0.08)
    return fig


def sweep_figures(sweep: SweepAnalysis, analysis: SceneAnalysis, nominal) -> Iterator[tuple[str, Callable]]:
    """(title, draw) of each sweep figure; ``nominal`` is the nominal report's Verdicts."""
    requirements = nominal.requirements.global_values() if nominal is not None else {}
    values = summary_metrics(analysis)  # the nominal case, as each case's row of the table
    yield f"Sweep: margins over the {sweep.n_cases} cases with the required bounds", \
        functools.partial(draw_sweep_histograms, sweep.table, requirements, values)
    if sweep.envelopes:
        yield "Sweep: Bode envelopes of the loops", functools.partial(draw_sweep_bode, sweep.envelopes,
                                                                      analysis.channels)
        curves = tuple((e.channel, tuple(r[k] for r in sweep.responses if r is not None))
                       for k, e in enumerate(sweep.envelopes))
        yield "Sweep: Nichols chart of the loops in every case", functools.partial(
            draw_sweep_nichols, curves, analysis.channels, requirements)
