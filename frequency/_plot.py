"""Bode, Nichols, Nyquist, singular-value and root-locus plots.

Each function takes a result or a system (computing the result first) and draws it with
:mod:`._draw`. matplotlib is imported when drawing (``import linflex`` must not load it); each
function draws on ``ax`` when given (else on a new figure), returns a
:class:`~linflex.system.PlotHandle`, never calls ``plt.show()`` and never changes ``rcParams``.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from linflex import ModelError
from linflex.system import PlotHandle, check_positive

from ._draw import draw_bode, draw_bode_envelope, draw_nichols, draw_nyquist, draw_root_locus, draw_sigma
from ._locus import RootLocus, root_locus
from ._nyquist import NyquistResponse, nyquist_response
from ._response import FrequencyResponse, frequency_response

__all__ = ["PlotHandle", "bode_envelope_plot", "bode_plot", "nichols_plot", "nyquist_plot", "sigma_plot", "root_locus_plot"]


def _response(result) -> FrequencyResponse:
    return result if isinstance(result, FrequencyResponse) else frequency_response(result)


def _label(fr, o, i):
    return f"{fr.inputs[i]} -> {fr.outputs[o]}" if fr.response.shape[1:] != (1, 1) else None


def bode_plot(result, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Bode plot: magnitude [dB] and unwrapped phase [deg] against frequency, every channel.

    Parameters
    ----------
    result : FrequencyResponse or a linear system
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

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import bode_plot
    >>> sys = LinearSystem([[0, 1], [-1, -0.2]], [[0], [1]], [[1, 0]])   # 1 rad/s, zeta = 0.1
    >>> h = bode_plot(sys)
    >>> len(h.lines), len(h.axes), type(h.data).__name__
    (2, 2, 'FrequencyResponse')
    >>> plt.close(h.figure)
    """
    return draw_bode(_response(result), ax=ax, hz=hz, **line_kw)



