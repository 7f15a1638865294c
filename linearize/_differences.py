"""Numerical Jacobians of a stacked model ``g(z) = [f(x, u, t); h(x, u, t)]``, ``z = [x; u]``.

Three methods, each returning the Jacobian, a per-entry error estimate and per-entry
convergence flags:

- :func:`perturbation_jacobian`: the classic DISCOS/DYNAMO numerical perturbation
  (reference: docs/reference/linear-analysis-discos.md, section 1);
- :func:`central_jacobian`: central differences with a Richardson extrapolation table;
- :func:`complex_step_jacobian`: the complex-step derivative (Squire and Trapp 1998).

Every method also looks at both sides of the operating point (:func:`one_sided_check`; the
exact methods, complex step and CasADi's algorithmic differentiation, through
:func:`exact_jacobian_check`), so a kink (``|x|``, a ReLU, a saturation reached exactly,
``fmax``) or a jump (``sign``) is not returned as a derivative to round-off: one-sided
three-point slopes at two step levels, with their own error estimates, decide it. At a kink
every method returns the mean of the two one-sided slopes with half their difference (plus
their errors) as the error estimate, and an :class:`~linflex.AccuracyWarning` names the entry;
at a jump the estimate is infinite. A perturbation or central entry that misses the requested
``digits`` is warned about too. Round-off levels are relative to the magnitude of the terms a
row adds up (:func:`value_scale`), since at an equilibrium the value itself is zero, and never
below the model's own noise, measured at the point (:func:`measured_noise`): a constrained
model's accelerations come out of a solve and carry more noise than their terms show, which
would otherwise pass for kinks and jumps.
"""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex import AccuracyWarning, MethodUnavailableError, ModelError

EPS = np.finfo(float).eps
# Error of one evaluated function value in units of its last place: a model's arithmetic
# rounds several times, so the reported round-off level of a difference quotient assumes a
# few ulps per value, not one.
ULPS_PER_VALUE = 4.0
# Safety factor on the round-off level before two one-sided slopes or two values count as
# different (the perturbation method's floor, 100 eps per value); models whose arithmetic is
# noisier than a few ulps do not see kinks in their noise.
KINK_ROUNDOFF_FACTOR = 25.0
# Relative step of the real one-sided check of the exact methods ('complex-step', 'autodiff'):
# the coarsest offset, as the first step of 'central'.
CHECK_REL_STEP = 1e-3
# The model's noise is measured at NOISE_POINTS points NOISE_REL_STEP times a column's nominal
# step apart (:func:`measured_noise`): many ulps of every variable, while the smooth part's
# fourth to sixth differences are ~1e-18 and below of the values.
NOISE_POINTS = 9
NOISE_REL_STEP = 1e-3
# A measured noise level is a standard deviation estimated from a few values: the round-off
# levels take NOISE_SAFETY times it (about three deviations, and the estimate's own scatter).
NOISE_SAFETY = 4.0


@dataclass(frozen=True)
class NumericalJacobian:
    """A Jacobian with per-entry absolute error estimates and convergence flags."""

    J: NDArray[np.float64]
    error: NDArray[np.float64]
    converged: NDArray[np.bool_]
    evaluations: int
    kinks: NDArray[np.bool_] | None = None
    jumps: NDArray[np.bool_] | None = None


class CountingFunction:
    """Wraps ``g(z)`` to count calls and to name the perturbed variable when ``g`` fails."""

    def __init__(self, g: Callable[[NDArray], NDArray], names: tuple[str, ...], rows: tuple[str, ...]):
        self._g = g
        self.names = names
        self.rows = rows
        self.calls = 0

    def __call__(self, z: NDArray, j: int | None = None, *, where: str = "") -> NDArray:
        """``g(z)``; ``j`` the perturbed variable or ``where`` what is being done, for the error message."""
        self.calls += 1
        try:
            value = self._g(z)
        except ModelError as err:
            where = f" while perturbing {self.names[j]!r}" if j is not None else where and f" {where}"
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
    """Signed initial steps: ``rel * max(|z0|, scale)`` with the sign of ``z0``, at least ``zero_step``.

    ``zero_step`` is the step at a zero value and the floor below it: a value of 1e-12 is no
    reason for a step of 1e-14, whose difference quotient is round-off.
    """
    magnitude = np.maximum(rel * np.maximum(np.abs(z0), scale), zero_step)
    return magnitude * np.where(z0 < 0, -1.0, 1.0)


