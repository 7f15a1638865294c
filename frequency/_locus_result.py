"""The result of :func:`linflex.frequency.root_locus`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["RootLocus"]


@dataclass(frozen=True)
class RootLocus:
    """Closed-loop eigenvalues of ``x' = (A - k B (I + k D)^-1 C) x`` over the gain ``k``.

    Attributes
    ----------
    gains : numpy.ndarray, shape (n_gains,)
        Loop gains [-] (dimensionless when the loop transfer function is; in general the
        inverse of its units), monotone (increasing for ``k >= 0``, decreasing for the
        complementary locus); the first is 0 for an automatic sequence.
    roots : numpy.ndarray of complex, shape (n_gains, n_states)
        ``roots[:, j]`` is branch ``j``: consecutive rows are matched by minimum total
        displacement (linear assignment) or carried by the continuation, so a branch is a
        continuous curve [1/s].
    open_loop_poles, open_loop_zeros : numpy.ndarray of complex
        Start and (finite) end points of the branches [1/s].
    breakaway_points : numpy.ndarray of complex
        Points [1/s] where two branches meet and leave (SISO loops; empty otherwise): double roots
        of ``1 + k L(s)``; all of them with the pencil (``breakaway=True``, the default for an
        automatic sequence up to 200 states), else those the continuation located between the
        gains it crossed.
    breakaway_gains : numpy.ndarray
        The gains at those points [-] (real, of the sign of the locus).
    max_step_displacement : float
        Largest accepted root displacement between consecutive gains, relative to the local
        root spacing [-]; the matching is reliable when this is well below 0.5.
    n_evaluations : int
        Dense eigenvalue solves.
    n_continuation_steps : int
        Gain steps taken by Newton continuation instead.
    n_rejected_continuation_steps : int
        Continuation steps that failed their checks and were replaced by a smaller step or a
        dense solve (after three in a row, dense solves take over for a while).
    seconds : float
        Wall time of :func:`root_locus` [s].
    dt : float or None
        Sampling period [s] of a sampled loop: the roots are then in ``z`` (stable inside the
        unit circle, which the plot draws); None for a continuous loop.
    error_estimate : numpy.ndarray, shape (n_gains, n_states)
        A-posteriori error estimate of each root [1/s]: every root is polished by Newton's
        method on ``det(I + k G(s))`` (``G`` from the Schur form of ``A``, so only ``A`` is
        perturbed by rounding, never the closed-loop matrix whose norm grows with ``k``), and
        its estimate is the last step plus ``n eps ||A|| cond`` (the root's condition for
        perturbations of ``A``); a root Newton's method does not take (multiple, or a mode the
        loop does not see) keeps its eigenvalue with a first-order estimate (see
        ``frequency/_locus_polish.py``). ``inf`` where no estimate is available (a defective
        open-loop pole at ``k = 0``).
    """

    gains: NDArray[np.float64]
    roots: NDArray[np.complex128]
    open_loop_poles: NDArray[np.complex128]
    open_loop_zeros: NDArray[np.complex128]
    breakaway_points: NDArray[np.complex128]
    breakaway_gains: NDArray[np.float64]
    max_step_displacement: float
    n_evaluations: int
    n_continuation_steps: int
    n_rejected_continuation_steps: int
    seconds: float
    error_estimate: NDArray[np.float64]
    dt: float | None = None

    def _display_fields(self):
        gains = np.asarray(self.gains)
        return [("n_gains", gains.size), ("gains", f"{gains.min():.4g} to {gains.max():.4g}" if gains.size else "-"),
                ("n_branches", np.asarray(self.roots).shape[1] if np.ndim(self.roots) == 2 else 0),
                ("open_loop_poles", np.asarray(self.open_loop_poles).size),
                ("open_loop_zeros", np.asarray(self.open_loop_zeros).size),
                ("breakaway_points", np.asarray(self.breakaway_points).size),
                ("max_step_displacement", self.max_step_displacement), ("n_evaluations", self.n_evaluations),
                ("n_continuation_steps", self.n_continuation_steps), ("seconds", self.seconds)]

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("RootLocus", self._display_fields())

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        poles = [("pole", p, abs(p)) for p in np.asarray(self.open_loop_poles)]
        zeros = [("zero", z, abs(z)) for z in np.asarray(self.open_loop_zeros)]
        return html_summary("RootLocus", self._display_fields(), ("open loop", "value [1/s]", "|value| [rad/s]"),
                            poles + zeros)

    @property
    def branches(self) -> list[NDArray[np.complex128]]:
        """The branches as a list of arrays of shape (n_gains,)."""
        return [self.roots[:, j] for j in range(self.roots.shape[1])]

    def plot(self, **kwargs):
        """Root-locus plot: see :func:`linflex.frequency.root_locus_plot`.

        Parameters
        ----------
        **kwargs
            ``ax=`` and line options, passed to :func:`root_locus_plot`.

        Returns
        -------
        PlotHandle
            The figure, the axes and the lines (branches, then the pole and zero markers).
        """
        # drawing depends on results, never the reverse (_draw imports no computing module)
        from ._draw import draw_root_locus

        return draw_root_locus(self, **kwargs)
