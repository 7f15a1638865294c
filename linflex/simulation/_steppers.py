"""The integrators behind ``simulate``: CVODES and IDAS through CasADi, scipy's ``solve_ivp`` and
linflex's exponential integrator, each as a stepper ``step(times, x0, U) -> X[1:]`` with ``U[k]``
held on ``[times[k], times[k+1])``, and the counts of a run (:class:`IntegratorCounts`)."""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..system._errors import ConvergenceError
from ..system._jacobians import colored_jacobian
from ..system._model import NonlinearModel

__all__ = ["IntegratorCounts", "autonomous", "buffered_function", "jacobian_function", "stepper"]

EXPONENTIAL = "exponential"
CASADI_METHODS = ("cvodes", "cvodes-adams", "idas", EXPONENTIAL)
SCIPY_METHODS = ("scipy-RK45", "scipy-DOP853", "scipy-RK23", "scipy-Radau", "scipy-BDF", "scipy-LSODA")


@dataclass
class IntegratorCounts:
    """Counts of one run of an integrator, as the integrator reports them.

    Attributes
    ----------
    steps, rejected, evaluations, linearizations : int or None
        Accepted steps, rejected steps (failed error tests and, for CVODES and IDAS, failed
        Newton iterations), evaluations of the right-hand side ``f`` (CVODES: without those of
        the Jacobian) and Jacobians taken; None where the integrator does not report one
        (scipy's ``solve_ivp`` reports no steps).
    """

    steps: int | None = 0
    rejected: int | None = 0
    evaluations: int | None = 0
    linearizations: int | None = 0

    def add(self, **counts: int) -> None:
        """Add ``counts`` (names of the attributes) to the running totals."""
        for name, value in counts.items():
            setattr(self, name, getattr(self, name) + int(value))


def stepper(model: NonlinearModel, method: str, rtol: float, atol, U, u_cont, timepts,
            jacobian0: np.ndarray | None = None):
    """``(step, counts)``: the integrator of ``method`` for one run, and the counts it adds to.

    The CVODES and IDAS integrators of a model are built once and reused by later runs with the
    same method and tolerances; scipy's and the exponential one are built for each run (the
    latter's frozen Jacobian belongs to the run; it starts from ``jacobian0``, df/dx at the first
    step's start [1/s], where the caller has it). The exponential integrator steps a compiled
    flexible model in its momentum form (:func:`~linflex.simulation._momentum.momentum_form`:
    the states it returns are the model's; ``jacobian0``, taken in them, is not used there).
    """
    counts = IntegratorCounts()
    if method == EXPONENTIAL:
        from ._exponential import exponential_stepper
        from ._momentum import momentum_form

        pv = model.param_values
        form = momentum_form(model)
        if form is not None:  # flexible models: steps in z = (q, M(q) u, a) (see _momentum)
            step_z = momentum_stepper(form, pv, rtol, atol, counts)

            def step(times, x0, U):
                Z = step_z(times, form.to_z(x0, pv, times[0]), U)
                return form.to_x(Z, pv, times[1:])
            return step, counts
        f, _ = model.casadi_functions()
        jac = jacobian_function(model)
        return exponential_stepper(buffered_function(f, pv), lambda x, u, t: jac(x, u, pv, t).full(),
                                   rtol, atol, counts, jacobian0), counts
    if method in CASADI_METHODS:
        raw = _casadi_stepper(model, method, rtol, atol)
    else:
        counts.steps = counts.rejected = None
        raw = _scipy_stepper(model, method, rtol, atol, U, u_cont, timepts)
    return (lambda times, x0, U: raw(times, x0, U, counts)), counts


def buffered_function(f, params) -> Callable[[np.ndarray, np.ndarray, float], np.ndarray]:
    """``(x, u, t) -> f(x, u, params, t)`` through CasADi's call buffer (``Function.buffer``):
    the arguments are copied into fixed arrays and the function runs on them, without the
    allocation and conversion of an ordinary call (70 us of overhead per call on the models
    of ``benchmarks/simulation.py``, several times the evaluation itself on small models).

    Parameters
    ----------
    f : casadi.Function
        Of ``(x, u, p, t)`` with one dense output.
    params : array_like
        The values of ``p``.

    Returns
    -------
    callable
        ``(x, u, t) -> xdot``, a new array on every call.
    """
    buffer, trigger = f.buffer()
    args = [np.zeros(f.nnz_in(i)) for i in range(4)]
    args[2][:] = np.asarray(params, float).reshape(-1)
    out = np.zeros(f.nnz_out(0))
    for i, a in enumerate(args):
        buffer.set_arg(i, memoryview(a))
    buffer.set_res(0, memoryview(out))
    x_arg, u_arg, t_arg = args[0], args[1], args[3]
    alive = (f, buffer, args)  # the buffer points into these: they live as long as the closure

    def call(x, u, t, alive=alive):
        x_arg[:] = x
        u_arg[:] = u
        t_arg[0] = t
        trigger()
        return out.copy()
    return call