def model_function(model, p: NDArray, t: float) -> CountingFunction:
    """The stacked ``g(z) = [f(x, u, p, t); h(x, u, p, t)]`` of a model as a :class:`CountingFunction`.

    Columns are named by the states then the inputs, rows by ``d(state)/dt`` then the outputs.
    """
    n = model.n_states

    def g(z):
        xdot, y = model.evaluate_raw(z[:n], z[n:], t, p)  # (evaluate_raw passes f and h copies)
        return np.concatenate([np.asarray(xdot).reshape(-1), np.asarray(y).reshape(-1)])

    return CountingFunction(g, model.states + model.inputs,
                            tuple(f"d({s})/dt" for s in model.states) + model.outputs)


@dataclass(frozen=True)
class OneSided:
    """The slopes of one Jacobian column on either side of the point (:func:`one_sided_check`).

    Attributes
    ----------
    s : float
        The finest offset (units of the column's variable).
    forward, backward : ndarray, shape (n_rows,)
        Three-point one-sided slopes at offsets ``s, 2s`` towards positive and negative offsets
        (units of the entry).
    forward_coarse, backward_coarse : ndarray, shape (n_rows,)
        The same at offsets ``2s, 4s``.
    roundoff : ndarray, shape (n_rows,)
        The round-off level of ``forward`` and ``backward`` together from the values' magnitudes.
    steps, step_changes : ndarray, shape (2, n_rows)
        Per side, the step of the value extrapolated to a zero offset,
        ``2 g(sigma s) - g(2 sigma s) - g0``, and its change ``|2 g(sigma s) - 3 g(2 sigma s) + g(4 sigma s)|``.
    """

    s: float
    forward: NDArray[np.float64]
    backward: NDArray[np.float64]
    forward_coarse: NDArray[np.float64]
    backward_coarse: NDArray[np.float64]
    roundoff: NDArray[np.float64]
    steps: NDArray[np.float64]
    step_changes: NDArray[np.float64]

    @property
    def mean(self) -> NDArray[np.float64]:
        """The central value ``(forward + backward) / 2``."""
        return 0.5 * (self.forward + self.backward)

    @property
    def change(self) -> NDArray[np.float64]:
        """``|forward - forward_coarse| + |backward - backward_coarse|``: the slopes' truncation error."""
        return np.abs(self.forward - self.forward_coarse) + np.abs(self.backward - self.backward_coarse)

    def noise(self, value_scale: NDArray) -> NDArray[np.float64]:
        """Round-off level of the two slopes together, with ``value_scale`` (per row, the magnitude
        of the terms the model adds up, see :func:`value_scale`) as well as the values themselves:
        at an equilibrium ``g0`` is 0 while its terms are not."""
        return self.roundoff + 2 * 8 * ULPS_PER_VALUE * EPS * value_scale / (2 * self.s)

    def jump(self, value_scale: NDArray) -> NDArray[np.bool_]:
        """The value itself jumps: the extrapolated step outweighs twice its change and the
        round-off, and the finer one-sided slope is the larger (slopes grow as ``1/s``)."""
        floor = KINK_ROUNDOFF_FACTOR * 4 * ULPS_PER_VALUE * EPS * value_scale
        fine = np.abs(np.stack([self.forward, self.backward]))
        coarse = np.abs(np.stack([self.forward_coarse, self.backward_coarse]))
        side = (np.abs(self.steps) > 2 * self.step_changes + floor) & (fine > 1.5 * coarse)
        return side[0] | side[1]

    def kink(self, value_scale: NDArray) -> NDArray[np.bool_]:
        """The slopes disagree beyond their change and ``KINK_ROUNDOFF_FACTOR`` times the
        round-off, by nearly the same amount at both levels, and the value does not jump."""
        d_fine = self.forward - self.backward
        d_coarse = self.forward_coarse - self.backward_coarse
        return (~self.jump(value_scale)
                & (np.abs(d_fine) > self.change + KINK_ROUNDOFF_FACTOR * self.noise(value_scale))
                & (np.abs(d_fine - d_coarse) <= 0.5 * np.abs(d_fine)))

    def kink_error(self, value_scale: NDArray) -> NDArray[np.float64]:
        """Error bound of ``mean`` against either one-sided slope: half their difference plus their errors."""
        return 0.5 * np.abs(self.forward - self.backward) + self.change + self.noise(value_scale)


