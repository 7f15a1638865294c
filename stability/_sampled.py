"""Margins of sampled and delayed loops on the continuous engine (see ``frequency/_sampled.py``).

- A **sampled loop** is analysed as its w-plane image ``z = (1 + s T/2) / (1 - s T/2)``
  (:func:`linflex.system.w_plane`, whole-period delays as exact shift registers): gain and phase
  margins, disk margins and encirclements are invariant under the map, poles outside the unit
  circle become right half-plane poles, and every frequency maps back by
  ``omega = (2/T) arctan(nu T/2)`` [rad/s]. The delay margin is recomputed in seconds from the
  real crossover frequency, ``PM / omega`` (a continuous delay ``exp(-j omega tau)`` at the
  crossover, as python-control reports it). The Nyquist frequency ``pi / T`` (``z = -1``, the
  w-plane's infinity) is a phase crossover when ``L(-1)`` is negative (``L`` is real there).
- A **delayed continuous loop** keeps ``exp(-s tau)`` exact in ``L`` (``AxisEvaluator``); its
  sensitivity ``S = 1 / (1 + L)`` is evaluated from ``L`` (it is not rational), its closed-loop
  poles only place grid points (from a 6th-order Pade approximation), and the number of unstable
  closed-loop poles is the Nyquist count of the delayed curve, ``Z = N + P``, exact.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from linflex import LinearSystem, ModelError
from linflex.frequency._sampled import SensitivityEvaluator, axis_evaluator
from linflex.system import from_w_frequency, pade, w_plane

from ._crossings import MAG_WINDOW, crossing_summary

__all__ = ["DELAYED_MAG_FLOOR", "delayed_band", "delayed_sensitivity", "sampled_margins"]

#: Order of the Pade approximation whose closed-loop poles place grid points of a delayed loop.
PADE_GRID_ORDER = 6
#: A delayed loop's curve crosses the negative real axis at every turn of ``exp(-j w tau)``, for
#: ever: its analysis grid ends after the last grid point where ``|L| >= DELAYED_MAG_FLOOR``, so
#: phase crossovers with gain margins beyond 60 dB above that frequency are not reported.
DELAYED_MAG_FLOOR = 1e-3


def delayed_band(grid: np.ndarray, values: np.ndarray, tau: float, L,
                 roots: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The grid of a loop delayed by ``tau`` [s], cut and filled for the delay's rotation.

    Cut after the last point where ``|L| >= DELAYED_MAG_FLOOR``: the grid is the pole- and
    zero-aware one (three decades beyond every pole and zero), so beyond its last point above the
    floor ``|L|`` only falls and what is cut are crossings with gain margins above 60 dB. A loop
    with a feedthrough (``|L| -> |D|``) crosses for ever: given its open-loop ``roots`` (poles
    and zeros; None without feedthrough), its band ends two decades above the largest of
    ``1 / tau`` and their moduli [rad/s], where ``L`` has settled to ``D exp(-j w tau)``. Filled
    so that ``exp(-j w tau)`` turns by at most 45 deg between neighbours: a log grid at high
    frequency would otherwise step over whole turns, which no phase test can see.
    """
    if roots is not None:
        finite = np.abs(roots[np.isfinite(roots)])
        keep = grid <= 100.0 * max(float(finite.max(initial=0.0)), 1.0 / tau)
        grid, values = grid[keep], values[keep]
    with np.errstate(invalid="ignore"):
        above = np.flatnonzero(~(np.abs(values) < DELAYED_MAG_FLOOR))
    end = min(int(above[-1]) + 2, grid.size) if above.size else min(2, grid.size)
    grid, values = grid[:end], values[:end]
    steps = np.ceil(np.diff(grid) * tau / (np.pi / 4)).astype(int)
    if grid.size < 2 or not np.any(steps > 1):
        return grid, values
    fill = np.concatenate([np.linspace(a, b, k + 1)[1:-1] for a, b, k in zip(grid[:-1], grid[1:], steps) if k > 1])
    all_w = np.concatenate([grid, fill])
    order = np.argsort(all_w)
    return all_w[order], np.concatenate([values, L(fill)])[order]