def momentum_stepper(form, params, rtol: float, atol, counts: IntegratorCounts, **options):
    """The exponential integrator's stepper ``step(times, z0, U) -> Z[1:]`` in a model's momentum
    form ``form`` (:class:`~linflex.simulation._momentum.MomentumForm`, parameter values
    ``params``): states ``z = (q, M(q) u, a)``, errors measured in the speeds ``u``; ``options``
    go to :func:`~linflex.simulation._exponential.exponential_stepper`."""
    from ._exponential import exponential_stepper

    return exponential_stepper(buffered_function(form.f, params),
                               lambda z, u, t: form.jacobian(z, u, params, t).full(), rtol, atol, counts,
                               momenta=(form.speeds, lambda z, u, t: form.inverse_mass(z, params, t)), **options)


# Integrators built for a model, reused by later calls with the same method and tolerances
# (building a CVODES integrator costs more than a short run). Keyed weakly by the model, so the
# cache never keeps a model alive; it holds no numerical state between calls.
_STEPPERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def jacobian_function(model: NonlinearModel):
    """``df/dx`` of a CasADi model as a ``casadi.Function`` of ``(x, u, p, t)``, built once per model.

    Coloured directional sweeps (:func:`~linflex.system.colored_jacobian`, as the autodiff
    linearization): exact, and cheap to build (a symbolic ``ca.jacobian`` of a compiled
    flexible model costs more to build than a short run).
    """
    import casadi as ca

    per_model = _STEPPERS.setdefault(model, {})
    if "jacobian" not in per_model:
        f, _ = model.casadi_functions()
        n, n_p = model.n_states, len(model.params)
        sym = ca.SX if model.f.is_a("SXFunction") else ca.MX
        x, u, p, t = sym.sym("x", n), sym.sym("u", model.n_inputs), sym.sym("p", n_p), sym.sym("t")
        X, U, P, T = ca.MX.sym("x", n), ca.MX.sym("u", model.n_inputs), ca.MX.sym("p", n_p), ca.MX.sym("t")
        J = colored_jacobian(f(x, u, p, t), x, [u, p, t], X, [U, P, T])
        per_model["jacobian"] = ca.Function("jacobian_x", [X, U, P, T], [ca.densify(J)])
    return per_model["jacobian"]


def autonomous(model: NonlinearModel) -> bool:
    """Whether a CasADi model's ``f`` does not depend on time explicitly."""
    f, _ = model.casadi_functions()
    return f.sparsity_jac("t", "xdot").nnz() == 0


def _casadi_stepper(model: NonlinearModel, method: str, rtol: float, atol: float):
    per_model = _STEPPERS.setdefault(model, {})
    key = (method, float(rtol), atol if isinstance(atol, float) else tuple(atol.tolist()))
    if key not in per_model:
        per_model[key] = _build_casadi_stepper(model, method, rtol, atol)
    return per_model[key]