def one_sided_check(g: CountingFunction, z0: NDArray, g0: NDArray, j: int, s: float,
                    known: dict[float, NDArray] | None = None) -> OneSided:
    """Both one-sided slopes of column ``j`` at two step levels: does the model bend or jump there?

    With the offsets ``+-s, +-2s, +-4s`` (``known`` holds values the method already has, keyed by
    the offset; the rest are evaluated), each side ``sigma`` gets the three-point slopes
    ``D(s) = sigma (-3 g0 + 4 g(sigma s) - g(2 sigma s)) / (2s)`` and ``D(2s)``. For a smooth
    model the two sides agree to ``O(s^3)`` while each side changes by ``O(s^2)`` between the
    levels: with ``D = g' + a s^2 + sigma b s^3 + ...`` the disagreement is ``2 |b| s^3`` and the
    changes sum to at least ``14 |b| s^3``, so a smooth model is never called kinked to leading
    order. At a kink the disagreement is the jump of the slope, the same at both levels, and
    the changes vanish (exactly, for piecewise-quadratic models): :meth:`OneSided.kink` is a
    disagreement beyond the changes and ``KINK_ROUNDOFF_FACTOR`` times the round-off that
    changes by less than half between the levels. A jump of the value (:meth:`OneSided.jump`)
    shows as a Richardson-extrapolated step ``2 g(sigma s) - g(2 sigma s) - g0`` that
    outweighs twice its own change, with one-sided slopes that grow as ``1/s``.

    Parameters
    ----------
    g : CountingFunction
        The stacked model.
    z0, g0 : ndarray
        The point and ``g(z0)`` (real).
    j : int
        The column.
    s : float
        The finest offset (positive), in the units of variable ``j``.
    known : dict, optional
        Already evaluated ``g(z0 + offset e_j)`` by offset; new values are added.

    Returns
    -------
    OneSided
    """
    known = {} if known is None else known

    def at(offset: float) -> NDArray:
        value = known.get(offset)
        if value is None:
            z = z0.copy()
            z[j] = z0[j] + offset
            value = known[offset] = g(z, j)
        return value

    fine, coarse, roundoff, steps, changes = [], [], [], [], []
    for sigma in (1.0, -1.0):
        a, b, c = at(sigma * s), at(sigma * 2 * s), at(sigma * 4 * s)
        fine.append(sigma * (-3 * g0 + 4 * a - b) / (2 * s))
        coarse.append(sigma * (-3 * g0 + 4 * b - c) / (4 * s))
        roundoff.append(ULPS_PER_VALUE * EPS * (3 * np.abs(g0) + 4 * np.abs(a) + np.abs(b)) / (2 * s))
        # g(o) - g0 = step + slope o + ...: the step extrapolated to o -> 0, and its change.
        steps.append(2 * a - b - g0)
        changes.append(np.abs(2 * a - 3 * b + c))
    return OneSided(s, fine[0], fine[1], coarse[0], coarse[1], roundoff[0] + roundoff[1],
                    np.stack(steps), np.stack(changes))