def delayed_sensitivity(sys: LinearSystem, rtol: float) -> tuple[object, SensitivityEvaluator]:
    """Evaluators of a delayed single loop ``L`` and of its sensitivity ``S = 1 / (1 + L)``."""
    if sys.n_inputs != 1:
        raise ModelError(
            "loop: stability_margins keeps delays exact on single loops; for a multivariable loop with delays "
            "analyse linflex.pade(loop, order).sys (its error reported) or each loop with the others closed"
        )
    ev_L = axis_evaluator(sys, rtol=rtol)
    approx = pade(sys, PADE_GRID_ORDER).sys
    I_D = np.eye(1) + approx.D
    poles = np.linalg.eigvals(approx.A - approx.B @ np.linalg.solve(I_D, approx.C)) if approx.n_states else np.zeros(0)
    return ev_L, SensitivityEvaluator(ev_L, poles)


def sampled_margins(sys: LinearSystem, margins, **options):
    """``margins(w_plane(sys), **options)`` with every frequency mapped back to [rad/s] of the sampled loop."""
    engine, cond = w_plane(sys)
    result = margins(engine, **options)
    T = sys.dt
    L_nyquist = np.asarray(engine.D, dtype=float)  # L(z = -1), real
    loops = tuple(_loop_back(loop, T, _single_loop_value(L_nyquist, i)) for i, loop in enumerate(result.loops))
    rounding = engine.n_states * np.finfo(float).eps * cond
    return dataclasses.replace(
        result,
        loops=loops,
        disk_margin=_disk_back(result.disk_margin, T),
        skewed_disk_margin=_disk_back(result.skewed_disk_margin, T),
        unstructured_disk_margin=_disk_back(result.unstructured_disk_margin, T),
        unstructured_skewed_disk_margin=_disk_back(result.unstructured_skewed_disk_margin, T),
        evaluation_error=float(result.evaluation_error + rounding),
        method=f"{result.method}; sampled loop (dt = {T} s) on its w-plane image z = (1 + sT/2)/(1 - sT/2)",
    )


def _single_loop_value(L: np.ndarray, i: int) -> float:
    """``L_ii - L_io (I + L_oo)^-1 L_oi``: loop ``i`` with the others closed, for a static ``L``."""
    o = [j for j in range(L.shape[0]) if j != i]
    if not o:
        return float(L[i, i])
    closed = L[np.ix_([i], o)] @ np.linalg.solve(np.eye(len(o)) + L[np.ix_(o, o)], L[np.ix_(o, [i])])
    return float(L[i, i] - closed[0, 0])


def _disk_back(disk, T: float):
    return dataclasses.replace(disk, frequency=float(from_w_frequency(disk.frequency, T)))


def _loop_back(loop, T: float, L_nyquist: float):
    wgc = from_w_frequency(loop.gain_crossovers, T)
    pm = np.asarray(loop.phase_margins)
    dm = np.radians(np.mod(pm, 360.0)) / wgc if wgc.size else np.zeros(0)
    wpc = list(from_w_frequency(loop.phase_crossovers, T))
    gm = list(loop.gain_margins)
    if L_nyquist < 0 and MAG_WINDOW[0] <= abs(L_nyquist) <= MAG_WINDOW[1]:
        wpc.append(np.pi / T)
        gm.append(-1.0 / L_nyquist)
    wpc, gm = np.array(wpc, dtype=float), np.array(gm, dtype=float)
    return dataclasses.replace(
        loop,
        **crossing_summary(wgc, pm, dm, wpc, gm),
        disk_margin=_disk_back(loop.disk_margin, T),
        skewed_disk_margin=_disk_back(loop.skewed_disk_margin, T),
    )
