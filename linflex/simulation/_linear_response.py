"""Time responses of linear systems, exact for held inputs: continuous by matrix exponentials, discrete by recursion.

``forced_response``, ``step_response``, ``impulse_response`` and ``initial_response`` return the
same :class:`TimeResponse` as :func:`simulate`. Between two samples the input is held constant
(``hold="zoh"``) or interpolated linearly (``hold="foh"``); under that assumption the state at
the samples is the exact solution up to round-off, because every interval is advanced by the
exponential of an augmented matrix (Van Loan 1978, "Computing integrals involving the matrix
exponential", IEEE TAC 23(3); Franklin, Powell and Workman, "Digital Control of Dynamic
Systems", 3rd ed., 1998, sections 4.3.3 and 6.3.2), computed once per distinct step size.

A discrete-time system is advanced by its own recursion ``x[k+1] = A x[k] + B u[k]`` at its
sample instants. Input and output delays are exact: a delayed input is the held input shifted
in time (the propagation grid holds every shifted switching instant, so the exponentials stay
exact), a delayed output the output shifted in time; before ``timepts[0]`` the system is at rest
with zero inputs, so a delayed channel is zero until its delay has passed.
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
from ._simulate import TimeResponse, _checked_timepts, _input_samples

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
    """Response of ``x' = A x + B u`` (or ``x[k+1] = A x[k] + B u[k]``), ``y = C x + D u`` to sampled inputs, exact.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A linear system, continuous or discrete, with or without input and output delays [s];
        states, inputs and outputs in their own units.
    timepts : array_like
        Strictly increasing sample times [s], at least two; the response starts at
        ``timepts[0]``. Steps need not be uniform for a continuous system; for a discrete one
        they must be its sampling period ``dt``.
    inputs : None, array_like, callable or mapping, optional
        Inputs [input units: N, N m, ...] as :func:`simulate` takes them: ``(n_time, n_inputs)``
        samples, a constant ``(n_inputs,)``, a function ``u(t)`` (sampled at ``timepts``) or a
        mapping from input names to scalars, callables or ``(n_time,)`` samples; zero when
        omitted.
    x0 : array_like, optional
        Initial state [state units] at ``timepts[0]``; zero when omitted.
    hold : {"zoh", "foh"}
        ``"zoh"`` holds each sample until the next one (the convention of :class:`TimeResponse`);
        ``"foh"`` interpolates linearly between samples (first-order hold). A discrete system
        takes ``"zoh"`` only (its inputs are sequences).

    Returns
    -------
    TimeResponse
        ``x``, ``y``, ``u`` at ``timepts`` (``u`` the samples given, before any input delay;
        ``y`` with the delays), the system's names; ``method`` is ``"expm-zoh"``, ``"expm-foh"``
        or ``"recursion"`` (discrete), ``rtol`` is the double-precision unit round-off [-] (the
        method has no truncation error) and ``atol`` is 0 [state units].

    Raises
    ------
    ShapeError
        For malformed ``timepts``, ``inputs`` or ``x0``, or, for a discrete system, ``timepts``
        not spaced by its ``dt``.
    ModelError
        For an unknown ``hold``, ``"foh"`` on a discrete system, or a system that is not linear.

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
    lin = as_linear_system(sys, "sys", discrete=True, delay=True)
    t = _check_timepts(timepts, lin.dt)
    if hold not in _HOLDS:
        raise ModelError(f"hold must be one of {_HOLDS}, got {hold!r}")
    if lin.is_discrete and hold != "zoh":
        raise ModelError(f"hold={hold!r}: a discrete-time system takes input sequences (hold='zoh')")
    U, _ = _input_samples(_InputNames(lin), t, inputs)
    x_start = np.zeros(lin.n_states) if x0 is None else real_vector(x0, "x0", lin.n_states)
    if lin.is_discrete:
        X, Y = _recursion(lin, U, x_start)
        return _response(lin, t, X, U, "recursion", start, Y)
    if lin.has_delay:
        X, Y = _delayed(lin, t, U, x_start, hold)
        return _response(lin, t, X, U, f"expm-{hold}", start, Y)
    X = _propagate(lin, t, U, x_start, hold)
    return _response(lin, t, X, U, f"expm-{hold}", start)


