"""Drawing of frequency-domain results: pure functions of a result, no computation.

The results' ``.plot()`` methods and the public ``*_plot`` functions (:mod:`._plot`, which
compute a result from a system first) draw through these. This module imports no computing
module, so results may import it (lazily) without an import circle. matplotlib is imported when
drawing; degrees, dB and Hz appear only here.
"""

from __future__ import annotations

import numpy as np

from linflex.system import PlotHandle, plot_axes

__all__ = ["draw_bode", "draw_bode_envelope", "draw_nichols", "draw_nyquist", "draw_root_locus", "draw_sigma",
           "unwrapped_phase"]


def unwrapped_phase(g, axis: int = -1):
    """Unwrapped phase [rad] of the complex values ``g`` along ``axis``, NaN where ``g`` is not
    finite (a pole on a grid point): ``numpy.unwrap`` alone carries one NaN into every later
    value, so the finite values are unwrapped among themselves."""
    g = np.moveaxis(np.asarray(g, dtype=complex), axis, -1)
    out = np.full(g.shape, np.nan)
    for idx in np.ndindex(g.shape[:-1]):
        finite = np.isfinite(g[idx])
        out[idx + (finite,)] = np.unwrap(np.angle(g[idx][finite]))
    return np.moveaxis(out, -1, axis)


def _label(fr, o, i):
    return f"{fr.inputs[i]} -> {fr.outputs[o]}" if fr.response.shape[1:] != (1, 1) else None


