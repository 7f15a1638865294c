"""Exact Jacobians from a model's CasADi graph (algorithmic differentiation).

A graph with operations that are not differentiable everywhere (``fabs``, ``fmin``/``fmax``,
``sign``, ``if_else`` and comparisons, ``floor``, ...) gets the real one-sided check of
:func:`~linflex.linearize._differences.exact_jacobian_check` after the exact Jacobian: CasADi's
derivative at such a point is a convention (``fabs'(0) = 0``, ``fmax`` at a tie 0.5, one
branch of an ``if_else``), so a kink there is reported with the one-sided slopes' error
instead of an error estimate of zero. Smooth graphs pay nothing.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from linflex import ModelError, NonlinearModel
from linflex.system import colored_jacobian

from ._differences import exact_jacobian_check, model_function
from ._result import LinearizationProblem, MethodResult

__all__ = ["jacobian_function"]

# How many models keep their compiled Jacobian function (the ones linearized last).
CACHED_MODELS = 8

# CasADi operation codes (casadi.OP_*) of functions with kinks or jumps somewhere.
NONSMOOTH_OPERATIONS = ("FABS", "FMIN", "FMAX", "MMIN", "MMAX", "SIGN", "COPYSIGN", "IF_ELSE_ZERO", "LT", "LE",
                        "EQ", "NE", "NOT", "AND", "OR", "FLOOR", "CEIL", "FMOD", "REMAINDER", "NORM1", "NORMINF")


def jacobian_function(model: NonlinearModel):
    """The ``casadi.Function`` ``(x, u, p, t) -> (f, h, A, B, C, D)`` of a CasADi model.

    Parameters
    ----------
    model : NonlinearModel
        A model built from CasADi expressions (:meth:`NonlinearModel.from_casadi` or a compiled
        scene).

    Returns
    -------
    function : casadi.Function
    build_seconds : float
        Time spent building it now [s]; 0 when it came from the cache.

    Raises
    ------
    MethodUnavailableError
        For a model of numpy callables (the message names the methods that work).
    ModelError
        For anything but a :class:`NonlinearModel`.

    Notes
    -----
    The function is built once per model object and reused by later linearizations of the
    same model (trajectories, sweeps, trim iterations): ``functools.lru_cache`` keyed on the
    model (models are immutable and compare by identity) keeps the functions of the
    ``CACHED_MODELS`` (8) models used last. A cache, not state: it never changes a result.

    Examples
    --------
    A pendulum (9.81 m/s^2 over a 1 m arm) at rest; the function's third output is ``A``:

    >>> import casadi as ca
    >>> import numpy as np
    >>> from linflex import NonlinearModel
    >>> from linflex.linearize import jacobian_function
    >>> x, u = ca.SX.sym("x", 2), ca.SX.sym("u", 1)
    >>> pend = NonlinearModel.from_casadi(ca.vertcat(x[1], -9.81 * ca.sin(x[0]) + u[0]), x, u,
    ...                                   states=["theta", "omega"], inputs=["torque"])
    >>> fun, seconds = jacobian_function(pend)
    >>> np.array(fun([0.0, 0.0], [0.0], [], 0.0)[2]).tolist()
    [[0.0, 1.0], [-9.81, 0.0]]
    >>> jacobian_function(pend)[1]  # the second call comes from the cache
    0.0
    """
    if not isinstance(model, NonlinearModel):
        raise ModelError(f"model must be a NonlinearModel built from CasADi expressions, got {type(model).__name__}")
    misses = _build.cache_info().misses
    start = time.perf_counter()
    function = _build(model)
    built = _build.cache_info().misses > misses
    return function, (time.perf_counter() - start) if built else 0.0


@functools.lru_cache(maxsize=CACHED_MODELS)
def _build(model: NonlinearModel):
    """The Jacobians by directional derivatives of the graph, evaluated numerically:
    ``g(z, p, t) = [f; h]`` with ``z = [x; u]`` differentiated by coloured sweeps
    (:func:`linflex.system.colored_jacobian`). Exact to round-off, like the symbolic Jacobian.
    """
    import casadi as ca

    f_fun, h_fun = model.casadi_functions()
    # SX graphs evaluate fastest; keep MX when the model is MX (large linear solves stay nodes).
    sx = model.f.is_a("SXFunction") and (model.h is None or model.h.is_a("SXFunction"))
    sym = ca.SX if sx else ca.MX
    nx, nu, n_p = model.n_states, model.n_inputs, len(model.params)
    z, p, t = sym.sym("z", nx + nu), sym.sym("p", n_p), sym.sym("t")
    g_expr = ca.vertcat(f_fun(z[:nx], z[nx:], p, t), h_fun(z[:nx], z[nx:], p, t))
    Z, P, T = ca.MX.sym("z", nx + nu), ca.MX.sym("p", n_p), ca.MX.sym("t")
    out = ca.Function("g", [z, p, t], [g_expr])(Z, P, T)
    J = colored_jacobian(g_expr, z, [p, t], Z, [P, T])
    outputs = [out[:nx], out[nx:], J[:nx, :nx], J[:nx, nx:], J[nx:, :nx], J[nx:, nx:]]
    x, u = ca.MX.sym("x", nx), ca.MX.sym("u", nu)
    inner = ca.Function("jacobians", [Z, P, T], outputs)
    # Dense outputs: numpy arrays are filled in place (see _evaluate).
    return ca.Function("linearization", [x, u, P, T], [ca.densify(v) for v in inner(ca.vertcat(x, u), P, T)],
                       ["x", "u", "p", "t"], ["f", "h", "A", "B", "C", "D"])


def _graph_is_nonsmooth(function, codes: frozenset) -> bool:
    """Whether a ``casadi.Function`` (and the functions it calls) uses a non-smooth operation."""
    import casadi as ca

    try:
        ids = [function.instruction_id(k) for k in range(function.n_instructions())]
    except RuntimeError:
        return True  # a function without an instruction list (external, compiled): assume the worst
    for k, op in enumerate(ids):
        if op in codes:
            return True
        if op == ca.OP_CALL:
            try:
                inner = function.instruction_MX(k).which_function()
            except RuntimeError:
                return True
            if _graph_is_nonsmooth(inner, codes):
                return True
    return False


@functools.lru_cache(maxsize=CACHED_MODELS)
def has_nonsmooth_operations(model: NonlinearModel) -> bool:
    """Whether the model's CasADi graph uses any of :data:`NONSMOOTH_OPERATIONS` (cached per model, as :func:`jacobian_function`).

    Parameters
    ----------
    model : NonlinearModel
        A CasADi model.

    Returns
    -------
    bool
        True when ``f`` or ``h`` contains ``fabs``, ``fmin``, ``fmax``, ``sign``, ``if_else``, a
        comparison, ``floor`` or a similar operation, or calls a function whose graph is hidden.
    """
    import casadi as ca

    codes = frozenset(getattr(ca, f"OP_{name}") for name in NONSMOOTH_OPERATIONS)
    return any(_graph_is_nonsmooth(fun, codes) for fun in (model.f, model.h) if fun is not None)


def _evaluate(function, args, shapes) -> list[np.ndarray]:
    """The dense outputs of ``function`` written straight into numpy arrays (CasADi's buffer
    interface): converting a 500 x 500 ``DM`` through ``.full()`` costs more than computing it."""
    inputs = [np.ascontiguousarray(np.asarray(a, dtype=float).reshape(-1)) for a in args]
    outputs = [np.zeros(shape, order="F") for shape in shapes]
    buffer, trigger = function.buffer()
    for k, a in enumerate(inputs):
        buffer.set_arg(k, memoryview(a))
    for k, out in enumerate(outputs):
        buffer.set_res(k, memoryview(out.reshape(-1, order="F")))
    trigger()
    return outputs


def autodiff_linearization(problem: LinearizationProblem, options) -> MethodResult:
    """The ``"autodiff"`` method: exact Jacobians of the model's CasADi graph (no options).

    The stacked Jacobian ``[[A, B], [C, D]]`` has the error estimate zero, unless the graph has
    non-smooth operations (:func:`has_nonsmooth_operations`): then
    :func:`~linflex.linearize._differences.exact_jacobian_check` probes every column with six
    real evaluations, and kinked entries hold the mean of the one-sided slopes with half their
    difference as the error estimate. ``n_evaluations`` counts the Jacobian call and the probes.
    """
    model = problem.model
    function, build_seconds = jacobian_function(model)
    shapes = [(model.n_states,), (model.n_outputs,), (model.n_states, model.n_states),
              (model.n_states, model.n_inputs), (model.n_outputs, model.n_states),
              (model.n_outputs, model.n_inputs)]
    arrays = _evaluate(function, (problem.x, problem.u, problem.p, problem.t), shapes)
    f0, y0, A, B, C, D = arrays
    model.check_values(f0, y0)
    if not has_nonsmooth_operations(model):
        return MethodResult.exact(*arrays, setup_seconds=build_seconds)
    J = np.block([[A, B], [C, D]])
    g = model_function(model, problem.p, problem.t)
    result = exact_jacobian_check(g, np.concatenate([problem.x, problem.u]), np.concatenate([f0, y0]), J,
                                  np.zeros_like(J), method="autodiff", scale=problem.scale)
    return MethodResult(f0, y0, result.J, result.error, result.converged, 1 + result.evaluations,
                        setup_seconds=build_seconds)