def step_response(sys: Any, timepts: ArrayLike, *, input: str | int | None = None, hold: str = "zoh") -> TimeResponse:
    """Response to a unit step on one input, from rest at ``timepts[0]``.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A linear system, continuous or discrete, with or without delays.
    timepts : array_like
        Strictly increasing sample times [s], at least two (spaced by ``dt`` for a discrete
        system); the step occurs at ``timepts[0]``.
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
    lin = as_linear_system(sys, "sys", discrete=True, delay=True)
    t = _check_timepts(timepts, lin.dt)
    U = np.zeros((t.size, lin.n_inputs))
    U[:, _one_input(lin, input)] = 1.0
    return forced_response(lin, t, U, hold=hold)


def impulse_response(sys: Any, timepts: ArrayLike, *, input: str | int | None = None) -> TimeResponse:
    """Response to a unit impulse on one input at ``timepts[0]``, from rest.

    The impulse moves the state at once to ``x(t0+) = B e_i``; the response is then the free
    motion from that state. ``y`` is ``C x`` from ``t0+`` on: the impulse ``D e_i delta(t)``
    of a system with a direct feedthrough is not a sampled value and is left out. An input delay
    moves the impulse to ``t0 + tau``, an output delay shifts the output. A discrete system
    receives the unit pulse ``u[0] = 1`` (``scipy.signal.dimpulse``'s convention; python-control
    scales it by ``1/dt``), so ``y[0] = D e_i`` and ``y[k] = C A^(k-1) B e_i``.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A linear system, continuous or discrete, with or without delays.
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
    lin = as_linear_system(sys, "sys", discrete=True, delay=True)
    k = _one_input(lin, input)
    if lin.is_discrete:
        t = _check_timepts(timepts, lin.dt)
        U = np.zeros((t.size, lin.n_inputs))
        U[0, k] = 1.0
        return forced_response(lin, t, U)
    return _free_response(lin, _check_timepts(timepts), lin.B[:, k], float(lin.input_delay[k]))