def draw_bode(fr, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Bode plot of the FrequencyResponse ``fr``; see :func:`linflex.frequency.bode_plot`."""
    fig, (ax_m, ax_p) = plot_axes(ax, 2)
    f = fr.omega / (2 * np.pi) if hz else fr.omega
    lines = []
    for o in range(fr.response.shape[1]):
        for i in range(fr.response.shape[2]):
            g = fr.response[:, o, i]
            with np.errstate(divide="ignore"):
                # the caller's label and color win over the defaults; the phase line takes the
                # magnitude line's color and no legend entry of its own
                (lm,) = ax_m.semilogx(f, 20 * np.log10(np.abs(g)), **{"label": _label(fr, o, i), **line_kw})
            phase_kw = {k: v for k, v in line_kw.items() if k != "label"} | {"color": lm.get_color()}
            (lp,) = ax_p.semilogx(f, np.degrees(unwrapped_phase(g)), **phase_kw)
            lines += [lm, lp]
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [Hz]" if hz else "frequency [rad/s]")
    if getattr(fr, "dt", None) is not None:  # a sampled system: its response ends at the Nyquist frequency
        nyquist = np.pi / fr.dt / (2 * np.pi) if hz else np.pi / fr.dt
        for a in (ax_m, ax_p):
            a.axvline(nyquist, color="0.5", linewidth=0.8, linestyle=":")
    if fr.response.shape[1:] != (1, 1):
        ax_m.legend(fontsize="small")
    return PlotHandle(fig, (ax_m, ax_p), tuple(lines), fr)


def draw_nichols(fr, *, ax=None, **line_kw) -> PlotHandle:
    """Nichols plot of the SISO FrequencyResponse ``fr``; see :func:`linflex.frequency.nichols_plot`."""
    fig, (axn,) = plot_axes(ax, 1)
    phase = np.degrees(fr.phase)
    with np.errstate(divide="ignore"):
        (line,) = axn.plot(phase, 20 * np.log10(fr.magnitude), **line_kw)
    # the unwrapped phase starts in (-180, 180]: a loop with a lag on a double integrator runs from
    # +180 deg down, so the critical point is marked at every -180 + k 360 deg less than half a
    # turn from the curve's phase range (at -180 deg when there is none)
    finite = phase[np.isfinite(phase)]
    turns = (np.arange(np.floor(finite.min() / 360.0) + 1, np.ceil((finite.max() + 360.0) / 360.0))
             if finite.size else np.zeros(0))
    centres = -180.0 + 360.0 * turns if turns.size else np.array([-180.0])
    (crit,) = axn.plot(centres, np.zeros_like(centres), "r+", markersize=10, linestyle="none")
    axn.set_xlabel("phase [deg]")
    axn.set_ylabel("gain [dB]")
    return PlotHandle(fig, (axn,), (line, crit), fr)


def draw_nyquist(nr, *, ax=None, max_magnitude: float = 20.0, **line_kw) -> PlotHandle:
    """Nyquist plot of the NyquistResponse ``nr``; see :func:`linflex.frequency.nyquist_plot`."""
    fig, (axq,) = plot_axes(ax, 1)
    v = np.asarray(nr.values)
    mag = np.abs(v)
    big = mag > max_magnitude
    with np.errstate(divide="ignore", invalid="ignore"):
        squash = np.where(big, max_magnitude * (1 + np.log(mag / max_magnitude)) / mag, 1.0)
    w = v * squash
    inner = np.where(big, np.nan, w)
    outer = np.where(big, w, np.nan)
    (l1,) = axq.plot(inner.real, inner.imag, **line_kw)
    (l2,) = axq.plot(outer.real, outer.imag, linestyle="--", color=l1.get_color())
    (crit,) = axq.plot([-1.0], [0.0], "r+", markersize=10)
    axq.set_xlabel("real")
    axq.set_ylabel("imaginary")
    axq.set_title(
        f"N = {nr.encirclements}, P = {nr.open_loop_unstable_poles}, Z = N + P = {nr.closed_loop_unstable_poles}"
    )
    return PlotHandle(fig, (axq,), (l1, l2, crit), nr)


def draw_sigma(fr, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Singular values of the FrequencyResponse ``fr``; see :func:`linflex.frequency.sigma_plot`."""
    fig, (axs,) = plot_axes(ax, 1)
    sv = fr.singular_values()
    f = fr.omega / (2 * np.pi) if hz else fr.omega
    lines = []
    for k in range(sv.shape[1]):
        with np.errstate(divide="ignore"):
            (line,) = axs.semilogx(f, 20 * np.log10(sv[:, k]), **{"label": f"sigma_{k + 1}", **line_kw})
        lines.append(line)
    axs.set_xlabel("frequency [Hz]" if hz else "frequency [rad/s]")
    axs.set_ylabel("singular values [dB]")
    return PlotHandle(fig, (axs,), tuple(lines), fr)


def draw_root_locus(rl, *, ax=None, **line_kw) -> PlotHandle:
    """Root locus of the RootLocus ``rl``; see :func:`linflex.frequency.root_locus_plot`."""
    fig, (axr,) = plot_axes(ax, 1)
    lines = []
    for j in range(rl.roots.shape[1]):
        (line,) = axr.plot(rl.roots[:, j].real, rl.roots[:, j].imag, **line_kw)
        lines.append(line)
    (lp,) = axr.plot(rl.open_loop_poles.real, rl.open_loop_poles.imag, "kx", linestyle="none")
    (lz,) = axr.plot(rl.open_loop_zeros.real, rl.open_loop_zeros.imag, "ko", fillstyle="none", linestyle="none")
    if getattr(rl, "dt", None) is not None:  # a sampled loop: roots in z, stable inside the unit circle
        theta = np.linspace(0.0, 2 * np.pi, 361)
        axr.plot(np.cos(theta), np.sin(theta), color="0.5", linewidth=0.8, linestyle=":")
        axr.set_aspect("equal", adjustable="datalim")
        axr.set_xlabel("real [-] (z)")
        axr.set_ylabel("imaginary [-] (z)")
    else:
        axr.set_xlabel("real [1/s]")
        axr.set_ylabel("imaginary [rad/s]")
    return PlotHandle(fig, (axr,), tuple(lines) + (lp, lz), rl)


def draw_bode_envelope(responses, *, output: int = 0, input: int = 0, nominal: int = 0, ax=None, hz: bool = False,
                       color: str = "C0") -> PlotHandle:
    """Envelope of FrequencyResponses sharing one ``omega``; see :func:`linflex.frequency.bode_envelope_plot`."""
    w = responses[0].omega
    G = np.array([fr.response[:, output, input] for fr in responses])
    with np.errstate(divide="ignore"):
        mag = 20 * np.log10(np.abs(G))
    phase = np.degrees(unwrapped_phase(G, axis=1))
    # each case unwrapped from its own first angle in (-180, 180]: cases on either side of -180 deg
    # there would span a false 360 deg band; shift each by whole turns onto the nominal's branch
    finite = np.all(np.isfinite(phase), axis=0)
    if np.any(finite):
        k = int(np.argmax(finite))
        phase -= 360.0 * np.round((phase[:, k] - phase[nominal, k]) / 360.0)[:, None]
    fig, (ax_m, ax_p) = plot_axes(ax, 2)
    f = w / (2 * np.pi) if hz else w
    ax_m.fill_between(f, mag.min(axis=0), mag.max(axis=0), color=color, alpha=0.25, lw=0,
                      label=f"{len(responses)} cases")
    ax_p.fill_between(f, phase.min(axis=0), phase.max(axis=0), color=color, alpha=0.25, lw=0)
    (lm,) = ax_m.semilogx(f, mag[nominal], color=color, label="nominal")
    (lp,) = ax_p.semilogx(f, phase[nominal], color=color)
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [Hz]" if hz else "frequency [rad/s]")
    ax_m.legend(fontsize="small")
    return PlotHandle(fig, (ax_m, ax_p), (lm, lp), tuple(responses))
