"""``linearize``: one entry point over the linearization methods, with the equilibrium contract."""

from __future__ import annotations

import time
from types import MappingProxyType
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from linflex import (
    LinearSystem,
    MethodUnavailableError,
    ModelError,
    NonlinearModel,
    NotAnEquilibriumError,
    OperatingPoint,
)
from linflex._signals import frozen_array, real_vector

from ._autodiff import autodiff_linearization
from ._differences import (
    central_jacobian,
    complex_step_jacobian,
    model_function,
    perturbation_jacobian,
)
from ._direct import direct_linearization
from ._result import JacobianBlocks, Linearization

__all__ = ["METHODS", "linearize", "scaled_residual"]

METHODS = ("perturbation", "central", "complex-step", "autodiff", "kane")
Method = Literal["auto", "perturbation", "central", "complex-step", "autodiff", "kane"]


def scaled_residual(residual: np.ndarray, x: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """``|f_i| / max(1, |x_i|, scale_i)``: the residual relative to each state's magnitude.

    A state derivative is in state units per second, so this reads as a relative drift rate
    [1/s]; the unit floor keeps states that are zero at the operating point meaningful.

    Parameters
    ----------
    residual : ndarray, shape (n,)
        State derivative at the point (state units per second).
    x : ndarray, shape (n,)
        The state (state units).
    scale : ndarray, shape (n,), optional
        Typical magnitude of each state (state units).

    Returns
    -------
    ndarray, shape (n,)
        The scaled residual [1/s].

    Examples
    --------
    >>> import numpy as np
    >>> from linflex.linearize import scaled_residual
    >>> scaled_residual(np.array([1e-3, 2.0]), np.array([0.0, 100.0])).tolist()
    [0.001, 0.02]
    """
    floor = np.maximum(1.0, np.abs(x))
    if scale is not None:
        floor = np.maximum(floor, scale[: x.size])
    return np.abs(residual) / floor


def linearize(
    model: NonlinearModel,
    op: OperatingPoint | None = None,
    *,
    method: Method = "auto",
    digits: float = 6,
    rel_step: float | None = None,
    zero_step: float = 1e-6,
    scale: ArrayLike | None = None,
    max_halvings: int = 10,
    abs_tol: float = 0.0,
    levels: int = 3,
    complex_step: float = 1e-20,
    equilibrium_tol: float = 1e-8,
    allow_non_equilibrium: bool = False,
    premature: bool = False,
) -> Linearization:
    """Linearize ``x' = f(x, u, t)``, ``y = h(x, u, t)`` about an operating point.

    The result is in deviation variables: ``dx = x - op.x``, ``du = u - op.u``,
    ``dy = y - h(op)``; ``A = df/dx``, ``B = df/du``, ``C = dh/dx``, ``D = dh/du``.

    Parameters
    ----------
    model : NonlinearModel
        The model (a compiled scene's ``Model`` is one).
    op : OperatingPoint, optional
        The point; default ``model.x0`` (when the model has one) with zero inputs at t = 0.
    method : {"auto", "perturbation", "central", "complex-step", "autodiff", "kane"}
        ``"auto"`` is ``"autodiff"`` for CasADi models, else ``"perturbation"``.

        - ``"perturbation"``: classic three-point quadratic fit with step halving
          (shared/reference/linear-analysis-discos.md section 1); per-entry error estimate.
        - ``"central"``: central differences with Richardson extrapolation over ``levels``.
        - ``"complex-step"``: for numpy models that propagate complex numbers; exact to
          round-off.
        - ``"autodiff"``: exact Jacobians of the CasADi graph (error estimate zero); a graph
          with ``fabs``, ``fmax``, ``sign``, ``if_else``... is also probed by real one-sided
          differences.
        - ``"kane"``: Kane's direct linearization of a compiled scene (linearized partial
          velocities, Banerjee 2016, section 1.4): exact like ``autodiff``, and also the
          second-order form ``second_order`` with its stiffness and damping split by origin.
    digits : float
        Significant digits [-] two successive estimates must share (``perturbation``), or the
        accuracy an entry must reach to count as converged (``central``).
    rel_step : float, optional
        Initial step [-] relative to ``max(|z_j|, scale_j)``: default 0.01 (the classic 1 %)
        for ``perturbation`` and 1e-3 for ``central``.
    zero_step : float
        Step for a variable whose value and scale are zero, and the smallest initial step of any
        variable, in that variable's units.
    scale : array_like, optional
        Characteristic magnitude of each state then each input (``n_states + n_inputs``), in
        their units; steps are relative to ``max(|value|, scale)``. Also scales the residual.
    max_halvings : int
        Cap on step halvings per variable (``perturbation``).
    abs_tol : float
        Absolute agreement floor per entry (``perturbation``), in the entry's units.
    levels : int
        Step levels of the Richardson table (``central``), at least 2.
    complex_step : float
        Relative imaginary step [-] (``complex-step``).
    equilibrium_tol : float
        Largest scaled residual (see :func:`scaled_residual`) accepted as an equilibrium [1/s].
    allow_non_equilibrium : bool
        Linearize about a non-equilibrium point too; ``residual`` is then the affine term.
    premature : bool
        ``"kane"`` only: take the partial velocities from the linearized velocities (premature
        linearization, Banerjee 2016, Eqs. 1.66-1.67), which loses the motion-induced
        stiffness unless the scene has the ``geometric_stiffness`` effect; for showing the
        error, not for use.

    Returns
    -------
    Linearization

    Raises
    ------
    NotAnEquilibriumError
        When the scaled residual exceeds ``equilibrium_tol`` and ``allow_non_equilibrium`` is
        false; the message gives the residual and the worst state.
    MethodUnavailableError
        ``"autodiff"`` on a numpy model, ``"complex-step"`` on a model that does not propagate
        complex numbers or on a CasADi model.
    ModelError, ShapeError
        For a wrong-shaped operating point, or a model that fails or returns non-finite values
        (the message names the entry and the perturbed variable).

    Warns
    -----
    AccuracyWarning
        When the model has a kink at the point (its one-sided slopes disagree: the entry holds
        their mean, its error estimate half their difference) or a jump (infinite error
        estimate), when ``"complex-step"`` or ``"autodiff"`` disagree with real one-sided
        differences, or when an entry misses ``digits``; the message names the entries.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import NonlinearModel, OperatingPoint
    >>> pend = NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
    ...                       states=["theta", "omega"], inputs=["torque"])
    >>> lin = linearize(pend, OperatingPoint([0.0, 0.0], [0.0]), method="perturbation")
    >>> round(float(lin.sys.A[1, 0]), 6)
    -9.81
    """
    start = time.perf_counter()
    if not isinstance(model, NonlinearModel):
        raise ModelError(f"model must be a NonlinearModel (or a compiled scene's Model), got {type(model).__name__}")
    op = _default_op(model, op)
    x, u, p = model.check_point(op.x, op.u)
    n, m, q = model.n_states, model.n_inputs, model.n_outputs
    scale_ = np.zeros(n + m) if scale is None else real_vector(scale, "scale", n + m)
    if np.any(scale_ < 0):
        raise ModelError("scale: characteristic magnitudes must be non-negative")
    if method == "auto":
        method = "autodiff" if model.is_casadi else "perturbation"
    if method not in METHODS:
        raise ModelError(f"method: unknown method {method!r}; choose one of {', '.join(METHODS)} or 'auto'")
    _check_settings(digits=digits, zero_step=zero_step, max_halvings=max_halvings, levels=levels,
                    rel_step=rel_step, complex_step=complex_step, equilibrium_tol=equilibrium_tol)

    if premature and method != "kane":
        raise ModelError(f"premature=True applies to method 'kane' only, not to {method!r}")
    setup_seconds = 0.0
    second_order = stiffness = damping = None
    if method == "kane":
        direct = direct_linearization(model, x, u, p, op.t, premature=premature)
        f0, y0, setup_seconds = direct.f0, direct.y0, direct.setup_seconds
        model.check_values(f0, y0)
        J = np.block([[direct.A, direct.B], [direct.C, direct.D]])
        err = np.zeros_like(J)
        converged = np.ones(J.shape, dtype=bool)
        evaluations = 1
        settings = {"premature": premature}
        second_order, stiffness, damping = direct.second_order, direct.stiffness, direct.damping
    elif method == "autodiff":
        f0, y0, result, setup_seconds = autodiff_linearization(model, x, u, p, op.t, scale=scale_,
                                                               zero_step=zero_step)
        J, err, converged, evaluations = result.J, result.error, result.converged, result.evaluations
        settings: dict = {}
    else:
        if method == "complex-step" and model.is_casadi:
            raise MethodUnavailableError(
                "method 'complex-step' needs numpy callables that accept complex input; this is a "
                "CasADi model: use 'autodiff' (exact) or 'perturbation'/'central'"
            )
        g = model_function(model, p, op.t)
        z0 = np.concatenate([x, u])
        g0 = g(z0)
        f0, y0 = g0[:n], g0[n:]
        model.check_values(f0, y0)
        if method == "perturbation":
            settings = dict(digits=digits, rel_step=0.01 if rel_step is None else rel_step, zero_step=zero_step,
                            max_halvings=max_halvings, abs_tol=abs_tol)
            result = perturbation_jacobian(g, z0, g0, scale=scale_, **settings)
        elif method == "central":
            settings = dict(digits=digits, rel_step=1e-3 if rel_step is None else rel_step, zero_step=zero_step,
                            levels=levels)
            result = central_jacobian(g, z0, g0, scale=scale_, **settings)
        else:
            settings = dict(step=complex_step)
            result = complex_step_jacobian(g, z0, step=complex_step, g0=g0, scale=scale_, zero_step=zero_step)
        J, err, converged, evaluations = result.J, result.error, result.converged, result.evaluations

    residual_scaled = scaled_residual(f0, x, scale_[:n] if scale is not None else None)
    is_equilibrium = bool(np.all(residual_scaled <= equilibrium_tol))
    if not is_equilibrium and not allow_non_equilibrium:
        worst = int(np.argmax(residual_scaled))
        raise NotAnEquilibriumError(
            f"the operating point is not an equilibrium: d({model.states[worst]})/dt = {f0[worst]:.6g} "
            f"(scaled residual {residual_scaled[worst]:.3g} > equilibrium_tol {equilibrium_tol:.3g}; "
            f"{int(np.sum(residual_scaled > equilibrium_tol))} of {n} states drift). Trim with "
            "find_operating_point, or pass allow_non_equilibrium=True to keep the affine term.",
            residual=np.array(f0),
        )

    sys = LinearSystem(J[:n, :n], J[:n, n:], J[n:, :n], J[n:, n:],
                       states=model.states, inputs=model.inputs, outputs=model.outputs)
    settings.update(equilibrium_tol=equilibrium_tol, allow_non_equilibrium=allow_non_equilibrium)
    return Linearization(
        sys=sys,
        op=OperatingPoint(x, u, op.t),
        residual=frozen_array(f0),
        y_op=frozen_array(y0),
        is_equilibrium=is_equilibrium,
        error_estimate=JacobianBlocks.split(err, n, q, m),
        converged=JacobianBlocks.split(converged, n, q, m),
        evaluations=int(evaluations),
        seconds=time.perf_counter() - start,
        setup_seconds=setup_seconds,
        method=method,
        settings=MappingProxyType(settings),
        second_order=second_order,
        stiffness=stiffness,
        damping=damping,
    )


def _default_op(model: NonlinearModel, op: OperatingPoint | None) -> OperatingPoint:
    if op is None:
        x0 = getattr(model, "x0", None)
        if x0 is None:
            raise ModelError("op: this model has no default initial state x0; pass an OperatingPoint")
        return OperatingPoint(x0, np.zeros(model.n_inputs), 0.0)
    if not isinstance(op, OperatingPoint):
        raise ModelError(f"op must be an OperatingPoint, got {type(op).__name__}")
    return op


def _check_settings(**settings) -> None:
    positive = ("digits", "zero_step", "complex_step", "equilibrium_tol")
    for name in positive:
        value = settings[name]
        if not np.isfinite(value) or value <= 0:
            raise ModelError(f"{name} must be a positive number, got {value!r}")
    if settings["rel_step"] is not None and not (0 < settings["rel_step"] < 1):
        raise ModelError(f"rel_step must lie in (0, 1), got {settings['rel_step']!r}")
    if int(settings["max_halvings"]) != settings["max_halvings"] or settings["max_halvings"] < 1:
        raise ModelError(f"max_halvings must be a positive integer, got {settings['max_halvings']!r}")
    if int(settings["levels"]) != settings["levels"] or settings["levels"] < 2:
        raise ModelError(f"levels must be an integer of at least 2, got {settings['levels']!r}")


