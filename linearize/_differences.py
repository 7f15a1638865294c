"""Numerical Jacobians of a stacked model ``g(z) = [f(x, u, t); h(x, u, t)]``, ``z = [x; u]``.

Three methods, each returning the Jacobian, a per-entry error estimate and per-entry
convergence flags:

- :func:`perturbation_jacobian`: the classic DISCOS/DYNAMO numerical perturbation
  (reference: shared/reference/linear-analysis-discos.md, section 1);
- :func:`central_jacobian`: central differences with a Richardson extrapolation table;
- :func:`complex_step_jacobian`: the complex-step derivative (Squire and Trapp 1998).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex import MethodUnavailableError, ModelError

EPS = np.finfo(float).eps
# Error of one evaluated function value in units of its last place: a model's arithmetic
# rounds several times, so the reported round-off level of a difference quotient assumes a
# few ulps per value, not one.
ULPS_PER_VALUE = 4.0


@dataclass(frozen=True)
class NumericalJacobian:
    """A Jacobian with per-entry absolute error estimates and convergence flags."""

    J: NDArray[np.float64]
    error: NDArray[np.float64]
    converged: NDArray[np.bool_]
    evaluations: int


class CountingFunction:
    """Wraps ``g(z)`` to count calls and to name the perturbed variable when ``g`` fails."""

    def __init__(self, g: Callable[[NDArray], NDArray], names: tuple[str, ...], rows: tuple[str, ...]):
        self._g = g
        self.names = names
        self.rows = rows
        self.calls = 0

    def __call__(self, z: NDArray, j: int | None = None) -> NDArray:
        self.calls += 1
        try:
            value = self._g(z)
        except ModelError as err:
            where = "" if j is None else f" while perturbing {self.names[j]!r}"
            raise ModelError(f"{err}{where}") from err
        if j is not None and value.dtype.kind != "c":
            bad = np.flatnonzero(~np.isfinite(value))
            if bad.size:
                raise ModelError(
                    f"the model returned a non-finite value ({self.rows[bad[0]]} = {value[bad[0]]}) "
                    f"while perturbing {self.names[j]!r} to {z[j]!r}"
                )
        return value


def _nominal_steps(z0: NDArray, rel: float, zero_step: float, scale: NDArray) -> NDArray:
    """Signed initial steps: ``rel * max(|z0|, scale)`` with the sign of ``z0``; zero_step at 0."""
    magnitude = np.maximum(np.abs(z0), scale)
    steps = rel * magnitude * np.where(z0 < 0, -1.0, 1.0)
    return np.where(magnitude > 0, steps, zero_step)


def perturbation_jacobian(
    g: CountingFunction,
    z0: NDArray,
    g0: NDArray,
    *,
    rel_step: float,
    zero_step: float,
    scale: NDArray,
    digits: float,
    abs_tol: float,
    max_halvings: int,
    roundoff_factor: float = 25.0,
) -> NumericalJacobian:
    """The classic numerical perturbation (DISCOS section 1.5), column by column.

    Each column uses the one-sided three-point quadratic fit
    ``D(Delta) = (-3 g(z0) + 4 g(z0 + Delta/2) - g(z0 + Delta)) / Delta`` and halves
    ``Delta`` (one new evaluation per halving) until each entry agrees with its previous
    estimate to ``digits`` significant digits or falls below the round-off floor
    ``roundoff_factor * 4 eps (3|g0| + 4|gm| + |g1|) / |Delta|`` (with the default factor 25, the
    reference's ``c_r = 100`` eps per value); an entry is frozen at the first
    halving where it passes. The error estimate of an entry is the larger of its last change and
    its round-off level ``4 eps (3|g0| + 4|gm| + |g1|) / |Delta|`` (four ulps per value; the
    larger safety factor only guards the convergence test); entries still moving after
    ``max_halvings`` are flagged unconverged.
    """
    n_rows, n_vars = g0.size, z0.size
    J = np.zeros((n_rows, n_vars))
    err = np.zeros((n_rows, n_vars))
    converged = np.zeros((n_rows, n_vars), dtype=bool)
    steps = _nominal_steps(z0, rel_step, zero_step, scale)
    rtol = 10.0 ** (-digits)
    for j in range(n_vars):
        delta = steps[j]
        z = z0.copy()
        z[j] = z0[j] + delta / 2
        gm = g(z, j)
        z[j] = z0[j] + delta
        g1 = g(z, j)
        d_old = (-3 * g0 + 4 * gm - g1) / delta
        frozen = np.zeros(n_rows, dtype=bool)
        for _ in range(max_halvings):
            delta /= 2
            g1 = gm
            z[j] = z0[j] + delta / 2
            gm = g(z, j)
            d_new = (-3 * g0 + 4 * gm - g1) / delta
            change = np.abs(d_new - d_old)
            roundoff = ULPS_PER_VALUE * EPS * (3 * np.abs(g0) + 4 * np.abs(gm) + np.abs(g1)) / abs(delta)
            floor = np.maximum(abs_tol, roundoff_factor * roundoff)  # 100 eps per value, as the reference
            ok = change <= np.maximum(rtol * np.abs(d_new), floor)
            newly = ok & ~frozen
            J[newly, j] = d_new[newly]
            err[newly, j] = np.maximum(change[newly], roundoff[newly])
            converged[newly, j] = True
            frozen |= ok
            if frozen.all():
                break
            d_old = d_new
        rest = ~frozen
        J[rest, j] = d_new[rest]
        err[rest, j] = np.maximum(change[rest], roundoff[rest])
    return NumericalJacobian(J, err, converged, g.calls)


def central_jacobian(
    g: CountingFunction,
    z0: NDArray,
    g0: NDArray,
    *,
    rel_step: float,
    zero_step: float,
    scale: NDArray,
    levels: int,
    digits: float,
    roundoff_factor: float = ULPS_PER_VALUE,
) -> NumericalJacobian:
    """Central differences with a Richardson table over ``levels`` halvings of the step.

    ``D(h) = (g(z0 + h e_j) - g(z0 - h e_j)) / (2h)`` has an error series in even powers of
    ``h``; the table ``R[k, i] = (4^i R[k, i-1] - R[k-1, i-1]) / (4^i - 1)`` removes them one by
    one. The error estimate of an entry is ``|R[top] - R[top, below]|`` (the change made by the
    last extrapolation) plus the round-off level of the finest difference quotient (times
    ``roundoff_factor`` for the amplification through the table); entries
    whose estimate exceeds ``10**-digits`` of their magnitude (and the round-off level) are
    flagged unconverged.
    """
    n_rows, n_vars = g0.size, z0.size
    J = np.zeros((n_rows, n_vars))
    err = np.zeros((n_rows, n_vars))
    converged = np.zeros((n_rows, n_vars), dtype=bool)
    steps = np.abs(_nominal_steps(z0, rel_step, zero_step, scale))
    for j in range(n_vars):
        h = steps[j]
        table: list[NDArray] = []
        roundoff = np.zeros(n_rows)
        z = z0.copy()
        for k in range(levels):
            z[j] = z0[j] + h
            gp = g(z, j)
            z[j] = z0[j] - h
            gmi = g(z, j)
            row = [(gp - gmi) / (2 * h)]
            for i in range(1, k + 1):
                factor = 4.0**i
                row.append((factor * row[i - 1] - table[-1][i - 1]) / (factor - 1))
            roundoff = roundoff_factor * EPS * (np.abs(gp) + np.abs(gmi) + np.abs(g0)) / h
            table.append(row)
            h /= 2
        best = table[-1][-1]
        change = np.abs(best - table[-1][-2]) if levels > 1 else np.abs(best - table[0][0])
        J[:, j] = best
        err[:, j] = change + roundoff
        converged[:, j] = err[:, j] <= np.maximum(10.0 ** (-digits) * np.abs(best), 2 * roundoff)
    return NumericalJacobian(J, err, converged, g.calls)


def complex_step_jacobian(g: CountingFunction, z0: NDArray, *, step: float) -> NumericalJacobian:
    """The complex-step Jacobian ``Im g(z0 + i h e_j) / h``: no subtractive cancellation.

    Requires a model written with complex-safe operations (no ``abs``, comparisons on values or
    ``np.real`` casts); a model that drops the imaginary part is detected and refused.
    The error estimate is the round-off level ``eps * |J|``.
    """
    n_vars = z0.size
    columns = []
    for j in range(n_vars):
        z = z0.astype(complex)
        h = step * max(1.0, abs(z0[j]))
        z[j] += 1j * h
        try:
            value = g(z, j)
        except ModelError as err:
            raise MethodUnavailableError(
                f"method 'complex-step' needs a model that accepts complex input; it failed: {err}"
            ) from err
        if value.dtype.kind != "c":
            raise MethodUnavailableError(
                "method 'complex-step' needs a model that propagates complex input, but this one "
                f"returned {value.dtype} values when {g.names[j]!r} was given an imaginary part; "
                "use 'perturbation', 'central' or 'autodiff'"
            )
        columns.append(value.imag / h)
    J = np.column_stack(columns) if columns else np.zeros((0, 0))
    if not np.all(np.isfinite(J)):
        i, j = np.argwhere(~np.isfinite(J))[0]
        raise ModelError(f"complex step gave a non-finite derivative of {g.rows[i]} with respect to {g.names[j]}")
    return NumericalJacobian(J, EPS * np.abs(J), np.ones(J.shape, dtype=bool), g.calls)
