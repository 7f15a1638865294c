"""Nyquist encirclement count from the curve ``det(I + L(s))`` along the Nyquist contour.

The contour goes up the imaginary axis with small half-circles to the right around open-loop
poles on the axis (rigid-body poles at the origin, undamped modes), closed through infinity,
where ``det(I + L) -> det(I + D)``. By the argument principle the net counterclockwise
encirclements of the origin by ``det(I + L)`` equal ``P - Z`` (open-loop minus closed-loop
poles in the right half-plane). The phase of ``det(I + L)`` is tracked point by point, the path
being refined until no step changes the phase by more than 15 deg; real systems are symmetric
about the real axis, so the half path ``w >= 0`` is traversed and its phase change doubled.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["nyquist_encirclements"]

_MAX_STEP_DEG = 15.0


def _f(ev, s: NDArray[np.complex128]) -> NDArray[np.complex128]:
    G = ev.at(s)
    return np.linalg.det(np.eye(G.shape[1])[None] + G)


def _phase_change(ev, path, t0: float, t1: float, t_init: NDArray[np.float64], max_points: int) -> float | None:
    """Unwrapped phase change of det(I + L(path(t))) for t from t0 to t1."""
    t = np.unique(np.concatenate([[t0, t1], t_init[(t_init > t0) & (t_init < t1)]]))
    v = _f(ev, path(t))
    for _ in range(40):
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.degrees(np.abs(np.angle(v[1:] / v[:-1])))
        bad = ~(d <= _MAX_STEP_DEG)
        bad &= (t[1:] - t[:-1]) > 1e-13 * np.maximum(np.abs(t[1:]), 1e-300)
        if not bad.any():
            break
        if t.size + bad.sum() > max_points:
            return None
        i = np.flatnonzero(bad)
        mid = 0.5 * (t[i] + t[i + 1])
        t = np.insert(t, i + 1, mid)
        v = np.insert(v, i + 1, _f(ev, path(mid)))
    with np.errstate(divide="ignore", invalid="ignore"):
        steps = np.angle(v[1:] / v[:-1])
    if not np.all(np.isfinite(steps)) or np.max(np.abs(np.degrees(steps))) > 2 * _MAX_STEP_DEG:
        return None
    return float(np.sum(steps))


def nyquist_encirclements(ev, D, axis_poles, other_poles, grid, *, max_points: int = 200_000) -> int | None:
    """Net counterclockwise encirclements of the origin by ``det(I + L)`` (``None`` if unresolved).

    Parameters
    ----------
    ev : TransferEvaluator
        Evaluator of the square open loop ``L``.
    D : ndarray
        Feedthrough of ``L``.
    axis_poles : list of (float, float)
        ``(w_p, r_p)``: open-loop poles on the imaginary axis at ``j w_p`` (``w_p >= 0``, conjugates
        implied) spread over a radius ``r_p`` by rounding (a Jordan block).
    other_poles : ndarray
        Every other open-loop and closed-loop pole (the indentations must not enclose them).
    grid : ndarray
        Frequencies [rad/s] that resolve ``L`` (the margin grid), used as initial points.
    """
    other = np.asarray(other_poles, dtype=complex)
    indents = []
    for wp, rp in sorted(axis_poles):
        centre = 1j * wp
        dist = np.abs(other - centre)
        dist = dist[dist > 10 * rp]
        for wq, _ in axis_poles:
            if wq != wp:
                dist = np.append(dist, abs(wq - wp))
        d_near = float(dist.min()) if dist.size else max(1.0, wp)
        eps = min(1e-2 * d_near, max(1e3 * rp, 1e-6 * d_near))
        if eps <= 10 * rp or eps >= 0.5 * d_near:
            return None
        indents.append((wp, eps))
    total = 0.0
    grid = np.asarray(grid, dtype=float)
    start = 0.0
    if indents and indents[0][0] == 0.0:
        eps0 = indents.pop(0)[1]
        th = np.linspace(0, np.pi / 2, 17)
        dphi = _phase_change(ev, lambda t: eps0 * np.exp(1j * t), 0.0, np.pi / 2, th, max_points)
        if dphi is None:
            return None
        total += dphi
        start = eps0
    hi = max(grid.max(), 10 * max([w for w, _ in indents], default=1.0))
    # extend until det(I + L) has settled to det(I + D) (the big arc adds nothing then)
    f_inf = np.linalg.det(np.eye(D.shape[0]) + D)
    for _ in range(30):
        if abs(_f(ev, np.array([1j * hi]))[0] - f_inf) <= 1e-3 * abs(f_inf):
            break
        hi *= 10.0
    else:
        return None
    ends = [start]
    for wp, eps in indents:
        ends += [wp - eps, wp + eps]
    ends.append(hi)
    init = np.concatenate([grid, np.geomspace(max(start, 1e-300) if start > 0 else grid.min(), hi, 200)])
    for k in range(0, len(ends), 2):
        a, b = ends[k], ends[k + 1]
        dphi = _phase_change(ev, lambda t: 1j * t, a, b, init, max_points)
        if dphi is None:
            return None
        total += dphi
        if k // 2 < len(indents):
            wp, eps = indents[k // 2]
            th = np.linspace(-np.pi / 2, np.pi / 2, 33)
            dphi = _phase_change(ev, lambda t, wp=wp, eps=eps: 1j * wp + eps * np.exp(1j * t), -np.pi / 2, np.pi / 2,
                                 th, max_points)
            if dphi is None:
                return None
            total += dphi
    total += float(np.angle(f_inf / _f(ev, np.array([1j * hi]))[0]))
    turns = 2 * total / (2 * np.pi)
    n = int(round(turns))
    return n if abs(turns - n) < 0.05 else None
