"""``linearize``: one entry point over the registered linearization methods, with the equilibrium contract."""

from __future__ import annotations

import dataclasses
import time
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from linflex import (
    LinearSystem,
    ModelError,
    NonlinearModel,
    NotAnEquilibriumError,
    OperatingPoint,
    ShapeError,
)
from linflex.system import check_positive, frozen_array, real_vector

from ._methods import METHODS, describe_methods
from ._result import JacobianBlocks, Linearization, LinearizationProblem

__all__ = ["METHODS", "linearize", "scaled_residual"]

# A method name: "auto" or a key of METHODS.
Method = str


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
        Typical magnitude of each state (state units); entries beyond the ``n`` states (the
        inputs' of :func:`linearize`'s ``scale``) are ignored.

    Returns
    -------
    ndarray, shape (n,)
        The scaled residual [1/s].

    Raises
    ------
    ShapeError
        When ``residual`` and ``x`` are not vectors of one length, or ``scale`` is shorter.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex.linearize import scaled_residual
    >>> scaled_residual(np.array([1e-3, 2.0]), np.array([0.0, 100.0])).tolist()
    [0.001, 0.02]
    """
    residual, x = np.asarray(residual, dtype=float), np.asarray(x, dtype=float)
    if residual.shape != x.shape or x.ndim != 1:
        raise ShapeError(f"residual has shape {residual.shape} and x {x.shape}; they must be vectors of one length")
    floor = np.maximum(1.0, np.abs(x))
    if scale is not None:
        scale = np.asarray(scale, dtype=float)
        if scale.ndim != 1 or scale.size < x.size:
            raise ShapeError(f"scale has shape {scale.shape}; it needs at least the {x.size} entries of x")
        floor = np.maximum(floor, scale[: x.size])
    return np.abs(residual) / floor


def linearize(
    model: NonlinearModel,
    op: OperatingPoint | None = None,
    *,
    method: Method = "auto",
    scale: ArrayLike | None = None,
    equilibrium_tol: float = 1e-8,
    allow_non_equilibrium: bool = False,
    **options,
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
    method : str
        ``"auto"`` (``"autodiff"`` for CasADi models, else ``"perturbation"``) or a registered
        method, a key of :data:`METHODS` (below: each with the models it applies to and its
        options).
    scale : array_like, optional
        Characteristic magnitude of each state then each input (``n_states + n_inputs``), in
        their units: it scales the residual, and the steps of ``perturbation`` and ``central``
        are relative to ``max(|value|, scale)``.
    equilibrium_tol : float
        Largest scaled residual (see :func:`scaled_residual`) accepted as an equilibrium [1/s].
    allow_non_equilibrium : bool
        Linearize about a non-equilibrium point too; ``residual`` is then the affine term.
    **options
        The chosen method's options, by name (None takes the default); an option the method
        does not take raises ``ModelError``. The registered methods, what they apply to, and
        their options with defaults and units:

{methods}

    Returns
    -------
    Linearization
        With ``second_order``, ``stiffness`` and ``damping`` when the method provides them
        (``"kane"``).

    Raises
    ------
    NotAnEquilibriumError
        When the scaled residual exceeds ``equilibrium_tol`` and ``allow_non_equilibrium`` is
        false; the message gives the residual and the worst state.
    MethodUnavailableError
        For a method that does not apply to the model (``"autodiff"`` on a numpy model,
        ``"complex-step"`` on a CasADi model or on one that does not propagate complex
        numbers, ``"kane"`` on anything but a compiled scene); the message names the methods
        that do.
    ModelError, ShapeError
        For an unknown method or option, an invalid option value, a wrong-shaped operating
        point, or a model that fails or returns non-finite values (the message names the
        entry and the perturbed variable).

    Warns
    -----
    AccuracyWarning
        When the model has a kink at the point (its one-sided slopes disagree: the entry holds
        their mean, its error estimate half their difference) or a jump (infinite error
        estimate), when ``"complex-step"`` or ``"autodiff"`` disagree with real one-sided
        differences (``"autodiff"`` probes graphs with ``fabs``, ``fmax``, ``sign``,
        ``if_else``, ...), or when an entry misses ``digits``; the message names the entries.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import NonlinearModel, OperatingPoint
    >>> pend = NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
    ...                       states=["theta", "omega"], inputs=["torque"])
    >>> lin = linearize(pend, OperatingPoint([0.0, 0.0], [0.0]), method="perturbation")
    >>> round(float(lin.sys.A[1, 0]), 6)
    -9.81
    >>> lin = linearize(pend, OperatingPoint([0.0, 0.0], [0.0]), method="central", levels=4)
    >>> lin.settings["levels"], round(float(lin.sys.A[1, 0]), 6)
    (4, -9.81)
    """
    start = time.perf_counter()
    if not isinstance(model, NonlinearModel):
        hint = ": compile it first, linearize(compile_model(scene))" if type(model).__name__ == "Scene" else ""
        raise ModelError(f"model must be a NonlinearModel (or a compiled scene's Model), got {type(model).__name__}{hint}")
    op = _default_op(model, op)
    x, u, p = model.check_point(op.x, op.u)
    n, m, q = model.n_states, model.n_inputs, model.n_outputs
    scale_ = np.zeros(n + m) if scale is None else real_vector(scale, "scale", n + m)
    if np.any(scale_ < 0):
        raise ModelError("scale: characteristic magnitudes must be non-negative")
    check_positive(equilibrium_tol, "equilibrium_tol")
    auto = method == "auto"
    if auto:
        method = "autodiff" if model.is_casadi else "perturbation"
    entry = METHODS.get(method) if isinstance(method, str) else None
    if entry is None:
        raise ModelError(f"method: unknown method {method!r}; choose one of {', '.join(METHODS)} or 'auto'")
    try:
        settings = entry.make_options(options)
    except ModelError as err:
        if not auto:
            raise
        kind = "CasADi" if model.is_casadi else "numpy"
        raise ModelError(f"{err} (method 'auto' is {entry.name!r} for this {kind} model; name the method)") from err
    entry.check_model(model)

    result = entry.function(LinearizationProblem(model, x, u, p, float(op.t), scale_), settings)
    f0, y0 = result.f0, result.y0
    model.check_values(f0, y0)
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

    J = result.J
    sys = LinearSystem(J[:n, :n], J[:n, n:], J[n:, :n], J[n:, n:],
                       states=model.states, inputs=model.inputs, outputs=model.outputs)
    ran_with = dataclasses.asdict(settings)
    ran_with.update(equilibrium_tol=equilibrium_tol, allow_non_equilibrium=allow_non_equilibrium)
    return Linearization(
        sys=sys,
        op=OperatingPoint(x, u, op.t),
        residual=frozen_array(f0),
        y_op=frozen_array(y0),
        is_equilibrium=is_equilibrium,
        error_estimate=JacobianBlocks.split(result.error, n, q, m),
        converged=JacobianBlocks.split(result.converged, n, q, m),
        n_evaluations=int(result.n_evaluations),
        seconds=time.perf_counter() - start,
        setup_seconds=result.setup_seconds,
        method=entry.name,
        settings=MappingProxyType(ran_with),
        second_order=result.second_order,
        stiffness=result.stiffness,
        damping=result.damping,
    )


# The registered methods' listing, generated from the registry so that it cannot drift.
if linearize.__doc__:  # None under python -OO
    linearize.__doc__ = linearize.__doc__.replace("{methods}", describe_methods(" " * 8))


def _default_op(model: NonlinearModel, op: OperatingPoint | None) -> OperatingPoint:
    if op is None:
        x0 = getattr(model, "x0", None)
        if x0 is None:
            raise ModelError("op: this model has no default initial state x0; pass an OperatingPoint")
        return OperatingPoint(x0, np.zeros(model.n_inputs), 0.0)
    if not isinstance(op, OperatingPoint):
        hint = f" (its point is {type(op).__name__}.op)" if isinstance(getattr(op, "op", None), OperatingPoint) else ""
        raise ModelError(f"op must be an OperatingPoint, got {type(op).__name__}{hint}")
    return op
