"""Nonlinear models ``x' = f(x, u, [p,] t)``, ``y = h(x, u, [p,] t)`` and operating points.

A :class:`NonlinearModel` wraps either plain numpy callables or CasADi functions/expressions
behind one evaluation interface. Everything downstream (linearization, simulation, trim)
talks to :meth:`NonlinearModel.evaluate`; methods that need the graph (automatic
differentiation) ask for :meth:`NonlinearModel.casadi_functions`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import MethodUnavailableError, ModelError, ShapeError
from ._signals import real_vector, signal_index, signal_names

__all__ = ["NonlinearModel", "OperatingPoint"]


@dataclass(frozen=True, init=False)
class OperatingPoint:
    """A point ``(x, u, t)`` to linearize about or to start from.

    Parameters
    ----------
    x : array_like
        State vector [state units] (those of the model's states: [m], [rad], [m/s], [rad/s],
        quaternion components [-], ...).
    u : array_like, optional
        Input vector [input units] ([N], [N m], ...); empty when omitted.
    t : float, optional
        Time [s]; default 0.

    Examples
    --------
    A pendulum hanging still under a zero torque:

    >>> from linflex import OperatingPoint
    >>> op = OperatingPoint([0.0, 0.0], [0.0])     # theta [rad], omega [rad/s]; torque [N m]
    >>> op.x.tolist(), op.u.tolist(), op.t
    ([0.0, 0.0], [0.0], 0.0)
    """

    x: NDArray[np.float64]
    u: NDArray[np.float64]
    t: float

    def __init__(self, x: ArrayLike, u: ArrayLike | None = None, t: float = 0.0) -> None:
        x_ = np.atleast_1d(np.asarray(x, dtype=float))
        u_ = np.zeros(0) if u is None else np.atleast_1d(np.asarray(u, dtype=float))
        if x_.ndim != 1:
            raise ShapeError(f"x must be a vector, got shape {x_.shape}")
        if u_.ndim != 1:
            raise ShapeError(f"u must be a vector, got shape {u_.shape}")
        object.__setattr__(self, "x", real_vector(x_, "x", x_.size))
        object.__setattr__(self, "u", real_vector(u_, "u", u_.size))
        if not np.isfinite(t):
            raise ShapeError(f"t must be finite, got {t}")
        object.__setattr__(self, "t", float(t))

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, OperatingPoint)
            and np.array_equal(self.x, other.x)
            and np.array_equal(self.u, other.u)
            and self.t == other.t
        )

    __hash__ = None  # type: ignore[assignment]


def _is_casadi(obj: Any) -> bool:
    return type(obj).__module__.startswith("casadi")


@dataclass(frozen=True, init=False, eq=False)
class NonlinearModel:
    """A nonlinear state-space model with named states, inputs, outputs and parameters.

    Parameters
    ----------
    f : callable or casadi.Function
        State derivative. Called as ``f(x, u, t)``, or ``f(x, u, p, t)`` when the model has
        parameters, with ``x`` of shape ``(n,)``, ``u`` of shape ``(m,)``, ``p`` of shape
        ``(n_p,)`` and ``t`` in seconds; returns ``(n,)``. A ``casadi.Function`` must take the
        same arguments (3 or 4 inputs) and return one ``(n, 1)`` output.
    h : callable or casadi.Function, optional
        Outputs, with the same arguments as ``f``; omitted means no outputs.
    states : int or sequence of str
        The number of states or their names.
    inputs : int or sequence of str, optional
        The number of inputs or their names; default none.
    outputs : int or sequence of str, optional
        Output names (their number is found by evaluating ``h`` when omitted).
    params : mapping of str to float, optional
        Parameter names and nominal values [parameter units], in order.

    Notes
    -----
    For models built from CasADi expressions use :meth:`from_casadi`. Automatic
    differentiation needs a CasADi model; numerical methods work with both kinds.

    Examples
    --------
    >>> import numpy as np
    >>> pend = NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
    ...                       states=["theta", "omega"], inputs=["torque"])
    >>> pend.evaluate([0.0, 0.0], [1.0])[0]
    array([0., 1.])
    """

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    params: tuple[str, ...]
    param_values: NDArray[np.float64]
    f: Any
    h: Any

    def __init__(
        self,
        f: Callable | Any,
        h: Callable | Any | None = None,
        *,
        states: int | list[str] | tuple[str, ...],
        inputs: int | list[str] | tuple[str, ...] = 0,
        outputs: int | list[str] | tuple[str, ...] | None = None,
        params: Mapping[str, float] | None = None,
    ) -> None:
        if not callable(f) and not _is_casadi(f):
            raise ModelError(f"f must be callable or a casadi.Function, got {type(f).__name__}")
        if h is not None and not callable(h) and not _is_casadi(h):
            raise ModelError(f"h must be callable or a casadi.Function, got {type(h).__name__}")
        n = states if isinstance(states, int) else len(tuple(states))
        m = inputs if isinstance(inputs, int) else len(tuple(inputs))
        object.__setattr__(self, "states", signal_names(None if isinstance(states, int) else states, n, "x", "states"))
        object.__setattr__(self, "inputs", signal_names(None if isinstance(inputs, int) else inputs, m, "u", "inputs"))
        params = dict(params or {})
        object.__setattr__(self, "params", signal_names(list(params), len(params), "p", "params"))
        object.__setattr__(self, "param_values", real_vector(list(params.values()), "params", len(params)))
        object.__setattr__(self, "f", f)
        object.__setattr__(self, "h", h)
        if n == 0:
            raise ModelError("states: a model needs at least one state")
        for name, fun in (("f", f), ("h", h)):
            if fun is not None and _is_casadi(fun):
                expected = 4 if self.params else 3
                if fun.n_in() != expected:
                    raise ModelError(
                        f"{name}: a casadi.Function with {fun.n_in()} inputs; expected {expected} "
                        f"({'x, u, p, t' if self.params else 'x, u, t'})"
                    )
        if _is_casadi(f) and f.numel_out(0) != n:
            raise ModelError(self._size_message("f", f.numel_out(0)))
        if outputs is None or isinstance(outputs, int):
            if h is None:
                p = 0
            elif isinstance(outputs, int):
                p = outputs
            elif _is_casadi(h):
                p = h.size1_out(0)
            else:
                p = self._call(h, "h", np.zeros(n), np.zeros(m), self.param_values, 0.0).size
            object.__setattr__(self, "outputs", signal_names(None, p, "y", "outputs"))
        else:
            if h is None and len(tuple(outputs)) > 0:
                raise ModelError("outputs: names given but no output function h")
            object.__setattr__(self, "outputs", signal_names(outputs, len(tuple(outputs)), "y", "outputs"))
        if h is not None and _is_casadi(h) and h.numel_out(0) != self.n_outputs:
            raise ModelError(self._size_message("h", h.numel_out(0)))

    # -- construction from CasADi expressions -------------------------------------------------

    @classmethod
    def from_casadi(
        cls,
        xdot: Any,
        x: Any,
        u: Any | None = None,
        y: Any | None = None,
        *,
        t: Any | None = None,
        p: Any | None = None,
        states=None,
        inputs=None,
        outputs=None,
        params: Mapping[str, float] | None = None,
    ) -> NonlinearModel:
        """Build a model from CasADi symbols ``x, u, t, p`` and expressions ``xdot, y``.

        Parameters
        ----------
        xdot, y : casadi.SX or casadi.MX
            Expressions for the state derivative [state units/s] and the outputs [output units].
        x, u, p : casadi.SX or casadi.MX
            Pure symbols (column vectors) of the states [state units], inputs [input units] and
            parameters the expressions depend on; ``u`` and ``p`` optional.
        t : casadi.SX or casadi.MX, optional
            Scalar symbol of the time [s], when the expressions depend on it.
        states, inputs, outputs : sequence of str, optional
            Signal names; default ``x0..``, ``u0..``, ``y0..`` with the sizes of the symbols.
        params : mapping of str to float, optional
            Nominal values of ``p`` [parameter units], in order (required when ``p`` is given).

        Returns
        -------
        NonlinearModel
            A CasADi model (``is_casadi``), differentiable by ``method="autodiff"``.

        Raises
        ------
        ModelError
            When ``params`` and ``p`` do not match.
        """
        import casadi as ca

        sym = ca.MX if isinstance(x, ca.MX) else ca.SX
        u = sym(0, 1) if u is None else u
        t = sym.sym("t") if t is None else t
        if p is not None:
            if params is None or len(params) != p.numel():
                raise ModelError(f"params: {p.numel()} nominal values are needed for p")
            args, names = [x, u, p, t], ["x", "u", "p", "t"]
        else:
            if params:
                raise ModelError("params given without the symbol p")
            args, names = [x, u, t], ["x", "u", "t"]
        f_fun = ca.Function("f", args, [xdot], names, ["xdot"])
        h_fun = None if y is None else ca.Function("h", args, [y], names, ["y"])
        return cls(
            f_fun, h_fun,
            states=x.numel() if states is None else states,
            inputs=u.numel() if inputs is None else inputs,
            outputs=outputs if outputs is not None else (None if y is None else y.numel()),
            params=params,
        )

    # -- properties ------------------------------------------------------------------------------

    @property
    def n_states(self) -> int:
        """Number of states."""
        return len(self.states)

    @property
    def n_inputs(self) -> int:
        """Number of inputs."""
        return len(self.inputs)

    @property
    def n_outputs(self) -> int:
        """Number of outputs."""
        return len(self.outputs)

    @property
    def is_casadi(self) -> bool:
        """True when ``f`` (and ``h``) are CasADi functions, so the graph can be differentiated."""
        return _is_casadi(self.f) and (self.h is None or _is_casadi(self.h))

    def with_params(self, **values: float) -> NonlinearModel:
        """A copy with some parameter values replaced (by name).

        Parameters
        ----------
        **values : float
            New nominal values [parameter units] by parameter name.

        Returns
        -------
        NonlinearModel
            The same functions with the new ``param_values``.

        Raises
        ------
        ModelError
            For a name that is not a parameter.
        """
        new = dict(zip(self.params, self.param_values))
        for key, value in values.items():
            signal_index(self.params, key, "params")
            new[key] = float(value)
        return type(self)(self.f, self.h, states=self.states, inputs=self.inputs,
                          outputs=self.outputs if self.h is not None else None, params=new)

    def state_index(self, name: str | int) -> int:
        """Index of a state given by name (or checked index).

        Parameters
        ----------
        name : str or int
            The state's name, or its index.

        Returns
        -------
        int
            Position in ``states``.

        Raises
        ------
        ModelError
            For an unknown name or an index out of range.
        """
        return signal_index(self.states, name, "states")

    def input_index(self, name: str | int) -> int:
        """Index of an input given by name (or checked index).

        Parameters
        ----------
        name : str or int
            The input's name, or its index.

        Returns
        -------
        int
            Position in ``inputs``.

        Raises
        ------
        ModelError
            For an unknown name or an index out of range.
        """
        return signal_index(self.inputs, name, "inputs")

    def output_index(self, name: str | int) -> int:
        """Index of an output given by name (or checked index).

        Parameters
        ----------
        name : str or int
            The output's name, or its index.

        Returns
        -------
        int
            Position in ``outputs``.

        Raises
        ------
        ModelError
            For an unknown name or an index out of range.
        """
        return signal_index(self.outputs, name, "outputs")

    # -- evaluation ------------------------------------------------------------------------------

    def _size_message(self, name: str, size: int) -> str:
        """``"f returned 3 values for 2 states (theta, omega)"``: which function, how many, for what."""
        names = self.states if name == "f" else self.outputs
        what = "states" if name == "f" else "outputs"
        shown = ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
        return f"{name} returned {size} values for {len(names)} {what} ({shown})"

    def _call(self, fun, name: str, x, u, p, t, size: int | None = None):
        try:
            if _is_casadi(fun):
                args = (x, u, p, t) if self.params else (x, u, t)
                out = np.asarray(fun(*args), dtype=float).reshape(-1)
            else:
                out = fun(x, u, p, t) if self.params else fun(x, u, t)
                out = np.asarray(out)
                if out.ndim > 1 and 1 in out.shape:
                    out = out.reshape(-1)
        except Exception as err:
            raise ModelError(f"the model's {name}(x, u, t) raised {type(err).__name__}: {err}") from err
        if out.ndim != 1:
            raise ModelError(f"{name} returned shape {out.shape}; a vector was expected")
        if size is not None and out.size != size:
            raise ModelError(self._size_message(name, out.size))
        return out

    def evaluate_raw(self, x: NDArray, u: NDArray, t: float, p: NDArray | None = None, *, outputs: bool = True):
        """``(f, h)`` at one point without validation or dtype cast (complex input allowed).

        This is the hot path for numerical linearization; use :meth:`evaluate` from user code.

        Parameters
        ----------
        x : ndarray, shape (n_states,)
            State [state units], real or complex.
        u : ndarray, shape (n_inputs,)
            Input [input units].
        t : float
            Time [s].
        p : ndarray, shape (n_params,), optional
            Parameter values [parameter units]; default ``param_values``.
        outputs : bool, optional
            Whether to evaluate ``h`` too (else ``y`` is empty).

        Returns
        -------
        xdot : ndarray, shape (n_states,)
            State derivative [state units/s], of the dtype of the computation.
        y : ndarray, shape (n_outputs,) or (0,)
            Outputs [output units].

        Raises
        ------
        ModelError
            When ``f`` or ``h`` raises (chained), or returns another number of values than the
            model has states or outputs (the message names the function and the signals).
        """
        p = self.param_values if p is None else p
        # f and h each get their own copies: a model that writes into its arguments (x[0] =
        # wrap(x[0])) must move neither the caller's point (a differencing's base point) nor h's
        xdot = self._call(self.f, "f", x.copy(), u.copy(), p, t, self.n_states)
        y = (self._call(self.h, "h", x.copy(), u.copy(), p, t, self.n_outputs) if (outputs and self.h is not None)
             else np.zeros(0, xdot.dtype))
        return xdot, y

    def evaluate(self, x: ArrayLike, u: ArrayLike | None = None, t: float = 0.0, params: ArrayLike | None = None):
        """State derivative and outputs at ``(x, u, t)``, checked.

        Parameters
        ----------
        x : array_like, shape (n_states,)
            State [state units].
        u : array_like, shape (n_inputs,), optional
            Input [input units]; default zeros.
        t : float, optional
            Time [s]; default 0.
        params : array_like, shape (n_params,), optional
            Parameter values [parameter units]; default ``param_values``.

        Returns
        -------
        xdot : ndarray, shape (n_states,)
            State derivative [state units/s].
        y : ndarray, shape (n_outputs,)
            Outputs [output units].

        Raises
        ------
        ShapeError
            For wrong shapes of ``x``, ``u`` or ``params``.
        ModelError
            When ``f`` or ``h`` raises (chained), returns the wrong size, or a non-finite value.
        """
        x_, u_, p_ = self.check_point(x, u, params)
        xdot, y = self.evaluate_raw(x_, u_, float(t), p_)
        self.check_values(xdot, y, x_, u_)
        return np.asarray(xdot, dtype=float), np.asarray(y, dtype=float)

    def check_point(self, x, u=None, params=None):
        """Validated float vectors ``(x, u, p)`` for this model (names in messages).

        Parameters
        ----------
        x : array_like, shape (n_states,)
            State [state units].
        u : array_like, shape (n_inputs,), optional
            Input [input units]; default zeros.
        params : array_like, shape (n_params,), optional
            Parameter values [parameter units]; default ``param_values``.

        Returns
        -------
        x, u, p : ndarray
            Float vectors of the model's sizes, in the units given.

        Raises
        ------
        ShapeError
            For a wrong size or a non-finite entry.
        """
        x_ = real_vector(x, "x", self.n_states)
        u_ = real_vector(np.zeros(self.n_inputs) if u is None else u, "u", self.n_inputs)
        p_ = self.param_values if params is None else real_vector(params, "params", len(self.params))
        return x_, u_, p_

    def check_values(self, xdot, y, x=None, u=None) -> None:
        """Raise a precise :class:`ModelError` for wrong sizes or non-finite values.

        Parameters
        ----------
        xdot : ndarray
            State derivative [state units/s] returned by ``f``.
        y : ndarray
            Outputs [output units] returned by ``h``.
        x, u : ndarray, optional
            The point [state units], [input units] (unused in the checks; kept for callers).

        Raises
        ------
        ModelError
            Naming the first non-finite derivative or output, or the size mismatch.
        """
        if xdot.shape != (self.n_states,):
            raise ModelError(self._size_message("f", xdot.size))
        if y.shape != (self.n_outputs,):
            raise ModelError(self._size_message("h", y.size))
        for what, values, names in (("f", xdot, self.states), ("h", y, self.outputs)):
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                i = int(bad[0])
                label = f"d({names[i]})/dt" if what == "f" else names[i]
                raise ModelError(
                    f"{what} is not finite at this point: {label} = {values[i]} "
                    f"({bad.size} non-finite entries)"
                )

    def casadi_functions(self):
        """``(f, h)`` as ``casadi.Function``s of ``(x, u, p, t)`` (``h`` may have 0 outputs).

        Returns
        -------
        f, h : casadi.Function
            Of the states [state units], inputs [input units], parameters and time [s];
            ``f`` returns ``xdot`` [state units/s], ``h`` returns ``y`` [output units].

        Raises
        ------
        MethodUnavailableError
            For a model made of plain numpy callables.
        """
        import casadi as ca

        if not self.is_casadi:
            raise MethodUnavailableError(
                "this model is made of numpy callables, so it has no CasADi graph to differentiate; "
                "build it with NonlinearModel.from_casadi, or use a numerical method "
                "('perturbation', 'central' or 'complex-step')"
            )
        x = ca.MX.sym("x", self.n_states)
        u = ca.MX.sym("u", self.n_inputs)
        p = ca.MX.sym("p", len(self.params))
        t = ca.MX.sym("t")
        args = (x, u, p, t) if self.params else (x, u, t)
        xdot = self.f(*args)
        y = self.h(*args) if self.h is not None else ca.MX(0, 1)
        names = ["x", "u", "p", "t"]
        return (ca.Function("f", [x, u, p, t], [xdot], names, ["xdot"]),
                ca.Function("h", [x, u, p, t], [y], names, ["y"]))

    def __repr__(self) -> str:
        kind = "casadi" if self.is_casadi else "numpy"
        return (f"NonlinearModel({kind}, states={self.n_states}, inputs={list(self.inputs)!r}, "
                f"outputs={list(self.outputs)!r})")