def bode_envelope_plot(results, omega=None, *, output: int = 0, input: int = 0, nominal: int = 0, ax=None,
                       hz: bool = False, color: str = "C0") -> PlotHandle:
    """Envelope of many Bode plots (a sweep's cases): the band between the smallest and largest
    magnitude [dB] and unwrapped phase [deg] at each frequency, with one nominal case drawn on it.

    Parameters
    ----------
    results : sequence of FrequencyResponse or of linear systems
        The cases; responses must share their ``omega``. Systems are evaluated at ``omega``.
    omega : array_like, optional
        Frequencies [rad/s] for systems; default: the ``omega`` of the responses among the cases,
        else the automatic grid of the nominal case.
    output, input : int
        The channel drawn.
    nominal : int
        Index of the case drawn as a line.
    ax : pair of matplotlib axes, optional
    hz : bool
        Frequency axis in Hz.
    color : str

    Returns
    -------
    PlotHandle
        ``lines``: the nominal magnitude and phase lines; ``data``: a tuple of the responses.

    Raises
    ------
    ModelError
        If ``results`` is not a sequence of cases or is empty, responses do not share their
        frequencies, or the channel or nominal index is not an integer in range.

    Examples
    --------
    Three oscillators whose stiffness is 0.8, 1 and 1.2 N/m (1 kg, zeta near 0.1):

    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import bode_envelope_plot
    >>> cases = [LinearSystem([[0, 1], [-k, -0.2]], [[0], [1]], [[1, 0]]) for k in (0.8, 1.0, 1.2)]
    >>> h = bode_envelope_plot(cases, nominal=1)
    >>> len(h.lines), len(h.data)
    (2, 3)
    >>> plt.close(h.figure)
    """
    if isinstance(results, FrequencyResponse) or not isinstance(results, Iterable):
        raise ModelError(f"bode_envelope_plot: results must be a sequence of cases (FrequencyResponse or linear "
                         f"systems), got one {type(results).__name__}; use bode_plot for a single case")
    cases = list(results)
    if not cases:
        raise ModelError("bode_envelope_plot: no cases")
    for name, value in (("nominal", nominal), ("output", output), ("input", input)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
            raise ModelError(f"bode_envelope_plot: {name} must be an integer index, got {value!r}")
    if not 0 <= nominal < len(cases):
        raise ModelError(f"bode_envelope_plot: nominal={nominal} but there are {len(cases)} cases")
    given = [c for c in cases if isinstance(c, FrequencyResponse)]
    if len(given) < len(cases):
        # systems are evaluated where the given responses are (or at omega, or on the nominal's grid)
        if omega is None:
            from ._response import frequency_grid

            omega = given[0].omega if given else frequency_grid(cases[nominal])
        responses = [c if isinstance(c, FrequencyResponse) else frequency_response(c, omega) for c in cases]
    else:
        responses = cases
    w = responses[0].omega
    for k, fr in enumerate(responses):
        if fr.omega.shape != w.shape or not np.array_equal(fr.omega, w):
            raise ModelError(f"bode_envelope_plot: response {k} has other frequencies than response 0; "
                             "evaluate every case at the same omega")
        shape = fr.response.shape[1:]
        if not (0 <= output < shape[0] and 0 <= input < shape[1]):
            raise ModelError(f"bode_envelope_plot: channel ({output}, {input}) outside the {shape} response {k}")
    return draw_bode_envelope(responses, output=output, input=input, nominal=nominal, ax=ax, hz=hz, color=color)



def nichols_plot(result, *, ax=None, **line_kw) -> PlotHandle:
    """Nichols plot of a SISO response: gain [dB] against unwrapped phase [deg].

    Parameters
    ----------
    result : FrequencyResponse or a linear system
        A system is evaluated with :func:`frequency_response` (automatic grid).
    ax : matplotlib axes, optional
    **line_kw
        Passed to ``Axes.plot``.

    Returns
    -------
    PlotHandle
        ``lines`` holds the curve, then the markers of the critical point (-180 + k 360 deg,
        0 dB) less than half a turn from the curve's phases (the unwrapped phase starts in
        (-180, 180] deg: a lagging loop on a double integrator starts near +180 deg).

    Raises
    ------
    ModelError
        For a MIMO response.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import nichols_plot
    >>> L = LinearSystem([[0, 1], [0, -1]], [[0], [1]], [[4, 0]])   # 4 / (s (s + 1))
    >>> h = nichols_plot(L)
    >>> len(h.lines)
    2
    >>> plt.close(h.figure)
    """
    fr = _response(result)
    if fr.response.shape[1:] != (1, 1):
        raise ModelError(f"nichols_plot draws one channel: this response has {fr.response.shape[1]} outputs and "
                         f"{fr.response.shape[2]} inputs; pass sys.subsystem(outputs=..., inputs=...) of one channel")
    return draw_nichols(fr, ax=ax, **line_kw)



def nyquist_plot(result, *, ax=None, max_magnitude: float = 20.0, **line_kw) -> PlotHandle:
    """Nyquist plot with indentations around imaginary-axis poles and the encirclement count.

    Parameters
    ----------
    result : NyquistResponse, Loop or loop transfer function
        Anything else than a :class:`NyquistResponse` goes through :func:`nyquist_response`.
    ax : matplotlib axes, optional
    max_magnitude : float, optional
        Points farther than this from the origin (near indented poles) are drawn radially
        compressed onto ``max_magnitude * (1 + log(|L| / max_magnitude))``, dashed, so the
        contour stays readable; the encirclement count is computed on the true values.
    **line_kw
        Passed to ``Axes.plot``.

    Returns
    -------
    PlotHandle
        ``lines``: the contour image for the contour as traversed (solid where ``|L|`` is below
        ``max_magnitude``), its compressed part (dashed), then the critical point -1.
        The title reports N, P and Z = N + P.

    Raises
    ------
    ModelError
        If ``max_magnitude`` is not a positive finite number.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import nyquist_plot
    >>> L = LinearSystem([[0, 1], [0, -1]], [[0], [1]], [[4, 0]])   # 4 / (s (s + 1)): a pole at 0
    >>> h = nyquist_plot(L)
    >>> len(h.lines), h.data.closed_loop_unstable_poles
    (3, 0)
    >>> h.axes[0].get_title()
    'N = 0, P = 0, Z = N + P = 0'
    >>> plt.close(h.figure)
    """
    max_magnitude = check_positive(max_magnitude, "max_magnitude")
    nr = result if isinstance(result, NyquistResponse) else nyquist_response(result)
    return draw_nyquist(nr, ax=ax, max_magnitude=max_magnitude, **line_kw)



def sigma_plot(result, *, ax=None, hz: bool = False, **line_kw) -> PlotHandle:
    """Singular values of ``G(j omega)`` [dB] against frequency (MIMO gain envelope).

    Parameters
    ----------
    result : FrequencyResponse or a linear system
        A system is evaluated with :func:`frequency_response` (automatic grid).
    ax : matplotlib axes, optional
    hz : bool, optional
        Frequency axis in Hz instead of rad/s.
    **line_kw
        Passed to ``Axes.semilogx``.

    Returns
    -------
    PlotHandle
        One line per singular value, largest first.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import sigma_plot
    >>> G = LinearSystem([[-1, 0], [0, -2]], np.eye(2), np.eye(2))   # diag(1/(s+1), 1/(s+2))
    >>> h = sigma_plot(G)
    >>> len(h.lines), bool(np.all(h.lines[0].get_ydata() >= h.lines[1].get_ydata()))
    (2, True)
    >>> plt.close(h.figure)
    """
    return draw_sigma(_response(result), ax=ax, hz=hz, **line_kw)



def root_locus_plot(result, *, ax=None, **line_kw) -> PlotHandle:
    """Root locus: one line per branch, open-loop poles (x) and zeros (o).

    Parameters
    ----------
    result : RootLocus, Loop or loop transfer function
        Anything else than a :class:`RootLocus` goes through :func:`root_locus`.
    ax : matplotlib axes, optional
    **line_kw
        Passed to ``Axes.plot``.

    Returns
    -------
    PlotHandle
        ``lines``: the branches in the order of ``RootLocus.roots`` columns, then the pole and
        zero markers.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import root_locus_plot
    >>> L = LinearSystem([[0, 1], [0, -2]], [[0], [1]], [[1, 0]])     # 1/(s (s + 2))
    >>> h = root_locus_plot(L)
    >>> len(h.lines)   # two branches, the pole markers, the (empty) zero markers
    4
    >>> plt.close(h.figure)
    """
    rl = result if isinstance(result, RootLocus) else root_locus(result)
    return draw_root_locus(rl, ax=ax, **line_kw)
