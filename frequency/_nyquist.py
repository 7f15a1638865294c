"""Nyquist contour, encirclement count and the Nyquist criterion, for SISO and MIMO loops."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import ModelError, as_linear_system

from ._loop import Loop
from ._response import _Evaluator, frequency_grid

__all__ = ["NyquistResponse", "nyquist_response"]


@dataclass(frozen=True)
class NyquistResponse:
    """The loop evaluated along the Nyquist contour, with the Nyquist criterion applied.

    Attributes
    ----------
    s : numpy.ndarray of complex
        Laplace variable [1/s] along the closed contour, traversed clockwise: up the imaginary axis from ``-j omega_max`` to
        ``+j omega_max`` with half-circles of radius ``indent_radius`` to the right of every
        imaginary-axis pole of ``L``, then back along a half-circle of radius ``omega_max``
        through the right half-plane.
    values : numpy.ndarray of complex
        ``L(s)`` [-] for a SISO loop; ``det(I + L(s)) - 1`` for a MIMO loop, so that in both cases
        the critical point is ``-1`` and ``1 + values`` is the return difference (determinant).
    on_axis : numpy.ndarray of bool
        True where ``s`` lies on the imaginary axis (the frequency-response part).
    encirclements : int
        ``N``: clockwise encirclements of ``-1`` by ``values`` (of the origin by the return
        difference).
    open_loop_unstable_poles : int
        ``P``: poles of ``L`` with positive real part (imaginary-axis poles are indented around
        and not counted).
    closed_loop_unstable_poles : int
        ``Z = N + P``, the Nyquist criterion.
    indentations : numpy.ndarray of complex
        Centres of the indentations (imaginary-axis poles of ``L``) [1/s].
    indent_radius : float
        Radius of the indentations [rad/s].
    omega_max : float
        Radius of the large half-circle [rad/s].
    min_distance : float
        Smallest ``|1 + values|`` [-] along the contour: how close the contour came to a closed-loop
        pole (a small value makes the count fragile).
    seconds : float
        Wall time of the contour evaluation and count [s].
    """

    s: NDArray[np.complex128]
    values: NDArray[np.complex128]
    on_axis: NDArray[np.bool_]
    encirclements: int
    open_loop_unstable_poles: int
    closed_loop_unstable_poles: int
    indentations: NDArray[np.complex128]
    indent_radius: float
    omega_max: float
    min_distance: float
    seconds: float

    def plot(self, **kwargs):
        """Nyquist plot of this response: see :func:`linflex.frequency.nyquist_plot`.

        Parameters
        ----------
        **kwargs
            Keyword arguments of :func:`~linflex.frequency.nyquist_plot` (``ax``, ...).

        Returns
        -------
        PlotHandle
            As :func:`~linflex.frequency.nyquist_plot`.
        """
        from ._plot import nyquist_plot

        return nyquist_plot(self, **kwargs)


def _arc(center: complex, radius: float, theta0: float, theta1: float, n: int) -> NDArray[np.complex128]:
    th = np.linspace(theta0, theta1, n)
    return center + radius * np.exp(1j * th)


def nyquist_response(sys_or_loop, omega_max: float | None = None, *, indent_radius: float | None = None,
                     max_refinements: int = 20) -> NyquistResponse:
    """Evaluate a loop along the Nyquist contour and count encirclements of -1.

    Parameters
    ----------
    sys_or_loop : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`Loop` (its loop transfer function broken at the plant input, ``L = K P``, is
        used) or a square loop transfer function ``L`` of a negative-feedback loop.
    omega_max : float, optional
        Radius of the large half-circle [rad/s]; default the top of :func:`frequency_grid`.
    indent_radius : float, optional
        Radius of the indentations around imaginary-axis poles [rad/s]; default
        ``min(1e-4 * scale, 0.01 * distance to the nearest other pole)``.
    max_refinements : int, optional
        Rounds of point insertion where the phase of the return difference jumps by more than
        pi/4 between contour points.

    Returns
    -------
    NyquistResponse

    Raises
    ------
    ModelError
        If ``L`` is not square.

    Notes
    -----
    The winding number of ``det(I + L(s))`` around the origin, accumulated from phase increments
    along the contour (refined until every increment is below pi/4), gives ``N``; the closed loop
    has ``Z = N + P`` poles in the right half-plane (MIMO via the determinant, Desoer and Wang
    1980). Poles on the imaginary axis (a rigid-body double integrator at the origin) are
    excluded by half-circles to their right, so they are not counted in ``P``.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> L = LinearSystem([[0, 1], [0, -1]], [[0], [1]], [[4, 0]])   # 4 / (s (s + 1)): stable loop
    >>> r = nyquist_response(L)
    >>> r.encirclements, r.open_loop_unstable_poles, r.closed_loop_unstable_poles
    (0, 0, 0)
    """
    t0 = time.perf_counter()
    L = sys_or_loop.open_loop() if isinstance(sys_or_loop, Loop) else as_linear_system(sys_or_loop, "sys_or_loop")
    if L.n_inputs != L.n_outputs:
        raise ModelError(f"the loop transfer function must be square, got {L.n_outputs} outputs and {L.n_inputs} inputs")
    siso = L.shape == (1, 1)
    lam = scipy.linalg.eigvals(L.A, check_finite=False) if L.n_states else np.zeros(0, dtype=complex)
    scale = max(float(np.max(np.abs(lam))) if lam.size else 0.0, 1.0)
    # Imaginary-axis poles: |Re| tiny against the scale. A defective pole at the origin splits
    # into ~sqrt(eps) scale under round-off, hence the 1e-6 radius for clustering.
    on_axis = np.abs(lam.real) <= 1e-7 * scale
    centers = []
    for z in lam[on_axis]:
        c = 1j * z.imag if abs(z.imag) > 1e-6 * scale else 0j
        if not any(abs(c - d) <= 1e-6 * scale for d in centers):
            centers.append(c)
    centers = np.array(sorted(centers, key=lambda c: c.imag), dtype=complex)
    P = int(np.sum(lam.real > 1e-7 * scale))
    if indent_radius is None:
        r = 1e-4 * scale
        for c in centers:
            others = lam[np.abs(lam - c) > 1e-6 * scale]
            if others.size:
                r = min(r, 0.01 * float(np.min(np.abs(others - c))))
    else:
        r = float(indent_radius)
        if not np.isfinite(r) or r <= 0:
            raise ModelError(f"indent_radius must be a positive radius in rad/s, got {indent_radius!r}")
    grid = frequency_grid(L, channel_zeros=False, _poles=lam)
    W = float(omega_max) if omega_max is not None else float(grid[-1])
    if not np.isfinite(W) or W <= 0:
        raise ModelError(f"omega_max must be a positive frequency in rad/s, got {omega_max!r}")
    # Points on the imaginary axis: the pole-aware grid mirrored, minus the indentation discs.
    w = np.concatenate([-grid[::-1], [0.0], grid])
    w = w[np.abs(w) <= W]
    for c in centers:
        w = w[np.abs(w - c.imag) > r]
    pieces, axis_flags = [], []
    cuts = [c.imag for c in centers]
    edges = [-W] + [x for c in cuts for x in (c - r, c + r)] + [W]
    for k in range(len(cuts) + 1):
        lo, hi = edges[2 * k], edges[2 * k + 1]
        seg = w[(w >= lo) & (w <= hi)]
        seg = np.unique(np.concatenate([[lo], seg, [hi]]))
        pieces.append(1j * seg)
        axis_flags.append(np.ones(len(seg), dtype=bool))
        if k < len(cuts):
            arc = _arc(centers[k], r, -np.pi / 2, np.pi / 2, 41)[1:-1]
            pieces.append(arc)
            axis_flags.append(np.zeros(len(arc), dtype=bool))
    big = _arc(0j, W, np.pi / 2, -np.pi / 2, 81)[1:-1]
    pieces.append(big)
    axis_flags.append(np.zeros(len(big), dtype=bool))
    s = np.concatenate(pieces)
    flags = np.concatenate(axis_flags)

    evaluator = _Evaluator(L, "auto", 1e-11)

    def f_of(spts):
        G = evaluator.at(spts)
        if siso:
            return G[:, 0, 0]
        return np.linalg.det(np.eye(L.n_inputs)[None] + G) - 1.0

    vals = f_of(s)
    for _ in range(max_refinements):
        ret = 1.0 + np.append(vals, vals[:1])
        dphi = np.angle(ret[1:] / ret[:-1])
        jump = np.abs(dphi) > np.pi / 4
        if not np.any(jump):
            break
        idx = np.nonzero(jump)[0]
        nxt = (idx + 1) % len(s)
        mids = 0.5 * (s[idx] + s[nxt])
        # keep midpoints of axis segments on the axis
        both_axis = flags[idx] & flags[nxt]
        mids = np.where(both_axis, 1j * mids.imag, mids)
        mvals = f_of(mids)
        s = np.insert(s, idx + 1, mids)
        vals = np.insert(vals, idx + 1, mvals)
        flags = np.insert(flags, idx + 1, both_axis)
    ret = 1.0 + np.append(vals, vals[:1])
    total = float(np.sum(np.angle(ret[1:] / ret[:-1])))
    N = int(round(-total / (2 * np.pi)))
    for arr in (s, vals, flags, centers):
        arr.setflags(write=False)
    return NyquistResponse(
        s=s, values=vals, on_axis=flags, encirclements=N, open_loop_unstable_poles=P,
        closed_loop_unstable_poles=N + P, indentations=centers, indent_radius=r, omega_max=W,
        min_distance=float(np.min(np.abs(1.0 + vals))), seconds=time.perf_counter() - t0,
    )