def _build_casadi_stepper(model: NonlinearModel, method: str, rtol: float, atol: float):
    import casadi as ca

    f, _ = model.casadi_functions()
    n, m = model.n_states, model.n_inputs
    xs, us = ca.MX.sym("x", n), ca.MX.sym("u", m)
    tau, t0 = ca.MX.sym("tau"), ca.MX.sym("t0")
    p = ca.MX.sym("p", len(model.params))
    # A per-state atol: CVODES integrates z = x / w with one absolute tolerance (see simulate's Notes).
    w = np.ones(n) if isinstance(atol, float) else atol / np.min(atol)
    scaled = not np.all(w == 1.0)
    wd = ca.DM(w)
    x_of = (lambda z: z * (wd if isinstance(z, ca.MX) else w)) if scaled else (lambda z: z)
    z_of = (lambda v: v / (wd if isinstance(v, ca.MX) else w)) if scaled else (lambda v: v)
    # Autonomous models need no time offset parameter (it would cost a Jacobian column).
    time_free = autonomous(model)
    if time_free:
        dae = {"x": xs, "u": us, "p": p, "t": tau, "ode": z_of(f(x_of(xs), us, p, tau))}
    else:
        dae = {"x": xs, "u": us, "p": ca.vertcat(t0, p), "t": tau, "ode": z_of(f(x_of(xs), us, p, t0 + tau))}
    # regularity_check: a NaN or Inf state derivative ends the run at once (CasADi's default lets
    # SUNDIALS retry with smaller steps: a diverging model, x' = 10 x over 100 s, crept up to
    # the overflow in a million steps, 50 s and 4e5 lines of warnings, to CV_TOO_MUCH_WORK).
    opts = {"abstol": float(np.min(atol)), "reltol": float(rtol), "max_num_steps": 1_000_000,
            "regularity_check": True}
    plugin = method
    if method == "cvodes-adams":
        plugin = "cvodes"
        opts.update(linear_multistep_method="adams", nonlinear_solver_iteration="functional")
    cache: dict[tuple, Any] = {}

    def step(times: np.ndarray, x0: np.ndarray, U: np.ndarray, counts: IntegratorCounts) -> np.ndarray:
        grid = times - times[0]
        key = tuple(np.round(grid, 12))
        if key not in cache:
            cache[key] = ca.integrator("F", plugin, dae, 0.0, grid.tolist(), opts)
        F = cache[key]
        # CasADi applies column k of u on the interval that ends at grid[k]: shift by one.
        # Column 0 acts at grid[0] only, where IDAS takes its initial state derivative: the
        # first interval's input (a zero there left IDAS an inconsistent x'(t0), and its error
        # test failed at tight tolerances).
        ucols = np.empty((m, grid.size))
        ucols[:, 1:] = U[:-1].T
        ucols[:, 0] = U[0]
        pv = model.param_values if time_free else np.concatenate([[times[0]], model.param_values])
        try:
            res = F(x0=z_of(np.asarray(x0, float)), u=ucols, p=pv)
        except RuntimeError as err:
            why = ""
            if "RHSFUNC_FAIL" in str(err) or "RES_FAIL" in str(err):
                why = ("the state derivative became NaN or Inf (the motion diverges, or the model is evaluated "
                       "outside its domain); ")
            raise ConvergenceError(f"{method} failed between t = {times[0]} s and {times[-1]} s: {why}{err}") from err
        stats = F.stats()
        counts.add(steps=stats["nsteps"], rejected=stats["netfails"] + stats["nncfails"],
                   evaluations=stats["nfevals"], linearizations=stats.get("n_call_jacF", 0))
        return x_of(np.asarray(res["xf"], float).T[1:])
    return step


def _scipy_stepper(model: NonlinearModel, method: str, rtol, atol, U_all, u_cont, timepts_all):
    from scipy.integrate import solve_ivp

    name = method.split("-", 1)[1]
    jac = None
    if model.is_casadi:
        # through CasADi's call buffer: scipy's explicit methods take several evaluations per
        # step, each a few microseconds of arithmetic on small models and ~40 us of an ordinary
        # call's conversions (measured on the rigid axis of benchmarks/sampled.py: 1.07 s of
        # which 0.97 s in the calls, at 18674 evaluations)
        f4, _ = model.casadi_functions()
        pv = model.param_values
        fcall = buffered_function(f4, pv)

        def fun(tt, xx, uu):
            return fcall(xx, uu, tt)
        if name in ("Radau", "BDF", "LSODA"):
            # Implicit methods get the exact Jacobian from the graph.
            jfun = jacobian_function(model)

            def jac(tt, xx, uu):
                return None, jfun(xx, uu, pv, tt).full()
    else:
        def fun(tt, xx, uu):
            return np.asarray(model.evaluate_raw(xx, uu, tt)[0], float)

    def step(times: np.ndarray, x0: np.ndarray, U: np.ndarray, counts: IntegratorCounts) -> np.ndarray:
        out = np.zeros((times.size - 1, x0.size))
        if u_cont is not None:
            extra = {} if jac is None else {"jac": lambda tt, xx: jac(tt, xx, u_cont(tt))[1]}
            res = solve_ivp(lambda tt, xx: fun(tt, xx, u_cont(tt)), (times[0], times[-1]), x0, method=name,
                            t_eval=times, rtol=rtol, atol=atol, **extra)
            if not res.success:
                raise ConvergenceError(f"{method} failed: {res.message}")
            counts.add(evaluations=res.nfev, linearizations=res.njev)
            return res.y.T[1:]
        xk = x0
        # Piecewise-constant inputs: integrate interval by interval only where they change.
        k = 0
        while k < times.size - 1:
            e = k + 1
            while e < times.size - 1 and np.array_equal(U[e], U[k]):
                e += 1
            uk = U[k]
            extra = {} if jac is None else {"jac": lambda tt, xx, uk=uk: jac(tt, xx, uk)[1]}
            res = solve_ivp(lambda tt, xx, uk=uk: fun(tt, xx, uk), (times[k], times[e]), xk, method=name,
                            t_eval=times[k:e + 1], rtol=rtol, atol=atol, **extra)
            if not res.success:
                raise ConvergenceError(f"{method} failed: {res.message}")
            counts.add(evaluations=res.nfev, linearizations=res.njev)
            out[k:e] = res.y.T[1:]
            xk = res.y[:, -1]
            k = e
        return out
    return step
