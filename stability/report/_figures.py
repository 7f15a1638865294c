"""The report's figures: pure drawing functions over the data :func:`analyse_scene` stored.

Layouts are fixed (``subplots_adjust``), not computed by ``tight_layout``: each figure is drawn
once, when it is saved.

Each channel is shown as its loop-at-a-time return ratio (that loop broken at its actuator, the
other loops closed), the transfer function whose margins the tables list. Nothing here computes
a response: every curve is a stored :class:`~linflex.frequency.FrequencyResponse`,
:class:`~linflex.frequency.NyquistResponse` or :class:`~linflex.frequency.RootLocus`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator

import numpy as np

from ._analysis import ROOT_LOCUS_GAINS, SceneAnalysis, phase_deg
from ._verdicts import Verdicts

__all__ = ["draw_bode", "draw_nichols", "draw_nyquist", "draw_root_locus", "draw_sensitivity", "report_figures"]

#: Damping ratios of the root-locus grid lines.
DAMPING_LINES = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4, 0.7)


def _critical_lines(ax, lo: float, hi: float, horizontal: bool = True) -> list[float]:
    """The -180 + k 360 deg lines inside [lo, hi], drawn and returned."""
    lines = [-180.0 + 360.0 * k for k in range(int(np.floor((lo + 180) / 360)), int(np.ceil((hi + 180) / 360)) + 1)]
    lines = [x for x in lines if lo - 1 <= x <= hi + 1]
    for x in lines:
        (ax.axhline if horizontal else ax.axvline)(x, color="k", lw=0.9, ls="--")
    return lines


def _label_slots(frequencies, min_decades: float = 0.16) -> list[int]:
    """A vertical slot per label so that labels closer than ``min_decades`` never share one."""
    placed: list[tuple[float, int]] = []
    slots = []
    for w in frequencies:
        x = np.log10(w)
        used = {slot for (y, slot) in placed if abs(y - x) < min_decades}
        slot = next(k for k in range(len(placed) + 1) if k not in used)
        placed.append((x, slot))
        slots.append(slot)
    return slots


def crossing_numbers(loops) -> list[tuple[str, str, float, int]]:
    """(loop, kind, frequency [rad/s], number) of every crossing, numbered as the table 'Every crossing'."""
    out = []
    for lm in loops:
        out += [(lm.channel, "gain crossover", float(w), 0) for w in lm.gain_crossovers]
        out += [(lm.channel, "phase crossover", float(w), 0) for w in lm.phase_crossovers]
    return [(c, k, w, i + 1) for i, (c, k, w, _) in enumerate(out)]


def draw_bode(channels, loops, dt: float | None = None):
    """Bode magnitude [dB] and phase [deg] of each loop, every crossing marked and numbered.

    Gain crossovers are dots at 0 dB with their phase margin as a bar on the phase plot, from
    the phase curve to its -180 + k 360 deg line; phase crossovers are squares. The numbers are
    the rows of the table 'Every crossing', stacked so that nearby ones never overlap. A sampled
    loop (``dt`` [s]) ends at its Nyquist frequency ``pi / dt`` [rad/s], drawn and named.
    """
    import matplotlib.pyplot as plt

    fig, (ax_mag, ax_phase) = plt.subplots(2, 1, sharex=True, figsize=(9, 7.5))
    numbers = {(c, k, w): n for c, k, w, n in crossing_numbers(loops)}
    labels = []  # (frequency, text, color)
    lo, hi = np.inf, -np.inf
    for k, (c, lm) in enumerate(zip(channels, loops)):
        color = f"C{k}"
        omega, values = c.response.omega, c.response.response[:, 0, 0]
        phase = phase_deg(values)
        lo, hi = min(lo, phase.min()), max(hi, phase.max())
        ax_mag.semilogx(omega, 20 * np.log10(np.abs(values)), color=color, lw=1.1, label=c.channel)
        ax_phase.semilogx(omega, phase, color=color, lw=1.1)
        for w, pm in zip(lm.gain_crossovers, lm.phase_margins):
            p = float(np.interp(np.log(w), np.log(omega), phase))
            target = p - pm  # the -180 + k 360 line this crossing's margin is measured to
            lo, hi = min(lo, target), max(hi, target)
            ax_mag.plot(w, 0.0, "o", color=color, ms=5)
            ax_phase.plot([w, w], [target, p], color=color, lw=3, alpha=0.55, solid_capstyle="butt")
            ax_phase.plot(w, p, "o", color=color, ms=4)
            labels.append((w, f"{numbers[(c.channel, 'gain crossover', float(w))]}: {pm:.0f}°", color))
        for w, gm in zip(lm.phase_crossovers, lm.gain_margins):
            ax_mag.plot(w, -20 * np.log10(gm), "s", color=color, ms=5)
            labels.append((w, f"{numbers[(c.channel, 'phase crossover', float(w))]}: {20 * np.log10(gm):+.1f} dB",
                           color))
    right = max(float(c.response.omega[-1]) for c in channels) / 10**0.2  # labels beyond: to the left
    starts = [w if w <= right else w / 10**0.45 for w, _, _ in labels]  # where each label's text begins
    order = np.argsort(starts)
    slots = _label_slots([starts[i] for i in order], min_decades=0.45)
    for i, slot in zip(order, slots):
        w, text, color = labels[i]
        ax_mag.annotate(text, (w, 0.0), xytext=(-3 if w > right else 3, 8 + 10 * slot), textcoords="offset points",
                        ha="right" if w > right else "left", fontsize=7,
                        color=color, arrowprops=dict(arrowstyle="-", color=color, lw=0.4, alpha=0.5),
                        bbox=dict(boxstyle="square,pad=0.05", fc="white", ec="none", alpha=0.85))
    ax_mag.axhline(0.0, color="k", lw=0.8)
    if dt is not None:  # where the curves end: a phase crossover there is the sampled loop's, not a cut
        for ax in (ax_mag, ax_phase):
            ax.axvline(np.pi / dt, color="0.3", lw=0.9, ls=":",
                       label=f"Nyquist frequency π/T = {np.pi / dt:.4g} rad/s (T = {dt:g} s)")
    ax_mag.set_ylabel("magnitude [dB]")
    ax_mag.grid(True, which="both", alpha=0.25)
    ax_mag.legend(title="loop broken at", fontsize=8, loc="lower left")
    ax_mag.set_title("Bode: loop-at-a-time return ratios; gain crossovers ● (n: PM), phase crossovers ■ (n: GM);\n"
                     "n = row of the table 'Every crossing'", fontsize=9)
    _critical_lines(ax_phase, lo, hi)
    ax_phase.set_ylabel("phase [deg]")
    ax_phase.set_xlabel("frequency [rad/s]")
    ticks = np.arange(90 * np.floor(lo / 90), 90 * np.ceil(hi / 90) + 1, 90)
    ax_phase.set_yticks(ticks)
    # a band below the lowest tick for the note, clear of the -180 deg line and the curves
    ax_phase.set_ylim(ticks[0] - 0.12 * (ticks[-1] - ticks[0]), ticks[-1] + 0.03 * (ticks[-1] - ticks[0]))
    ax_phase.grid(True, which="both", alpha=0.25)
    ax_phase.text(0.01, 0.02, "bars: phase margins, from the curve to the dashed -180° (+k 360°) line", fontsize=7,
                  transform=ax_phase.transAxes)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.07, hspace=0.06)
    return fig


def _nichols_grid(ax, lo: float, hi: float) -> None:
    """Closed-loop magnitude contours |L / (1 + L)| [dB] on the Nichols plane (as python-control's
    ``nichols_grid`` draws them; contoured here because importing python-control costs more than
    the whole report's drawing)."""
    phase = np.linspace(lo, hi, 361)
    mag_db = np.linspace(-40, 40, 321)
    P, M = np.meshgrid(np.radians(phase), 10 ** (mag_db / 20))
    L = M * np.exp(1j * P)
    T_db = 20 * np.log10(np.abs(L / (1 + L)))
    levels = [-20, -12, -6, -3, -1, 0, 0.25, 0.5, 1, 3, 6]
    lines = ax.contour(phase, mag_db, T_db, levels=levels, colors="0.6", linewidths=0.5, linestyles="dotted")
    ax.clabel(lines, fmt="%g dB", fontsize=6, inline=True)


def _exclusion_zones(ax, centres, requirements: dict) -> None:
    """The required margins around each critical point (``centres`` [deg], 0 dB) of a Nichols chart: the
    rectangle of the phase margin [deg] and gain margin [dB], and a required Ms's contour ``|1 + L| = 1/Ms``;
    the legend names only what is required."""
    from matplotlib.patches import Rectangle

    gm, pm = requirements.get("gain_margin_db"), requirements.get("phase_margin_deg")
    if gm or pm:
        dx, dy = (pm or 0.5), (gm or 0.25)
        for x in centres:
            ax.add_patch(Rectangle((x - dx, -dy), 2 * dx, 2 * dy, color="red", alpha=0.18, lw=0))
        zone = [*([f"|PM| < {pm:g}°"] if pm else []), *([f"|GM| < {gm:g} dB"] if gm else [])]
        ax.plot([], [], "s", color="red", alpha=0.3, label="excluded: " + ", ".join(zone))
    ms = requirements.get("sensitivity_peak_db")
    if ms:
        theta = np.linspace(0, 2 * np.pi, 361)
        L = -1 + 10 ** (-ms / 20) * np.exp(1j * theta)
        for x in centres:
            ph = np.degrees(np.angle(L * np.exp(-1j * np.pi))) + x
            ax.plot(ph, 20 * np.log10(np.abs(L)), color="red", lw=1.0, ls="-.")
        ax.plot([], [], color="red", lw=1.0, ls="-.", label=f"Ms = {ms:g} dB contour")


def draw_nichols(channels, requirements: dict):
    """Nichols chart with the closed-loop magnitude grid and the requirement's exclusion zone.

    The zone around each critical point (-180 + k 360 deg, 0 dB) is the rectangle of the
    required phase margin [deg] and gain margin [dB]; a required Ms adds its contour
    ``|1 + L| = 1/Ms``.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 6.5))
    lo, hi = np.inf, -np.inf
    for k, c in enumerate(channels):
        values = c.response.response[:, 0, 0]
        phase, mag = phase_deg(values), 20 * np.log10(np.abs(values))
        keep = np.abs(mag) < 40
        lo, hi = min(lo, phase[keep].min(initial=-180)), max(hi, phase[keep].max(initial=-180))
        ax.plot(phase, mag, color=f"C{k}", lw=1.2, label=c.channel)
    lo, hi = 45 * np.floor(min(lo, -200) / 45), 45 * np.ceil(max(hi, -160) / 45)
    ax.set_xlim(lo, hi)
    ax.set_ylim(-40, 40)
    _nichols_grid(ax, lo, hi)
    _exclusion_zones(ax, _critical_lines(ax, lo, hi, horizontal=False), requirements)
    ax.set_xlabel("phase [deg]")
    ax.set_ylabel("magnitude [dB]")
    ax.set_title("Nichols: loop-at-a-time return ratios; dotted: closed-loop |L/(1+L)| [dB]", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    fig.subplots_adjust(left=0.08, right=0.98, top=0.94, bottom=0.08)
    return fig


def draw_nyquist(channels, requirements_of):
    """One Nyquist panel per loop near -1: the contour's image, the unit circle, the -1 point,
    the encirclement count, and the required Ms circle ``|1 + L| = 1/Ms`` when there is one."""
    import matplotlib.pyplot as plt

    n = len(channels)
    fig, axes = plt.subplots(1, n, figsize=(4.0 * n, 4.4), squeeze=False)
    theta = np.linspace(0, 2 * np.pi, 361)
    for k, (ax, c) in enumerate(zip(axes[0], channels)):
        ny = c.nyquist
        values = c.response.response[:, 0, 0]  # dense across every resonance
        ax.plot(values.real, values.imag, color=f"C{k}", lw=1.0)
        ax.plot(values.real, -values.imag, color=f"C{k}", lw=0.8, ls=":")
        ax.plot(np.cos(theta), np.sin(theta), color="0.5", lw=0.8, ls="--")
        ax.plot(-1, 0, "r+", ms=12, mew=2)
        ms = requirements_of(c.channel).get("sensitivity_peak_db")
        if ms:
            r = 10 ** (-ms / 20)
            ax.fill(-1 + r * np.cos(theta), r * np.sin(theta), color="red", alpha=0.15, lw=0)
        ax.set_xlim(-3.0, 1.5)
        ax.set_ylim(-2.25, 2.25)
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.25)
        ax.set_title(f"loop broken at {c.channel}\nN = {ny.encirclements}, P = {ny.open_loop_unstable_poles}, "
                     f"Z = {ny.closed_loop_unstable_poles}", fontsize=9)
        ax.set_xlabel("Re L")
    axes[0][0].set_ylabel("Im L")
    fig.suptitle("Nyquist near -1 (dashed: unit circle; dotted: negative frequencies"
                 + ("; red: |1 + L| < 1/Ms required" if any(requirements_of(c.channel).get("sensitivity_peak_db")
                                                            for c in channels) else "") + ")", fontsize=9)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.80, bottom=0.11, wspace=0.22)
    return fig


def _damping_lines(ax, xlim, ylim) -> None:
    for zeta in DAMPING_LINES:
        # the ray s = r (-zeta + j sqrt(1 - zeta^2)), cut at the window's edges
        slope = np.sqrt(1 - zeta**2) / zeta
        r_end = min(-xlim[0] / zeta, max(abs(ylim[0]), abs(ylim[1])) / np.sqrt(1 - zeta**2))
        for sign in (1, -1):
            ax.plot([0, -zeta * r_end], [0, sign * slope * zeta * r_end], color="0.6", lw=0.5, ls=":")
        y = min(ylim[1] * 0.97, slope * -xlim[0] * 0.97)
        x = -y / slope
        if xlim[0] < x < xlim[1] and y > 0:
            ax.text(x, y, f"ζ {zeta:g}", fontsize=6, color="0.35", ha="right", va="top")


def _z_damping_lines(ax, dt: float, top: float) -> None:
    """The damping lines of a sampled loop's z plane, ``z = exp(s dt)`` along each ray
    ``s = w (-zeta + j sqrt(1 - zeta^2))`` up to ``top`` [rad/s] (at most the Nyquist frequency)."""
    labelled: list[complex] = []
    for zeta in DAMPING_LINES:
        wd_max = min(top, np.pi / dt)
        w = np.linspace(0.0, wd_max / np.sqrt(1 - zeta**2), 200)
        z = np.exp(w * (-zeta + 1j * np.sqrt(1 - zeta**2)) * dt)
        ax.plot(z.real, z.imag, color="0.6", lw=0.5, ls=":")
        if all(abs(z[-1] - other) > 0.1 for other in labelled):  # lightly damped lines end together: one label
            labelled.append(z[-1])
            ax.text(z[-1].real, z[-1].imag, f"ζ {zeta:g}", fontsize=6, color="0.35", ha="right", va="bottom")


def draw_root_locus(channel, nominal: np.ndarray, flexible_top: float, dt: float | None = None):
    """Root locus of one loop's gain (0.01 to 20 times the nominal; the others nominal).

    Left: every branch. Right: near the imaginary axis up to the highest lightly damped mode,
    where the flexible branches are, with damping lines. A sampled loop (``dt`` [s]) is drawn
    in the z plane: the unit circle is the stability boundary, the zoom is the arc
    ``exp(j w dt)`` up to that mode (or the Nyquist frequency ``pi / dt``), and the damping lines
    are their images ``exp(s dt)``.
    """
    import matplotlib.pyplot as plt

    locus = channel.locus
    roots = np.asarray(locus.roots)
    fig, (ax_all, ax_zoom) = plt.subplots(1, 2, figsize=(10, 5), gridspec_kw={"width_ratios": [1, 1.4]})
    oscillatory = nominal[np.abs(nominal.imag) > 1e-9]
    if dt is None:
        x_zoom = -1.6 * max(float(np.max(-oscillatory.real, initial=0.0)), 1e-3) if oscillatory.size else -1.0
        y_zoom = 1.1 * max(flexible_top, float(np.max(np.abs(oscillatory.imag), initial=1.0)))
    for ax in (ax_all, ax_zoom):
        for j in range(roots.shape[1]):
            ax.plot(roots[:, j].real, roots[:, j].imag, color="C0", lw=0.8)
        ax.plot(locus.open_loop_poles.real, locus.open_loop_poles.imag, "x", color="k", ms=6, label="gain 0")
        if locus.open_loop_zeros.size:
            ax.plot(locus.open_loop_zeros.real, locus.open_loop_zeros.imag, "o", mfc="none", color="k", ms=6,
                    label="zeros (gain -> inf)")
        ax.plot(roots[-1].real, roots[-1].imag, ".", color="C1", ms=5, label=f"gain {ROOT_LOCUS_GAINS[-1]:g}x")
        ax.plot(nominal.real, nominal.imag, "s", color="C3", ms=4, label="nominal (1x)")
        ax.axhline(0, color="k", lw=0.5)
        ax.grid(True, alpha=0.2)
        if dt is None:
            ax.axvline(0, color="k", lw=0.7)
            ax.set_xlabel("real [1/s]")
        else:
            theta = np.linspace(0.0, 2 * np.pi, 721)
            ax.plot(np.cos(theta), np.sin(theta), color="k", lw=0.7)
            ax.set_xlabel("real z [-]")
    if dt is None:
        ax_zoom.set_xlim(x_zoom, -0.1 * x_zoom)
        ax_zoom.set_ylim(-0.02 * y_zoom, y_zoom)
        _damping_lines(ax_zoom, ax_zoom.get_xlim(), ax_zoom.get_ylim())
        ax_all.set_ylabel("imaginary [rad/s]")
        ax_zoom.set_title("zoom: flexible branches near the imaginary axis, damping lines", fontsize=9)
    else:
        angle = min(np.pi, 1.1 * flexible_top * dt)  # the arc exp(j w dt) up to the highest flexible mode
        arc = np.exp(1j * np.linspace(0.0, angle, 100))
        ax_zoom.set_xlim(min(float(arc.real.min()), 0.0) - 0.1, 1.1)
        ax_zoom.set_ylim(-0.05, max(float(arc.imag.max()), 0.2) + 0.1)
        _z_damping_lines(ax_zoom, dt, 1.1 * flexible_top)
        ax_all.set_xlim(-1.3, 1.3)
        ax_all.set_ylim(-1.3, 1.3)
        ax_all.set_aspect("equal")
        ax_all.set_ylabel("imaginary z [-]")
        ax_zoom.set_title("zoom: the unit circle up to the flexible modes, damping lines exp(s dt)", fontsize=9)
    ax_all.set_title("all branches" + ("" if dt is None else " (z plane, unit circle)"), fontsize=9)
    ax_all.legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Root locus: gain of the loop broken at {channel.channel} scaled by 0 to "
                 f"{ROOT_LOCUS_GAINS[-1]:g} (other loops nominal)"
                 + ("" if dt is None else f"; sampled loop, dt = {dt:g} s"), fontsize=10)
    fig.subplots_adjust(left=0.07, right=0.99, top=0.87, bottom=0.1, wspace=0.15)
    return fig


def draw_sensitivity(analysis_sensitivity, analysis_complementary, output_sensitivity, channels, requirements: dict,
                     peaks=None):
    """Largest singular values of S and T (plant input; S at the sensors too) and each loop's
    |S_k|, |T_k| [dB], with the required peaks as lines; the peaks marked are ``peaks`` (the
    H-infinity norms and their frequencies, :attr:`SceneAnalysis.peaks`), else the grid's."""
    import matplotlib.pyplot as plt

    fig, (ax_s, ax_t) = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    marked = [15.0]  # [dB] the top of the axes: above every marked peak and required line
    for ax, mimo, per, name, key, top in ((ax_s, analysis_sensitivity, "sensitivity", "S", "sensitivity_peak_db",
                                           peaks[0] if peaks else None),
                                          (ax_t, analysis_complementary, "complementary_sensitivity", "T",
                                           "complementary_sensitivity_peak_db", peaks[1] if peaks else None)):
        for k, c in enumerate(channels):
            r = getattr(c, per)
            ax.semilogx(r.omega, 20 * np.log10(np.abs(r.response[:, 0, 0])), color=f"C{k}", lw=0.9,
                        label=f"|{name}| of {c.channel}")
        if mimo is not None:
            sigma = np.linalg.svd(mimo.response, compute_uv=False)
            ax.semilogx(mimo.omega, 20 * np.log10(sigma[:, 0]), color="k", lw=1.4, label=f"σmax {name}_i (input)")
            k = int(np.argmax(sigma[:, 0]))
            value, at = top if top is not None and np.isfinite(top[1]) else (sigma[k, 0], mimo.omega[k])
            ax.plot(at, 20 * np.log10(value), "kv")
            marked.append(20 * np.log10(value) + 5.0)  # room for its label
            ax.annotate(f"M{name.lower()} {20 * np.log10(value):.2f} dB", (at, 20 * np.log10(value)),
                        xytext=(4, 6), textcoords="offset points", fontsize=7)
        if name == "S" and output_sensitivity is not None:
            sigma = np.linalg.svd(output_sensitivity.response, compute_uv=False)
            ax.semilogx(output_sensitivity.omega, 20 * np.log10(sigma[:, 0]), color="0.4", lw=1.0, ls="--",
                        label="σmax S_o (sensors)")
        if requirements.get(key) is not None:
            ax.axhline(requirements[key], color="red", lw=1.0, ls="-.", label=f"required ≤ {requirements[key]:g} dB")
            marked.append(requirements[key] + 3.0)
        ax.grid(True, which="both", alpha=0.25)
        ax.set_xlabel("frequency [rad/s]")
        ax.legend(fontsize=7, loc="lower right")
    ax_s.set_ylim(-40, 5 * np.ceil(max(x for x in marked if np.isfinite(x)) / 5))  # shared by both axes
    ax_s.set_ylabel("magnitude [dB]")
    ax_s.set_title("sensitivity S", fontsize=9)
    ax_t.set_title("complementary sensitivity T", fontsize=9)
    fig.subplots_adjust(left=0.07, right=0.99, top=0.93, bottom=0.12, wspace=0.05)
    return fig


def report_figures(analysis: SceneAnalysis, checked: Verdicts | None = None) -> Iterator[tuple[str, Callable]]:
    """(title, draw) for each figure of the report: drawing functions bound to stored data."""
    if not analysis.channels:
        return
    requirements = checked.requirements.global_values() if checked is not None else {}

    def of(channel):
        return checked.requirements.for_loop(channel) if checked is not None else {}

    channels, loops = analysis.channels, analysis.margins.loops
    yield "Bode diagram of each loop with every crossing and its margin", \
        functools.partial(draw_bode, channels, loops, analysis.loop.dt)
    yield "Nichols chart with the requirements' exclusion zone", functools.partial(draw_nichols, channels, requirements)
    yield "Nyquist diagram of each loop near -1", functools.partial(draw_nyquist, channels, of)
    yield "Sensitivity and complementary sensitivity", functools.partial(
        draw_sensitivity, analysis.sensitivity, analysis.complementary_sensitivity, analysis.output_sensitivity,
        channels, requirements, analysis.peaks)
    table, dt = analysis.closed_loop_modes, analysis.loop.dt
    nominal = np.asarray(table.eigenvalues if dt is None else table.z_eigenvalues)
    nominal = np.concatenate([nominal, np.conj(nominal[np.abs(nominal.imag) > 0])])
    flexible = [m.natural_frequency for m in analysis.plant_modes if m.kind == "oscillatory"]
    top = max(flexible, default=1.0)
    for c in channels:
        yield f"Root locus of the loop broken at {c.channel}", functools.partial(draw_root_locus, c, nominal, top, dt)
