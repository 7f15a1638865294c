"""Time responses of continuous-time linear systems, exact for held inputs by matrix exponentials.

``forced_response``, ``step_response``, ``impulse_response`` and ``initial_response`` return the
same :class:`TimeResponse` as :func:`simulate`. Between two samples the input is held constant
(``hold="zoh"``) or interpolated linearly (``hold="foh"``); under that assumption the state at
the samples is the exact solution up to round-off, because every interval is advanced by the
exponential of an augmented matrix (Van Loan 1978, "Computing integrals involving the matrix
exponential", IEEE TAC 23(3); Franklin, Powell and Workman, "Digital Control of Dynamic
Systems", 3rd ed., 1998, sections 4.3.3 and 6.3.2), computed once per distinct step size.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..system._errors import ModelError, ShapeError
from ..system._linear import LinearSystem, as_linear_system
from ..system._signals import frozen_array, real_vector, signal_index
from ._simulate import TimeResponse, _input_samples

__all__ = ["forced_response", "impulse_response", "initial_response", "step_response"]

_HOLDS = ("zoh", "foh")


def forced_response(
    sys: Any,
    timepts: ArrayLike,
    inputs: Any = None,
    x0: ArrayLike | None = None,
    *,
    hold: str = "zoh",
) -> TimeResponse:
    """Response of ``x' = A x + B u``, ``y = C x + D u`` to sampled inputs, exact between samples.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A continuous-time linear system; states, inputs and outputs in their own units.
    timepts : array_like
        Strictly increasing sample times [s], at least two; the response starts at
        ``timepts[0]``. Steps need not be uniform.
    inputs : None, array_like, callable or mapping, optional
        Inputs [input units: N, N m, ...] as :func:`simulate` takes them: ``(n_time, n_inputs)``
        samples, a constant ``(n_inputs,)``, a function ``u(t)`` (sampled at ``timepts``) or a
        mapping from input names to scalars, callables or ``(n_time,)`` samples; zero when
        omitted.
    x0 : array_like, optional
        Initial state [state units] at ``timepts[0]``; zero when omitted.
    hold : {"zoh", "foh"}
        ``"zoh"`` holds each sample until the next one (the convention of :class:`TimeResponse`);
        ``"foh"`` interpolates linearly between samples (first-order hold).

    Returns
    -------
    TimeResponse
        ``x``, ``y``, ``u`` at ``timepts`` (``u`` the samples used), the system's names;
        ``method`` is ``"expm-zoh"`` or ``"expm-foh"``, ``rtol`` is the double-precision unit
        round-off [-] (the method has no truncation error) and ``atol`` is 0 [state units].

    Raises
    ------
    ShapeError
        For malformed ``timepts``, ``inputs`` or ``x0``.
    ModelError
        For an unknown ``hold`` or a system that is not a continuous-time linear system.

    Notes
    -----
    For a step ``h`` the zero-order hold uses ::

        expm(h [A  B]) = [Ad  Bd]        x[k+1] = Ad x[k] + Bd u[k]
               [0  0]    [0   I ]

    and the first-order hold, with ``v = (u[k+1] - u[k]) / h`` the constant input rate, ::

             [A  B  0]   [Ad  G1  G2]
        expm(h [0  0  I]) = [0   I   hI]   x[k+1] = Ad x[k] + G1 u[k] + G2 (u[k+1] - u[k]) / h
             [0  0  0]   [0   0   I ]

    Steps that differ by no more than the round-off of the sample times themselves
    (``8 eps max|t|``) share one exponential.

    Examples
    --------
    The first-order lag ``x' = -2 x + 2 u`` under a unit step is ``1 - exp(-2 t)``:

    >>> import numpy as np
    >>> from linflex import LinearSystem, forced_response
    >>> lag = LinearSystem([[-2.0]], [[2.0]], [[1.0]])
    >>> r = forced_response(lag, np.linspace(0.0, 1.0, 11), np.ones((11, 1)))
    >>> round(float(r.y[-1, 0]), 12), round(1.0 - float(np.exp(-2.0)), 12)
    (0.864664716763, 0.864664716763)
    """
    start = time.perf_counter()
    lin = as_linear_system(sys, "sys")
    t = _check_timepts(timepts)
    if hold not in _HOLDS:
        raise ModelError(f"hold must be one of {_HOLDS}, got {hold!r}")
    U, _ = _input_samples(_InputNames(lin), t, inputs)
    x_start = np.zeros(lin.n_states) if x0 is None else real_vector(x0, "x0", lin.n_states)
    X = _propagate(lin, t, U, x_start, hold)
    return _response(lin, t, X, U, hold, start)


def step_response(sys: Any, timepts: ArrayLike, *, input: str | int | None = None, hold: str = "zoh") -> TimeResponse:
    """Response to a unit step on one input, from rest at ``timepts[0]``.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A continuous-time linear system.
    timepts : array_like
        Strictly increasing sample times [s], at least two; the step occurs at ``timepts[0]``.
    input : str or int, optional
        The input that steps (name or index); required when the system has several.
    hold : {"zoh", "foh"}
        As in :func:`forced_response` (the results agree: the input is constant).

    Returns
    -------
    TimeResponse
        As :func:`forced_response`, with ``u`` equal to 1 [input unit] on the stepped input.

    Raises
    ------
    ModelError
        For a missing or unknown ``input``.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import LinearSystem, step_response
    >>> r = step_response(LinearSystem([[-2.0]], [[2.0]], [[1.0]]), [0.0, 0.5])
    >>> round(float(r.y[-1, 0]), 12), round(1.0 - float(np.exp(-1.0)), 12)
    (0.632120558829, 0.632120558829)
    """
    lin = as_linear_system(sys, "sys")
    t = _check_timepts(timepts)
    U = np.zeros((t.size, lin.n_inputs))
    U[:, _one_input(lin, input)] = 1.0
    return forced_response(lin, t, U, hold=hold)


def impulse_response(sys: Any, timepts: ArrayLike, *, input: str | int | None = None) -> TimeResponse:
    """Response to a unit impulse on one input at ``timepts[0]``, from rest.

    The impulse moves the state at once to ``x(t0+) = B e_i``; the response is then the free
    motion from that state. ``y`` is ``C x`` from ``t0+`` on: the impulse ``D e_i delta(t)``
    of a system with a direct feedthrough is not a sampled value and is left out.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A continuous-time linear system.
    timepts : array_like
        Strictly increasing sample times [s], at least two; the impulse acts at ``timepts[0]``.
    input : str or int, optional
        The input that receives the impulse (name or index); required when the system has
        several.

    Returns
    -------
    TimeResponse
        As :func:`forced_response`, with ``u`` zero (the impulse has no sampled value).

    Raises
    ------
    ModelError
        For a missing or unknown ``input``.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import LinearSystem, impulse_response
    >>> r = impulse_response(LinearSystem([[-2.0]], [[2.0]], [[1.0]]), [0.0, 0.5])
    >>> round(float(r.y[-1, 0]), 12), round(2.0 * float(np.exp(-1.0)), 12)
    (0.735758882343, 0.735758882343)
    """
    lin = as_linear_system(sys, "sys")
    k = _one_input(lin, input)
    return initial_response(lin, timepts, lin.B[:, k])


def initial_response(sys: Any, timepts: ArrayLike, x0: ArrayLike) -> TimeResponse:
    """Free response from the initial state ``x0`` at ``timepts[0]``, with zero inputs.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A continuous-time linear system.
    timepts : array_like
        Strictly increasing sample times [s], at least two.
    x0 : array_like
        Initial state [state units].

    Returns
    -------
    TimeResponse
        As :func:`forced_response`: ``x(t) = expm(A (t - t0)) x0``, exact up to round-off.

    Raises
    ------
    ShapeError
        For malformed ``timepts`` or ``x0``.

    Examples
    --------
    A double integrator moving at 1 m/s from the origin is at ``t`` [m] at time ``t`` [s]:

    >>> from linflex import LinearSystem, initial_response
    >>> r = initial_response(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]]), [0.0, 2.5], [0.0, 1.0])
    >>> r.x[-1].tolist()
    [2.5, 1.0]
    """
    return forced_response(sys, timepts, None, x0)


class _InputNames:
    """What :func:`_input_samples` needs of a model: the input count and name lookup."""

    def __init__(self, sys: LinearSystem) -> None:
        self.n_inputs = sys.n_inputs
        self._names = sys.inputs

    def input_index(self, key: str | int) -> int:
        return signal_index(self._names, key, "inputs")


def _check_timepts(timepts: ArrayLike) -> NDArray[np.float64]:
    try:
        t = np.asarray(timepts, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"timepts must be a vector of times: {err}") from err
    if t.ndim != 1 or t.size < 2:
        raise ShapeError(f"timepts must be a vector of at least 2 times, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ShapeError("timepts must be finite and strictly increasing")
    return t


def _one_input(sys: LinearSystem, input: str | int | None) -> int:
    if input is None:
        if sys.n_inputs != 1:
            raise ModelError(f"input: the system has {sys.n_inputs} inputs {list(sys.inputs)[:12]}; name one with input=")
        return 0
    return signal_index(sys.inputs, input, "input")


def _step_groups(steps: NDArray[np.float64], t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Distinct step sizes (within the round-off of the times) and each step's group."""
    tol = 8.0 * np.finfo(float).eps * float(np.max(np.abs(t)))
    order = np.argsort(steps)
    sorted_steps = steps[order]
    # Each group spans at most tol from its smallest step (anchored, so a slowly growing step
    # never chains into one group).
    labels_sorted = np.empty(steps.size, dtype=np.intp)
    first, group = 0, 0
    while first < steps.size:
        last = int(np.searchsorted(sorted_steps, sorted_steps[first] + tol, side="right"))
        labels_sorted[first:last] = group
        first, group = last, group + 1
    labels = np.empty_like(labels_sorted)
    labels[order] = labels_sorted
    # The correctly rounded mean (math.fsum) keeps a uniform grid's end time t0 + n h to a few
    # ulps; a plain sum of 2e4 steps is off by 1e-13 relative, a phase drift of 1e-9 over 1000
    # periods of an undamped mode.
    representatives = np.array([
        math.fsum(sorted_steps[labels_sorted == g]) / np.count_nonzero(labels_sorted == g)
        for g in range(labels_sorted[-1] + 1)
    ])
    return representatives, labels