def initial_response(sys: Any, timepts: ArrayLike, x0: ArrayLike) -> TimeResponse:
    """Free response from the initial state ``x0`` at ``timepts[0]``, with zero inputs.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A linear system, continuous or discrete (an output delay shifts the output: it is zero
        until the delay has passed).
    timepts : array_like
        Strictly increasing sample times [s], at least two (spaced by ``dt`` for a discrete
        system).
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
    lin = as_linear_system(sys, "sys", discrete=True, delay=True)
    if lin.is_discrete:
        return forced_response(lin, timepts, None, x0)
    return _free_response(lin, _check_timepts(timepts), real_vector(x0, "x0", lin.n_states), 0.0)


class _InputNames:
    """What :func:`_input_samples` needs of a model: the input count and name lookup."""

    def __init__(self, sys: LinearSystem) -> None:
        self.n_inputs = sys.n_inputs
        self._names = sys.inputs

    def input_index(self, key: str | int) -> int:
        return signal_index(self._names, key, "inputs")


def _check_timepts(timepts: ArrayLike, dt: float | None = None) -> NDArray[np.float64]:
    t = _checked_timepts(timepts)
    if dt is not None:
        off = np.abs(np.diff(t) - dt) > 1e-9 * dt + 8 * np.finfo(float).eps * np.max(np.abs(t))
        if np.any(off):
            i = int(np.argmax(off))
            raise ShapeError(
                f"timepts of a discrete system must be its sample instants, spaced by dt = {dt} s; "
                f"timepts[{i + 1}] - timepts[{i}] = {t[i + 1] - t[i]} s"
            )
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
               hold: str, U_end: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """States at ``t`` by one augmented matrix exponential per distinct step (see forced_response).

    ``U_end[k + 1]``: the input's limit from the left at ``t[k + 1]`` (a first-order hold with a
    jump there); ``U`` itself when omitted."""
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
            x += G2 @ ((U if U_end is None else U_end)[k + 1] - U[k])
        X[k + 1] = x
    return X


def _response(sys: LinearSystem, t, X, U, method: str, start: float, Y=None) -> TimeResponse:
    if Y is None:
        Y = X @ sys.C.T + U @ sys.D.T
    return TimeResponse(
        time=frozen_array(t), x=frozen_array(X), y=frozen_array(Y), u=frozen_array(U),
        states=sys.states, outputs=sys.outputs, inputs=sys.inputs, quaternion_drift=0.0,
        method=method, rtol=float(np.finfo(float).eps), atol=0.0,
        seconds=time.perf_counter() - start,
    )


def _shifted(values: NDArray, k: int) -> NDArray:
    """``values`` delayed by ``k`` samples, zero before (the system at rest)."""
    if k == 0:
        return values
    out = np.zeros_like(values)
    out[k:] = values[:-k] if k < values.shape[0] else out[k:]
    return out


def _recursion(sys: LinearSystem, U: NDArray, x0: NDArray) -> tuple[NDArray, NDArray]:
    """States and outputs of a discrete system: whole-period delays shift the sequences exactly."""
    k_in = np.round(sys.input_delay / sys.dt).astype(int) if sys.has_delay else np.zeros(sys.n_inputs, int)
    Ud = np.column_stack([_shifted(U[:, j], k_in[j]) for j in range(U.shape[1])]) if U.shape[1] else U
    X = np.empty((U.shape[0], sys.n_states))
    X[0] = x0
    for k in range(U.shape[0] - 1):
        X[k + 1] = sys.A @ X[k] + sys.B @ Ud[k]
    Y = X @ sys.C.T + Ud @ sys.D.T
    if sys.output_delay.any():
        k_out = np.round(sys.output_delay / sys.dt).astype(int)
        Y = np.column_stack([_shifted(Y[:, i], k_out[i]) for i in range(Y.shape[1])])
    return X, Y


def _held(t: NDArray, values: NDArray, s: NDArray, hold: str, left: bool, slack: float) -> NDArray:
    """The held input at times ``s`` (zero before ``t[0]``); ``left``: the limit from the left.

    A time within ``slack`` of a sample time is that sample time (``t + tau - tau`` is not ``t``
    in floating point)."""
    s = s - slack if left else s + slack
    if hold == "zoh":
        k = np.searchsorted(t, s, side="right") - 1
        return np.where(k >= 0, values[np.clip(k, 0, t.size - 1)], 0.0)
    return np.where(s >= t[0], np.interp(s, t, values), 0.0)


def _delayed(sys: LinearSystem, t: NDArray, U: NDArray, x0: NDArray, hold: str) -> tuple[NDArray, NDArray]:
    """A continuous system with delays, exactly: one grid holding every shifted switching instant."""
    base = sys.with_(input_delay=None, output_delay=None)
    t0, t1 = t[0], t[-1]
    extra = [t + d for d in np.unique(sys.input_delay[sys.input_delay > 0])]
    extra += [t - d for d in np.unique(sys.output_delay[sys.output_delay > 0])]
    slack = 1e-12 * (1.0 + max(abs(t0), abs(t1)))
    grid = np.concatenate([t] + extra)
    grid = np.unique(grid[(grid >= t0) & (grid <= t1)])
    # a shifted instant within the slack of another point is that point (no step of a few ulps)
    grid = grid[np.r_[True, np.diff(grid) > slack]]
    grid = np.unique(np.concatenate([grid[np.abs(grid[:, None] - t[None, :]).min(axis=1) > slack], t]))
    Ur = np.column_stack([_held(t, U[:, j], grid - sys.input_delay[j], hold, False, slack)
                          for j in range(sys.n_inputs)])
    Ul = np.column_stack([_held(t, U[:, j], grid - sys.input_delay[j], hold, True, slack)
                          for j in range(sys.n_inputs)])
    Xg = _propagate(base, grid, Ur, x0, hold, Ul)
    Yg = Xg @ base.C.T + Ur @ base.D.T
    X = Xg[np.searchsorted(grid, t)]
    Y = np.zeros((t.size, sys.n_outputs))
    for i in range(sys.n_outputs):
        s = t - sys.output_delay[i]
        ok = s >= t0 - 1e-12 * max(1.0, abs(t0))
        idx = np.clip(np.searchsorted(grid, s - 1e-12 * np.maximum(1.0, np.abs(s))), 0, grid.size - 1)
        Y[ok, i] = Yg[idx[ok], i]
    return X, Y


def _free_response(sys: LinearSystem, t: NDArray, x_start: NDArray, tau: float) -> TimeResponse:
    """Free motion of a continuous system from ``x_start`` at ``t0 + tau``, zero before (at rest).

    The one routine of :func:`initial_response` (``x0`` at ``t0``, ``tau = 0``) and
    :func:`impulse_response` (``B e_k`` at ``t0 + tau_k``, the input's delay): one matrix
    exponential per distinct step on a grid holding every instant the states are read at
    (``t - tau`` and ``t - tau - output delay``), so the delays stay exact."""
    start = time.perf_counter()
    base = sys.with_(input_delay=None, output_delay=None)
    out_delay = sys.output_delay
    shifts = np.unique(np.concatenate([[tau], tau + out_delay]))
    grid = np.unique(np.concatenate([np.maximum(t - d, t[0]) for d in shifts]))
    Xg = _propagate(base, grid, np.zeros((grid.size, base.n_inputs)), x_start, "zoh")

    def free(s: NDArray) -> NDArray:   # the state of the motion started at t0, read at s (zero before t0)
        slack = 1e-12 * np.maximum(1.0, np.abs(s))
        out = Xg[np.clip(np.searchsorted(grid, s - slack), 0, grid.size - 1)]
        return np.where((s >= t[0] - slack)[:, None], out, 0.0)

    X = free(t - tau)
    Y = np.column_stack([free(t - tau - out_delay[i]) @ base.C[i] for i in range(sys.n_outputs)]) \
        if sys.n_outputs else np.zeros((t.size, 0))
    return _response(sys, t, X, np.zeros((t.size, sys.n_inputs)), "expm-zoh", start, Y)
