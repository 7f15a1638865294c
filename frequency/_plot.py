"""Bode, Nichols, Nyquist, singular-value and root-locus plots.

matplotlib is imported inside the functions only (``import linflex`` must not load it). Each
function draws on ``ax`` when given (else on a new figure), returns a :class:`PlotHandle`, never
calls ``plt.show()`` and never changes ``rcParams``. Degrees, dB and Hz appear here only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from linflex import ModelError

from ._locus import RootLocus, root_locus
from ._nyquist import NyquistResponse, nyquist_response
from ._response import FrequencyResponse, frequency_response

__all__ = ["PlotHandle", "bode_plot", "nichols_plot", "nyquist_plot", "sigma_plot", "root_locus_plot"]


@dataclass(frozen=True)
class PlotHandle:
    """What a plot function drew.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
    axes : tuple of matplotlib.axes.Axes
    lines : tuple of matplotlib.lines.Line2D
        The data lines, in the order documented by each function.
    data : object
        The analysis result that was drawn (FrequencyResponse, NyquistResponse or RootLocus).
    """

    figure: Any
    axes: tuple
    lines: tuple
    data: Any


def _axes(ax, n: int):
    import matplotlib.pyplot as plt

    if ax is None:
        fig, axs = plt.subplots(n, 1, sharex=n > 1, squeeze=False)
        return fig, tuple(axs[:, 0])
    axs = tuple(ax) if isinstance(ax, (list, tuple, np.ndarray)) else (ax,)
    if len(axs) != n:
        raise ModelError(f"ax must be {n} matplotlib axes for this plot, got {len(axs)}")
    return axs[0].figure, axs


def _response(data) -> FrequencyResponse:
    return data if isinstance(data, FrequencyResponse) else frequency_response(data)


def _label(fr, o, i):
    return f"{fr.inputs[i]} -> {fr.outputs[o]}" if fr.response.shape[1:] != (1, 1) else None


def bode_plot(data, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Bode plot: magnitude [dB] and unwrapped phase [deg] against frequency, every channel.

    Parameters
    ----------
    data : FrequencyResponse or a linear system
        A system is evaluated with :func:`frequency_response` (automatic grid).
    ax : pair of matplotlib axes, optional
        Magnitude and phase axes.
    hz : bool, optional
        Frequency axis in Hz instead of rad/s.
    **line_kw
        Passed to ``Axes.semilogx``.

    Returns
    -------
    PlotHandle
        ``lines`` holds, per channel (outputs outer, inputs inner), the magnitude then the phase line.
    """
    fr = _response(data)
    fig, (ax_m, ax_p) = _axes(ax, 2)
    f = fr.omega / (2 * np.pi) if hz else fr.omega
    lines = []
    for o in range(fr.response.shape[1]):
        for i in range(fr.response.shape[2]):
            g = fr.response[:, o, i]
            with np.errstate(divide="ignore"):
                (lm,) = ax_m.semilogx(f, 20 * np.log10(np.abs(g)), label=_label(fr, o, i), **line_kw)
            (lp,) = ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(g))), color=lm.get_color(), **line_kw)
            lines += [lm, lp]
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [Hz]" if hz else "frequency [rad/s]")
    if fr.response.shape[1:] != (1, 1):
        ax_m.legend(fontsize="small")
    return PlotHandle(fig, (ax_m, ax_p), tuple(lines), fr)


def nichols_plot(data, *, ax=None, **line_kw) -> PlotHandle:
    """Nichols plot of a SISO response: gain [dB] against unwrapped phase [deg].

    Returns
    -------
    PlotHandle
        ``lines`` holds the curve, then the marker of the critical point (-180 deg, 0 dB).

    Raises
    ------
    ModelError
        For a MIMO response.
    """
    fr = _response(data)
    fig, (axn,) = _axes(ax, 1)
    with np.errstate(divide="ignore"):
        (line,) = axn.plot(np.degrees(fr.phase), 20 * np.log10(fr.magnitude), **line_kw)
    (crit,) = axn.plot([-180.0], [0.0], "r+", markersize=10)
    axn.set_xlabel("phase [deg]")
    axn.set_ylabel("gain [dB]")
    return PlotHandle(fig, (axn,), (line, crit), fr)


def nyquist_plot(data, *, ax=None, max_magnitude: float = 20.0, **line_kw) -> PlotHandle:
    """Nyquist plot with indentations around imaginary-axis poles and the encirclement count.

    Parameters
    ----------
    data : NyquistResponse, Loop or loop transfer function
        Anything else than a :class:`NyquistResponse` goes through :func:`nyquist_response`.
    max_magnitude : float, optional
        Points farther than this from the origin (near indented poles) are drawn radially
        compressed onto ``max_magnitude * (1 + log(|L| / max_magnitude))``, dashed, so the
        contour stays readable; the encirclement count is computed on the true values.

    Returns
    -------
    PlotHandle
        ``lines``: the contour image for the contour as traversed (solid where ``|L|`` is below
        ``max_magnitude``), its compressed part (dashed), then the critical point -1.
        The title reports N, P and Z = N + P.
    """
    nr = data if isinstance(data, NyquistResponse) else nyquist_response(data)
    fig, (axq,) = _axes(ax, 1)
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


def sigma_plot(data, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Singular values of ``G(j omega)`` [dB] against frequency (MIMO gain envelope).

    Returns
    -------
    PlotHandle
        One line per singular value, largest first.
    """
    fr = _response(data)
    fig, (axs,) = _axes(ax, 1)
    sv = fr.singular_values()
    f = fr.omega / (2 * np.pi) if hz else fr.omega
    lines = []
    for k in range(sv.shape[1]):
        with np.errstate(divide="ignore"):
            (line,) = axs.semilogx(f, 20 * np.log10(sv[:, k]), label=f"sigma_{k + 1}", **line_kw)
        lines.append(line)
    axs.set_xlabel("frequency [Hz]" if hz else "frequency [rad/s]")
    axs.set_ylabel("singular values [dB]")
    return PlotHandle(fig, (axs,), tuple(lines), fr)


def root_locus_plot(data, *, ax=None, **line_kw) -> PlotHandle:
    """Root locus: one line per branch, open-loop poles (x) and zeros (o).

    Parameters
    ----------
    data : RootLocus, Loop or loop transfer function
        Anything else than a :class:`RootLocus` goes through :func:`root_locus`.

    Returns
    -------
    PlotHandle
        ``lines``: the branches in the order of ``RootLocus.roots`` columns, then the pole and
        zero markers.
    """
    rl = data if isinstance(data, RootLocus) else root_locus(data)
    fig, (axr,) = _axes(ax, 1)
    lines = []
    for j in range(rl.roots.shape[1]):
        (line,) = axr.plot(rl.roots[:, j].real, rl.roots[:, j].imag, **line_kw)
        lines.append(line)
    (lp,) = axr.plot(rl.open_loop_poles.real, rl.open_loop_poles.imag, "kx", linestyle="none")
    (lz,) = axr.plot(rl.open_loop_zeros.real, rl.open_loop_zeros.imag, "ko", fillstyle="none", linestyle="none")
    axr.set_xlabel("real [1/s]")
    axr.set_ylabel("imaginary [rad/s]")
    return PlotHandle(fig, (axr,), tuple(lines) + (lp, lz), rl)
