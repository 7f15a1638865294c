"""Trim: find an operating point where the state derivative vanishes."""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from linflex import ConvergenceError, ModelError, NonlinearModel, OperatingPoint
from linflex.system import check_positive

from ._linearization import linearize, scaled_residual
from ._methods import _integer

__all__ = ["TrimResult", "find_operating_point"]


@dataclass(frozen=True)
class TrimResult:
    """An operating point found by trim, with how well it satisfies ``f = 0``.

    Attributes
    ----------
    op : OperatingPoint
        The trimmed point.
    residual : ndarray, shape (n_states,)
        ``f(op.x, op.u, op.t)`` [state units / s].
    max_scaled_residual : float
        ``max_i |f_i| / max(1, |x_i|)`` [1/s].
    free_states, free_inputs : tuple of str
        The names that were solved for; every other state and input kept its given value.
    success : bool
        Whether ``max_scaled_residual <= tol``.
    n_evaluations : int
        Jacobian evaluations (each a linearization) plus residual evaluations.
    seconds : float
        Wall time [s].
    """

    op: OperatingPoint
    residual: NDArray[np.float64]
    max_scaled_residual: float
    free_states: tuple[str, ...]
    free_inputs: tuple[str, ...]
    success: bool
    n_evaluations: int
    seconds: float


def find_operating_point(
    model: NonlinearModel,
    x0: ArrayLike,
    u0: ArrayLike | None = None,
    *,
    fix_states: Iterable[str | int] = (),
    fix_inputs: Iterable[str | int] | None = None,
    free: Iterable[str | int] = (),
    t: float = 0.0,
    tol: float = 1e-10,
    max_iterations: int = 100,
    raise_on_failure: bool = True,
) -> TrimResult:
    """Solve ``f(x, u, t) = 0`` for the free states and inputs, starting from ``(x0, u0)``.

    By default every state is free and every input is held; ``fix_states`` holds states at
    their value in ``x0`` (for example a spin rate, so the trim finds a steady spin),
    ``fix_inputs`` lists the inputs held (default: all), and ``free`` names states or inputs
    to solve for whatever the other two say (for example the torque that holds an attitude).
    The equations are all ``n_states`` derivatives, solved in the least-squares sense by
    scipy's trust-region reflective method with the model's Jacobian (exact for CasADi
    models, central differences otherwise), so redundant equations such as a quaternion's norm
    direction are harmless.

    Parameters
    ----------
    model : NonlinearModel
    x0, u0 : array_like
        Starting point and the values of held variables [state units], [input units].
    fix_states, fix_inputs : str, int or iterables of names or indices
        States and inputs held at their ``x0``/``u0`` values (a single name or index is one).
    free : str or iterable of str
        Names of states or inputs solved for (names only: an index would not tell a state
        from an input).
    t : float
        Time [s].
    tol : float
        Largest accepted scaled residual ``max |f_i| / max(1, |x_i|)`` [1/s].
    max_iterations : int
        Cap on solver iterations (at least 1).
    raise_on_failure : bool
        Raise :class:`ConvergenceError` when ``tol`` is not met (default), else return the
        result with ``success=False``.

    Returns
    -------
    TrimResult

    Raises
    ------
    ModelError
        For a ``model`` that is not a NonlinearModel, an unknown name, an index in ``free``, nothing left to solve for, a ``tol`` that is
        not a positive number or a ``max_iterations`` that is not a positive integer.
    ConvergenceError
        When ``tol`` is not met and ``raise_on_failure`` is true.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import NonlinearModel
    >>> pend = NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
    ...                       states=["theta", "omega"], inputs=["torque"])
    >>> trim = find_operating_point(pend, [0.5, 0.0], [0.0], fix_states=["theta"], free=["torque"])
    >>> round(float(trim.op.u[0]), 6)  # 9.81 sin(0.5)
    4.703165
    """
    start = time.perf_counter()
    if not isinstance(model, NonlinearModel):
        raise ModelError(f"model must be a NonlinearModel (or a compiled scene's Model), got {type(model).__name__}")
    x0_, u0_, _ = model.check_point(x0, u0)
    tol = check_positive(tol, "tol")
    _integer("max_iterations", max_iterations, 1, "a positive integer")
    held_x = {model.state_index(k) for k in _keys(fix_states)}
    held_u = set(range(model.n_inputs)) if fix_inputs is None else {model.input_index(k) for k in _keys(fix_inputs)}
    for key in _keys(free):
        if isinstance(key, str) and key in model.states:
            held_x.discard(model.state_index(key))
        elif isinstance(key, str) and key in model.inputs:
            held_u.discard(model.input_index(key))
        elif isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            raise ModelError(f"free: give names, not the index {key!r} (an index does not tell a state from an "
                             f"input); states: {', '.join(model.states[:12])}; inputs: {', '.join(model.inputs[:12])}")
        else:
            raise ModelError(f"free: {key!r} is neither a state nor an input of the model")
    free_x = [i for i in range(model.n_states) if i not in held_x]
    free_u = [i for i in range(model.n_inputs) if i not in held_u]
    if not free_x and not free_u:
        raise ModelError("find_operating_point: every state and input is held; nothing to solve for")
    method = "autodiff" if model.is_casadi else "central"
    evaluations = 0

    def unpack(z):
        x, u = x0_.copy(), u0_.copy()
        x[free_x] = z[: len(free_x)]
        u[free_u] = z[len(free_x):]
        return x, u

    def weights(x):
        return 1.0 / np.maximum(1.0, np.abs(x))

    def residual(z):
        nonlocal evaluations
        evaluations += 1
        x, u = unpack(z)
        return model.evaluate(x, u, t)[0] * weights(x)

    def jacobian(z):
        nonlocal evaluations
        x, u = unpack(z)
        lin = linearize(model, OperatingPoint(x, u, t), method=method, allow_non_equilibrium=True)
        evaluations += lin.n_evaluations
        J = np.hstack([lin.sys.A[:, free_x], lin.sys.B[:, free_u]])
        return J * weights(x)[:, None]

    z0 = np.concatenate([x0_[free_x], u0_[free_u]])
    solution = scipy.optimize.least_squares(
        residual, z0, jac=jacobian, method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15,
        max_nfev=int(max_iterations),
    )
    x, u = unpack(solution.x)
    f = model.evaluate(x, u, t)[0]
    worst = float(np.max(scaled_residual(f, x)))
    success = worst <= tol
    result = TrimResult(
        op=OperatingPoint(x, u, t),
        residual=f,
        max_scaled_residual=worst,
        free_states=tuple(model.states[i] for i in free_x),
        free_inputs=tuple(model.inputs[i] for i in free_u),
        success=success,
        n_evaluations=evaluations,
        seconds=time.perf_counter() - start,
    )
    if not success and raise_on_failure:
        i = int(np.argmax(scaled_residual(f, x)))
        raise ConvergenceError(
            f"find_operating_point did not reach tol={tol:.1e}: scaled residual {worst:.3e} at "
            f"d({model.states[i]})/dt after {solution.nfev} iterations ({solution.message}); "
            "hold fewer variables, free an input, or start closer"
        )
    return result


def _keys(keys) -> list:
    """``fix_states``, ``fix_inputs`` or ``free`` as a list: one name or index stands for itself
    (iterating ``"theta"`` would give its letters)."""
    return [keys] if isinstance(keys, (str, int, np.integer)) else list(keys)