def measured_noise(g: CountingFunction, z0: NDArray, steps: NDArray) -> NDArray[np.float64]:
    """Per row, the noise level of the model's values measured at the point [units of the row].

    The model is evaluated at ``NOISE_POINTS`` points ``z0 + k h p`` (``k = 1, 2, ...``; ``p`` a
    fixed pattern of signs, ``h_j = NOISE_REL_STEP |steps_j|``), all on one side of ``z0``, so a
    kink or jump at the point itself is not among them. For values ``f_k = smooth + e_k`` with
    independent errors of standard deviation ``sigma``, the ``k``-th differences have variance
    ``C(2k, k) sigma^2`` while the smooth part's are ``O(h^k)``: the median over ``k = 4, 5, 6`` of
    ``sqrt(mean(Delta^k f^2) / C(2k, k))`` estimates ``sigma`` (Moré and Wild, "Estimating
    computational noise", SIAM J. Sci. Comput. 33(3), 2011). A model whose value is the result of a
    linear solve or of terms that cancel (constraint forces, a mass-matrix solve) is noisier than
    the magnitude of its Jacobian's terms suggests; this measures it. A level that the rounding
    of the values themselves (``ULPS_PER_VALUE eps max |f_k|``) explains is returned as 0.
    """
    pattern = np.where(np.arange(z0.size) % 3 == 1, -1.0, 1.0)
    h = NOISE_REL_STEP * np.abs(steps) * pattern
    where = "while measuring the model's noise beside the point (every variable moved together)"
    values = np.array([g(z0 + k * h, where=where) for k in range(1, NOISE_POINTS + 1)], dtype=float)
    estimates = [np.sqrt(np.mean(np.diff(values, n=k, axis=0) ** 2, axis=0) / math.comb(2 * k, k))
                 for k in (4, 5, 6)]
    noise = np.median(np.array(estimates), axis=0)
    # what the rounding of the values themselves explains is no extra noise (a row that is zero
    # at the point and tiny beside it would otherwise get an error estimate out of nothing)
    return np.where(noise > ULPS_PER_VALUE * EPS * np.max(np.abs(values), axis=0), noise, 0.0)


def value_scale(g0: NDArray, z0: NDArray, checks: list[OneSided], noise: NDArray | None = None) -> NDArray[np.float64]:
    """Per row, the magnitude of the terms that make up ``g``: ``|g0| + sum_j |slope_ij| max(|z0_j|, 4 s_j)``,
    at least :func:`noise_scale` of the :func:`measured_noise` ``noise``.

    The round-off of a model value is relative to its terms, not to the value: at an
    equilibrium ``g0`` is 0 while ``J_ij z0_j`` is not, and one-sided slopes of pure noise
    would otherwise look like kinks. Where the measured noise is larger than that magnitude's
    round-off, the noise sets the scale.
    """
    scale = np.abs(g0).astype(float)
    for j, check in enumerate(checks):
        slope = np.maximum(np.abs(check.forward), np.abs(check.backward))
        scale = scale + np.where(np.isfinite(slope), slope, 0.0) * max(abs(z0[j]), 4 * check.s)
    if noise is not None:
        scale = np.maximum(scale, noise_scale(noise))
    return scale


def noise_scale(noise: NDArray) -> NDArray[np.float64]:
    """The value magnitude whose round-off (``ULPS_PER_VALUE eps`` of it) is ``NOISE_SAFETY`` times
    the measured ``noise`` [units of the row]."""
    return NOISE_SAFETY * noise / (ULPS_PER_VALUE * EPS)