def _propagate(sys: LinearSystem, t: NDArray[np.float64], U: NDArray[np.float64], x0: NDArray[np.float64],
               hold: str) -> NDArray[np.float64]:
    """States at ``t`` by one augmented matrix exponential per distinct step (see forced_response)."""
    n, m = sys.n_states, sys.n_inputs
    X = np.empty((t.size, n))
    X[0] = x0
    if n == 0:
        return X
    steps, labels = _step_groups(np.diff(t), t)
    size = n + m if hold == "zoh" else n + 2 * m
    maps = []
    for h in steps:
        M = np.zeros((size, size))
        M[:n, :n], M[:n, n:n + m] = sys.A, sys.B
        if hold == "foh":
            M[n:n + m, n + m:] = np.eye(m)
        E = scipy.linalg.expm(h * M)
        Ad, G1 = E[:n, :n], E[:n, n:n + m]
        G2 = E[:n, n + m:] / h if hold == "foh" else None
        maps.append((Ad, G1, G2))
    for k in range(t.size - 1):
        Ad, G1, G2 = maps[labels[k]]
        x = Ad @ X[k] + G1 @ U[k]
        if G2 is not None:
            x += G2 @ (U[k + 1] - U[k])
        X[k + 1] = x
    return X


def _response(sys: LinearSystem, t, X, U, hold: str, start: float) -> TimeResponse:
    Y = X @ sys.C.T + U @ sys.D.T
    return TimeResponse(
        time=frozen_array(t), x=frozen_array(X), y=frozen_array(Y), u=frozen_array(U),
        states=sys.states, outputs=sys.outputs, inputs=sys.inputs, quaternion_drift=0.0,
        method=f"expm-{hold}", rtol=float(np.finfo(float).eps), atol=0.0,
        seconds=time.perf_counter() - start,
    )
