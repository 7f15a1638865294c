"""Exact Jacobians from a model's CasADi graph (algorithmic differentiation)."""

from __future__ import annotations

import time
import weakref

import numpy as np

from linflex import NonlinearModel

__all__ = ["jacobian_function"]

# Compiled Jacobian functions, one per model object: built once, reused by later
# linearizations of the same model (trajectories, sweeps, trim iterations). A cache, not state:
# it never changes a result.
_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


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
    cached = _CACHE.get(model)
    if cached is not None:
        return cached, 0.0
    import casadi as ca

    start = time.perf_counter()
    f_fun, h_fun = model.casadi_functions()
    # SX graphs evaluate fastest; keep MX when the model is MX (large linear solves stay nodes).
    sx = model.f.is_a("SXFunction") and (model.h is None or model.h.is_a("SXFunction"))
    sym = ca.SX if sx else ca.MX
    x = sym.sym("x", model.n_states)
    u = sym.sym("u", model.n_inputs)
    p = sym.sym("p", len(model.params))
    t = sym.sym("t")
    xdot = f_fun(x, u, p, t)
    y = h_fun(x, u, p, t)
    outputs = [xdot, y, ca.jacobian(xdot, x), ca.jacobian(xdot, u), ca.jacobian(y, x), ca.jacobian(y, u)]
    function = ca.Function("linearization", [x, u, p, t], outputs,
                           ["x", "u", "p", "t"], ["f", "h", "A", "B", "C", "D"])
    _CACHE[model] = function
    return function, time.perf_counter() - start


def autodiff_jacobians(model: NonlinearModel, x, u, p, t):
    """``(f, h, A, B, C, D)`` as dense numpy arrays, and the build time of the graph [s]."""
    function, build_seconds = jacobian_function(model)
    values = function(x, u, p, t)
    shapes = [(model.n_states,), (model.n_outputs,), (model.n_states, model.n_states),
              (model.n_states, model.n_inputs), (model.n_outputs, model.n_states),
              (model.n_outputs, model.n_inputs)]
    arrays = [np.asarray(ca_value.full() if hasattr(ca_value, "full") else ca_value, dtype=float).reshape(shape)
              for ca_value, shape in zip(values, shapes)]
    return arrays, build_seconds