def _apply_one_sided(J: NDArray, err: NDArray, converged: NDArray, checks: list[OneSided], scale: NDArray):
    """At a kink: the mean of the one-sided slopes with :meth:`OneSided.kink_error`; at a jump:
    an infinite error estimate. Both are flagged unconverged. Returns the kink and jump flags."""
    kinks = np.zeros(J.shape, dtype=bool)
    jumps = np.zeros(J.shape, dtype=bool)
    for j, check in enumerate(checks):
        k, jump = check.kink(scale), check.jump(scale)
        J[k, j] = check.mean[k]
        err[k, j] = np.maximum(err[k, j], check.kink_error(scale)[k])
        err[jump, j] = np.inf
        converged[k | jump, j] = False
        kinks[:, j], jumps[:, j] = k, jump
    return kinks, jumps


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
    halving where it passes. The error estimate of an entry is the largest of its last change,
    a quarter of the change before (the last change underestimates the error before the
    ``Delta^2`` regime is reached, when the changes shrink faster than fourfold) and its
    round-off level ``4 eps (3|g0| + 4|gm| + |g1| + 8 v) / |Delta|`` (four ulps per value and
    :func:`value_scale` ``v``; the larger safety factor only guards the convergence test);
    entries still moving after ``max_halvings`` are flagged unconverged. The error estimate is at
    least the entry's distance to the slope at the column's last step plus a quarter of the
    two-sided change of :func:`one_sided_check` there: the forward changes alone can stall by
    coincidence (an ``a Delta^2`` and a ``b Delta^3`` term cancelling in the difference), both
    sides together cannot.

    The method is one-sided, so three more evaluations per column on the other side (at minus
    the last two steps and half the last) feed :func:`one_sided_check`, which reuses the last
    forward values: at a kink the entry becomes the mean of the one-sided slopes.
    Unconverged entries, kinks and jumps are reported by an :class:`~linflex.AccuracyWarning`.
    """
    n_rows, n_vars = g0.size, z0.size
    J = np.zeros((n_rows, n_vars))
    err = np.zeros((n_rows, n_vars))
    converged = np.zeros((n_rows, n_vars), dtype=bool)
    used = np.zeros((n_rows, n_vars))  # |Delta| of each accepted entry
    checks = []
    steps = _nominal_steps(z0, rel_step, zero_step, scale)
    noise = measured_noise(g, z0, steps)
    noisy = 8 * noise_scale(noise)  # in the round-off level of a three-point quotient: no halving into noise
    rtol = 10.0 ** (-digits)
    for j in range(n_vars):
        delta = steps[j]
        z = z0.copy()
        z[j] = z0[j] + delta / 2
        gm = g(z, j)
        z[j] = z0[j] + delta
        g1 = g(z, j)
        known = {delta / 2: gm, delta: g1}  # by offset, for the one-sided check
        d_old = (-3 * g0 + 4 * gm - g1) / delta
        frozen = np.zeros(n_rows, dtype=bool)
        previous = np.zeros(n_rows)
        for _ in range(max_halvings):
            delta /= 2
            g1 = gm
            z[j] = z0[j] + delta / 2
            gm = g(z, j)
            known[delta / 2] = gm
            d_new = (-3 * g0 + 4 * gm - g1) / delta
            change = np.abs(d_new - d_old)
            roundoff = ULPS_PER_VALUE * EPS * (3 * np.abs(g0) + 4 * np.abs(gm) + np.abs(g1) + noisy) / abs(delta)
            floor = np.maximum(abs_tol, roundoff_factor * roundoff)  # 100 eps per value, as the reference
            ok = change <= np.maximum(rtol * np.abs(d_new), floor)
            newly = ok & ~frozen
            estimate = np.maximum(np.maximum(change, previous / 4), roundoff)
            J[newly, j] = d_new[newly]
            err[newly, j] = estimate[newly]
            used[newly, j] = abs(delta)
            converged[newly, j] = True
            frozen |= ok
            if frozen.all():
                break
            d_old, previous = d_new, change
        rest = ~frozen
        J[rest, j] = d_new[rest]
        err[rest, j] = estimate[rest]
        used[rest, j] = abs(delta)
        # The last step's values at delta/2, delta and 2 delta are known: s = |delta| / 2.
        checks.append(one_sided_check(g, z0, g0, j, abs(delta) / 2, known))
    rows = value_scale(g0, z0, checks, noise)
    err = np.maximum(err, ULPS_PER_VALUE * EPS * 8 * rows[:, None] / used)
    for j, check in enumerate(checks):
        # Both sides' changes bound the last step's slope error to leading order, also where
        # the forward changes alone stalled by coincidence: with D = g' + a s^2 + b s^3 on the
        # forward side, |D - g'| <= (1/6 + 1/14) (changes of both sides) (see one_sided_check).
        # An entry accepted earlier is as far from the truth as from that slope, plus its error.
        last = check.forward if steps[j] > 0 else check.backward
        err[:, j] = np.maximum(err[:, j], np.abs(J[:, j] - last) + check.change / 4)
    kinks, jumps = _apply_one_sided(J, err, converged, checks, rows)
    result = NumericalJacobian(J, err, converged, g.calls, kinks, jumps)
    report(result, g, "perturbation", digits=digits)
    return result


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
    last extrapolation) plus the round-off level of the finest difference quotient,
    ``eps (|g(z0 + h)| + |g(z0 - h)| + |g0| + 2 v) / h`` with :func:`value_scale` ``v``, times
    ``roundoff_factor`` for the amplification through the table; entries
    whose estimate exceeds ``10**-digits`` of their magnitude (and the round-off level) are
    flagged unconverged.

    The values at the three finest offsets ``+-h`` feed :func:`one_sided_check` (two more
    evaluations per column when ``levels`` is 2): at a kink the Richardson table extrapolates a
    series the function does not have, so the entry becomes the mean of the one-sided slopes
    with their half difference as its error. Unconverged entries, kinks and jumps are reported
    by an :class:`~linflex.AccuracyWarning`.
    """
    n_rows, n_vars = g0.size, z0.size
    J = np.zeros((n_rows, n_vars))
    err = np.zeros((n_rows, n_vars))
    converged = np.zeros((n_rows, n_vars), dtype=bool)
    roundoffs = np.zeros((n_rows, n_vars))
    finest = np.zeros(n_vars)
    checks = []
    steps = np.abs(_nominal_steps(z0, rel_step, zero_step, scale))
    noise = measured_noise(g, z0, steps)
    for j in range(n_vars):
        h = steps[j]
        table: list[NDArray] = []
        roundoff = np.zeros(n_rows)
        z = z0.copy()
        known = {}
        for k in range(levels):
            z[j] = z0[j] + h
            gp = known[h] = g(z, j)
            z[j] = z0[j] - h
            gmi = known[-h] = g(z, j)
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
        err[:, j] = change
        roundoffs[:, j], finest[j] = roundoff, 2 * h
        checks.append(one_sided_check(g, z0, g0, j, 2 * h, known))
    rows = value_scale(g0, z0, checks, noise)
    roundoffs += roundoff_factor * EPS * 2 * rows[:, None] / finest
    err += roundoffs
    converged = err <= np.maximum(10.0 ** (-digits) * np.abs(J), 2 * roundoffs)
    kinks, jumps = _apply_one_sided(J, err, converged, checks, rows)
    result = NumericalJacobian(J, err, converged, g.calls, kinks, jumps)
    report(result, g, "central", digits=digits)
    return result


