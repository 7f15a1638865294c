"""What every plot function returns, and the axes it draws on (matplotlib imported when drawing).

Every linflex plot function draws on ``ax`` when given (else on a new figure), returns one
:class:`PlotHandle`, never calls ``plt.show()`` and never changes ``rcParams``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._errors import ModelError

__all__ = ["PlotHandle", "plot_axes"]


@dataclass(frozen=True)
class PlotHandle:
    """What a plot function drew.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
        The figure drawn on.
    axes : tuple of matplotlib.axes.Axes
        The axes drawn on, in the order documented by each function.
    lines : tuple of matplotlib artists
        The data artists (lines, scatter collections), in the order documented by each function.
    data : object
        The result that was drawn (FrequencyResponse, NyquistResponse, RootLocus, TimeResponse,
        SweepResult, ...).

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import bode_plot
    >>> h = bode_plot(LinearSystem([[-1.0]], [[1.0]], [[1.0]]))
    >>> len(h.axes), len(h.lines)
    (2, 2)
    >>> plt.close(h.figure)
    """

    figure: Any
    axes: tuple
    lines: tuple
    data: Any


def plot_axes(ax: Any, n: int, *, figsize: tuple[float, float] | None = None) -> tuple[Any, tuple]:
    """The figure and ``n`` axes to draw on: ``ax`` when given (one axes or a sequence of ``n``),
    else a new figure with ``n`` axes stacked on a shared x axis.

    Parameters
    ----------
    ax : matplotlib Axes, sequence of Axes, or None
        Where to draw.
    n : int
        How many axes the plot needs.
    figsize : pair of float, optional
        Size of a new figure [inch].

    Returns
    -------
    (figure, tuple of Axes)
        The figure and the ``n`` axes.

    Raises
    ------
    ModelError
        When ``ax`` holds another number of axes than ``n``.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, axs = plt.subplots(n, 1, sharex=n > 1, squeeze=False, figsize=figsize)
        return fig, tuple(axs[:, 0])
    axs = tuple(np.ravel(ax)) if isinstance(ax, (list, tuple, np.ndarray)) else (ax,)
    if len(axs) != n:
        raise ModelError(f"ax must be {n} matplotlib axes for this plot, got {len(axs)}")
    return axs[0].figure, axs