def complex_step_jacobian(
    g: CountingFunction,
    z0: NDArray,
    *,
    step: float,
    g0: NDArray | None = None,
    scale: NDArray | None = None,
    zero_step: float = 1e-6,
) -> NumericalJacobian:
    """The complex-step Jacobian ``Im g(z0 + i h e_j) / h``: no subtractive cancellation.

    Requires a model written with complex-safe operations (no ``abs``, comparisons on values or
    ``np.real`` casts); a model that drops the imaginary part everywhere is detected and
    refused. The error estimate is the round-off level ``4 eps max(|J_ij|, max_k |J_ik|)``: the
    imaginary parts are sums of terms the size of the row's entries, so an entry much smaller
    than its row (or zero, where the step's ``h^2 g'''/6`` remains) carries their round-off.

    A model that drops the imaginary part in some operations only (``np.abs`` of a complex
    number is real, so ``|x|`` has a complex-step derivative 0 everywhere) or that is not
    differentiable at the point cannot be told from the complex step alone: the real check of
    :func:`exact_jacobian_check` (six real evaluations per column, steps from ``scale`` and
    ``zero_step`` as for ``central``) catches both.
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
            if isinstance(err.__cause__, ModelError) and err.__cause__.__cause__ is None:
                raise  # the model's own complaint (a wrong number of values), not a failure on complex input
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
    g0 = g(z0) if g0 is None else g0
    row = np.max(np.abs(J), axis=1, keepdims=True) if J.size else np.zeros((J.shape[0], 1))
    return exact_jacobian_check(g, z0, g0, J, ULPS_PER_VALUE * EPS * np.maximum(np.abs(J), row),
                                method="complex-step", scale=scale, zero_step=zero_step)


def exact_jacobian_check(
    g: CountingFunction,
    z0: NDArray,
    g0: NDArray,
    J: NDArray,
    error: NDArray,
    *,
    method: str,
    scale: NDArray | None = None,
    zero_step: float = 1e-6,
) -> NumericalJacobian:
    """Check an exact Jacobian (complex step, algorithmic differentiation) by real one-sided slopes.

    An exact method returns one number at a point where the model is not differentiable: the
    complex step of ``abs`` is 0 (numpy's ``abs`` drops the imaginary part), CasADi's derivative of
    ``fabs`` at 0 is 0 and of ``fmax`` at a tie 0.5, an ``if_else`` takes one branch's derivative,
    all with no hint. :func:`one_sided_check` on every column, with the finest offset a quarter of
    ``CHECK_REL_STEP * max(|z0_j|, scale_j)`` (at least ``zero_step``), costs six real
    evaluations per column and finds kinks and jumps: a kinked entry becomes the mean of the
    one-sided slopes with :meth:`OneSided.kink_error`, a jump gets an infinite error estimate.
    An entry of a smooth model where ``J`` differs from the real central value by more than
    the real differences' error (a model that drops the imaginary part, such as ``abs`` away
    from 0) takes the real central value and its error estimate. Each case is flagged
    unconverged and reported by an :class:`~linflex.AccuracyWarning`.

    Parameters
    ----------
    g : CountingFunction
        The stacked model.
    z0, g0 : ndarray
        The point and ``g(z0)``.
    J, error : ndarray, shape (n_rows, n_vars)
        The exact method's Jacobian and its error estimate (units of the entries).
    method : str
        The method's name, for the warning.
    scale : ndarray, shape (n_vars,), optional
        Characteristic magnitudes of the variables (their units).
    zero_step : float
        Coarsest offset of a variable whose value and scale are zero (its units).

    Returns
    -------
    NumericalJacobian
        The checked Jacobian, its error estimate and flags.
    """
    J, err = np.array(J, dtype=float), np.array(error, dtype=float)
    n_rows, n_vars = J.shape
    converged = np.ones((n_rows, n_vars), dtype=bool)
    disagree = np.zeros((n_rows, n_vars), dtype=bool)
    scale_ = np.zeros(n_vars) if scale is None else scale
    steps = np.abs(_nominal_steps(z0, CHECK_REL_STEP, zero_step, scale_))
    exact = J.copy()
    checks = [one_sided_check(g, z0, g0, j, steps[j] / 4) for j in range(n_vars)]
    rows = value_scale(g0, z0, checks, measured_noise(g, z0, steps))
    for j, check in enumerate(checks):
        smooth = ~(check.kink(rows) | check.jump(rows))
        real_error = check.change + KINK_ROUNDOFF_FACTOR * check.noise(rows)
        off = smooth & (np.abs(exact[:, j] - check.mean) > real_error + err[:, j])
        J[off, j] = check.mean[off]
        err[off, j] = check.change[off] + check.noise(rows)[off]
        converged[off, j] = False
        disagree[:, j] = off
    kinks, jumps = _apply_one_sided(J, err, converged, checks, rows)
    result = NumericalJacobian(J, err, converged, g.calls, kinks, jumps)
    report(result, g, method, exact=exact, disagree=disagree)
    return result


def _label(g: CountingFunction, i: int, j: int) -> str:
    return f"{g.rows[i]} by {g.names[j]}"


def _listing(items: list[str], limit: int = 4) -> str:
    text = "; ".join(items[:limit])
    return text + (f"; and {len(items) - limit} more" if len(items) > limit else "")


def _warn(message: str) -> None:
    """Issue an :class:`~linflex.AccuracyWarning` at the first caller outside linflex.

    The depth of the call inside linflex varies (``linearize``, ``trim``, trajectories), so
    the stack level is counted rather than fixed.
    """
    frame, level = sys._getframe(0), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith("linflex"):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, AccuracyWarning, stacklevel=level)


def report(result: NumericalJacobian, g: CountingFunction, method: str, *, digits: float | None = None,
           exact: NDArray | None = None, disagree: NDArray | None = None) -> None:
    """Warn about kinks, jumps, disagreement with real differences and ``digits`` not reached.

    Parameters
    ----------
    result : NumericalJacobian
        The checked Jacobian.
    g : CountingFunction
        The stacked model (for the row and column names).
    method : str
        The method's name.
    digits : float, optional
        The requested significant digits (``perturbation``, ``central``); smooth entries that
        failed the method's accuracy test and whose error estimate exceeds ``10**-digits`` of
        the larger of the entry and its row's largest entry are reported with the digits they
        reached (an entry at the round-off floor passed the test: its estimate says how far).
    exact, disagree : ndarray, optional
        An exact method's own Jacobian and the entries where it disagreed with the real
        differences (:func:`exact_jacobian_check`).
    """
    J, err = result.J, result.error
    kinks = np.zeros(J.shape, dtype=bool) if result.kinks is None else result.kinks
    jumps = np.zeros(J.shape, dtype=bool) if result.jumps is None else result.jumps
    if kinks.any():
        items = [f"{_label(g, i, j)} (value {J[i, j]:.6g} +- {err[i, j]:.3g})" for i, j in np.argwhere(kinks)]
        _warn(f"linearize ({method}): the model has a kink at the operating point (or noise far above "
              "round-off): its one-sided slopes "
              f"disagree beyond their error estimates: {_listing(items)}. {method!r} returns the central "
              "value (the mean of the one-sided slopes) with half their difference, plus their errors, "
              "as the error estimate; linearize at a point beside the kink for a one-sided model")
    if jumps.any():
        items = [_label(g, i, j) for i, j in np.argwhere(jumps)]
        _warn(f"linearize ({method}): the model's value jumps at the operating point, so these entries "
              f"have no derivative: {_listing(items)}. {method!r} keeps its value with an infinite "
              "error estimate")
    if disagree is not None and disagree.any():
        items = [f"{_label(g, i, j)}: {exact[i, j]:.6g} against {J[i, j]:.6g} +- {err[i, j]:.3g}"
                 for i, j in np.argwhere(disagree)]
        _warn(f"linearize ({method}): the {method} derivative disagrees with real one-sided differences "
              f"beyond their error estimate: {_listing(items)}. The model may drop the imaginary part "
              "(abs, comparisons, real casts) or change branch next to the point; the Jacobian holds the "
              "real central value with its error estimate")
    if digits is not None:
        # Digits relative to the entry or to its row's largest entry, whichever is larger: an
        # entry that is zero has no significant digits, but its row has a scale.
        finite = np.where(np.isfinite(J) & ~jumps, np.abs(J), 0.0)
        size = np.maximum(finite, finite.max(axis=1, keepdims=True) if J.shape[1] else 0.0)
        missed = ~result.converged & ~kinks & ~jumps & (err > 10.0 ** (-digits) * size)
        if missed.any():
            items = []
            for i, j in np.argwhere(missed):
                with np.errstate(divide="ignore"):
                    reached = max(0.0, float(np.log10(size[i, j] / err[i, j])))
                items.append(f"{_label(g, i, j)} = {J[i, j]:.6g} +- {err[i, j]:.3g} ({reached:.1f} digits)")
            _warn(f"linearize ({method}): {int(missed.sum())} Jacobian entries did not reach digits={digits:g} "
                  f"(relative to the entry or its row's largest entry): {_listing(items)}; their error estimates "
                  "give the accuracy reached")
