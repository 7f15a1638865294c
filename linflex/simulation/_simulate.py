"""Nonlinear time simulation: ``simulate(model, timepts, ...) -> TimeResponse``."""

from __future__ import annotations

import csv
import numbers
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..scene._scene import Scene
from ..system._errors import LinflexError, MethodUnavailableError, ModelError, ShapeError
from ..system._linear import as_linear_system
from ..system._model import NonlinearModel
from ..system._plotting import PlotHandle, plot_axes
from ..system._progress import Progress, stderr_is_terminal
from ..system._signals import check_positive, frozen_array, real_array, real_vector
from ._steppers import CASADI_METHODS, EXPONENTIAL, SCIPY_METHODS, autonomous, jacobian_function, stepper

__all__ = ["TimeResponse", "simulate", "time_response_plot"]

_AUTO = "auto"
# "auto" takes BDF when a heavily damped mode decays this many times faster than the fastest
# motion the run must resolve anyway (see _stiffness).
STIFFNESS_RATIO = 10.0
# "auto" takes the exponential integrator when the fastest lightly damped mode turns through more
# than OSCILLATION_PER_SAMPLE radians per sample interval on average and more than
# OSCILLATION_RADIANS over the run, for models of at least OSCILLATION_STATES states (see
# simulate's Notes).
OSCILLATION_PER_SAMPLE = 3.0
OSCILLATION_RADIANS = 1000.0
OSCILLATION_STATES = 30




@dataclass(frozen=True, eq=False)
class TimeResponse:
    """A simulated time response with named signals.

    Attributes
    ----------
    time : ndarray, shape (n_time,)
        Sample times [s].
    x, y, u : ndarray, shape (n_time, n_signals)
        State, output and input trajectories [state, output and input units: m, rad, m/s,
        rad/s, N, N m, ...]; inputs are the values held over the interval that starts at each
        sample.
    states, outputs, inputs : tuple of str
        Names of the columns of ``x``, ``y``, ``u`` (as a system's ``states``, ``outputs``,
        ``inputs``: names, never data; see ``docs/glossary.md``).
    energy : ndarray, shape (n_time,) or None
        Total mechanical energy [J] where the model provides it (evaluated from the states on
        first access).
    momentum : ndarray, shape (n_time, 3) or None
        Angular momentum about the frame origin in inertial axes [N m s] where provided (idem).
    quaternion_drift : float
        Largest ``| |q| - 1 |`` [-] of any quaternion found before renormalization (0 without
        quaternions).
    method : str
        The integrator used (``"cvodes"``, ``"scipy-RK45"``, ...).
    rtol : float
        Relative tolerance of the integrator [-].
    atol : float or ndarray, shape (n_states,)
        Absolute tolerance of the integrator [state units]: one for every state, or one per state.
    seconds : float
        Wall time of the integration [s].
    monitors : callable or None
        Computes ``(energy, momentum)`` from the states (used by the two properties).
    n_steps, n_rejected, n_evaluations, n_linearizations : int or None
        The integrator's accepted steps, rejected steps, evaluations of the right-hand side and
        Jacobians taken (re-linearizations included), as it reports them
        (:class:`~linflex.simulation._steppers.IntegratorCounts`); None where it reports none
        (scipy's ``solve_ivp`` reports no steps).
    """

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    u: NDArray[np.float64]
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    quaternion_drift: float
    method: str
    rtol: float
    atol: float | NDArray[np.float64]
    seconds: float
    monitors: Callable[[], tuple[np.ndarray, np.ndarray]] | None = field(default=None, repr=False, compare=False)
    n_steps: int | None = None
    n_rejected: int | None = None
    n_evaluations: int | None = None
    n_linearizations: int | None = None

    def _display_fields(self):
        span = f"{self.time[0]:.4g} to {self.time[-1]:.4g}" if self.time.size else "-"
        return [("n_time", self.time.size), ("time [s]", span), ("states", self.states), ("outputs", self.outputs),
                ("inputs", self.inputs), ("method", self.method), ("rtol", self.rtol), ("atol", self.atol),
                ("quaternion_drift", self.quaternion_drift), ("seconds", self.seconds)] + [
                    (name, getattr(self, name)) for name in ("n_steps", "n_rejected", "n_evaluations", "n_linearizations")
                    if getattr(self, name) is not None]

    def __repr__(self) -> str:
        from ..system._display import short_repr

        return short_repr("TimeResponse", self._display_fields())

    def _repr_html_(self) -> str:
        from ..system._display import html_summary

        rows = []
        if self.time.size:
            for kind, names, data in (("state", self.states, self.x), ("output", self.outputs, self.y),
                                      ("input", self.inputs, self.u)):
                for j, name in enumerate(names):
                    column = data[:, j]
                    rows.append((name, kind, column[0], column[-1], column.min(), column.max()))
        return html_summary(f"TimeResponse ({self.time.size} points)", self._display_fields(),
                            ("signal", "kind", "initial", "final", "min", "max"), rows,
                            note="Signals in their units; response[name] gives one over time.")

    def _monitor_values(self) -> tuple[np.ndarray, np.ndarray] | None:
        if self.monitors is None:
            return None
        cached = self.__dict__.get("_monitor_cache")
        if cached is None:
            cached = self.monitors()
            object.__setattr__(self, "_monitor_cache", cached)
        return cached

    @property
    def energy(self) -> NDArray[np.float64] | None:
        """Total mechanical energy [J], shape ``(n_time,)``, or None when the model has no monitors."""
        values = self._monitor_values()
        return None if values is None else values[0]

    @property
    def momentum(self) -> NDArray[np.float64] | None:
        """Angular momentum about the frame origin in inertial axes [N m s], shape ``(n_time, 3)``, or None."""
        values = self._monitor_values()
        return None if values is None else values[1]

    @property
    def signal_names(self) -> tuple[str, ...]:
        """Names of the columns of :attr:`data`: states, then outputs, then inputs."""
        return self.states + self.outputs + self.inputs

    @property
    def data(self) -> NDArray[np.float64]:
        """All signals, shape ``(n_time, n_signals)`` in the order of :attr:`signal_names`."""
        return np.hstack([self.x, self.y, self.u])

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        """One signal by name (states first, then outputs, then inputs); also ``"energy"``."""
        for names, values in ((self.states, self.x), (self.outputs, self.y), (self.inputs, self.u)):
            if name in names:
                return values[:, names.index(name)]
        if name == "energy" and self.energy is not None:
            return self.energy
        from difflib import get_close_matches

        hint = get_close_matches(str(name), self.signal_names, n=1)
        raise ModelError(f"unknown signal {name!r}" + (f" (did you mean {hint[0]!r}?)" if hint else
                                                      f"; known: {', '.join(self.signal_names[:12])}"))

    def to_csv(self, path: str | Path, signals: str | list[str] | None = None) -> None:
        """Write ``time`` and the chosen ``signals`` (all by default) as CSV with a header.

        Parameters
        ----------
        path : str or path-like
            The file to write: written under a temporary name and renamed into place, so an
            existing file is replaced in one step (or kept if writing fails).
        signals : str or list of str, optional
            Signal names (see :meth:`__getitem__`); all of :attr:`signal_names` when omitted.
            Values are written in the signals' units, ``time`` in [s], full precision.

        Raises
        ------
        ModelError
            For an unknown signal name.
        """
        names = list(self.signal_names) if signals is None else _signal_list(signals)
        columns = [self[n] for n in names]
        from ..system._files import atomic_write

        with atomic_write(path, newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(["time"] + names)
            for k, t in enumerate(self.time):
                writer.writerow([repr(float(t))] + [repr(float(c[k])) for c in columns])

    def plot(self, signals: str | list[str] | None = None, *, ax=None):
        """Plot signals over time; see :func:`time_response_plot`.

        Parameters
        ----------
        signals : str or list of str, optional
            Names of the signals to draw; the first six states when omitted.
        ax : matplotlib Axes, optional
            The axes to draw on; a new figure when omitted.

        Returns
        -------
        PlotHandle
            As :func:`time_response_plot`; time on the x axis [s].
        """
        return time_response_plot(self, signals, ax=ax)


def time_response_plot(response: TimeResponse, signals: str | list[str] | None = None, *, ax=None) -> PlotHandle:
    """Draw ``signals`` of ``response`` over time on ``ax`` (a new figure when omitted).

    Parameters
    ----------
    response : TimeResponse
        A simulation result; time on the x axis in seconds.
    signals : str or list of str, optional
        Names of the signals to draw; the first six states when omitted.
    ax : matplotlib Axes, optional
        The axes to draw on.

    Returns
    -------
    PlotHandle
        ``axes`` is the one axes drawn on; ``lines`` one ``Line2D`` per signal (in the signal's
        units against time [s]); ``data`` the response.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from linflex import NonlinearModel, simulate, time_response_plot
    >>> decay = NonlinearModel(lambda x, u, t: -x, states=["x"])
    >>> r = simulate(decay, np.linspace(0, 1, 11), [1.0], method="scipy-RK45")
    >>> h = time_response_plot(r)
    >>> len(h.lines)
    1
    >>> plt.close(h.figure)
    """
    names = list(response.states[:6]) if signals is None else _signal_list(signals)
    fig, (ax,) = plot_axes(ax, 1, figsize=(8, 4.5))
    lines = tuple(ax.plot(response.time, response[n], label=n)[0] for n in names)
    ax.set_xlabel("time [s]")
    ax.grid(True, alpha=0.3)
    if names:
        ax.legend(loc="best", fontsize="small")
    return PlotHandle(fig, (ax,), lines, response)


def _signal_list(signals: Any) -> list[str]:
    """``signals`` as a list of names: one name alone is that signal (not its characters)."""
    return [signals] if isinstance(signals, str) else list(signals)


def _input_samples(model: NonlinearModel, timepts: np.ndarray, inputs: Any) -> tuple[np.ndarray, Callable | None]:
    """Sampled inputs (n_time, n_inputs) and, for callables, a continuous-time function."""
    n_t, m = timepts.size, model.n_inputs
    if inputs is None:
        return np.zeros((n_t, m)), None
    if callable(inputs):
        samples = np.array([real_vector(inputs(t), "inputs(t)", m) for t in timepts]).reshape(n_t, m)
        return samples, lambda t: np.asarray(inputs(t), float).reshape(m)
    if isinstance(inputs, Mapping):
        samples = np.zeros((n_t, m))
        funcs: dict[int, Callable] = {}
        for key, value in inputs.items():
            k = model.input_index(key)
            if callable(value):
                funcs[k] = lambda t, value=value, key=key: _scalar_input(value, key, t)
                samples[:, k] = [funcs[k](t) for t in timepts]
            else:
                arr = real_array(value, f"inputs[{key!r}]", "number or vector")
                if arr.ndim == 0:
                    samples[:, k] = arr
                elif arr.shape == (n_t,):
                    samples[:, k] = arr
                else:
                    raise ShapeError(f"inputs[{key!r}] has shape {arr.shape}; a scalar, a callable or "
                                     f"shape ({n_t},) was expected")
        if not np.all(np.isfinite(samples)):
            raise ShapeError("inputs: non-finite values")
        if not funcs:
            return samples, None

        def cont(t, base=samples):
            out = _zoh(timepts, base, t).copy()
            for k, fn in funcs.items():
                out[k] = fn(t)
            return out
        return samples, cont
    arr = real_array(inputs, "inputs", "array")
    if arr.shape == (m,):
        arr = np.tile(arr, (n_t, 1))
    if arr.shape != (n_t, m):
        raise ShapeError(f"inputs has shape {arr.shape}; ({n_t}, {m}) (n_time, n_inputs), ({m},), a callable "
                         "or a mapping by input name was expected")
    if not np.all(np.isfinite(arr)):
        raise ShapeError("inputs: non-finite values")
    return arr, None


def _scalar_input(function: Callable, key: Any, t: float) -> float:
    """The value of an input's function ``inputs[key](t)``, checked: one real number."""
    return float(real_vector(function(t), f"inputs[{key!r}](t)", 1)[0])


def _checked_timepts(timepts: ArrayLike) -> NDArray[np.float64]:
    """``timepts`` [s] as a float vector, checked: at least two finite, strictly increasing times."""
    t = real_array(timepts, "timepts", "vector of times")
    if t.ndim != 1 or t.size < 2:
        raise ShapeError(f"timepts must be a vector of at least 2 times, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ShapeError("timepts must be finite and strictly increasing")
    return t


def scene_inputs(model: NonlinearModel) -> dict[str, Callable[[float], float]] | None:
    """The time profiles of a compiled scene's ``[[inputs]]`` by input name (None without any).

    Parameters
    ----------
    model : NonlinearModel
        A compiled scene (other models have no profiles).

    Returns
    -------
    dict of str to callable, or None
        ``{input name: t -> value}`` [input units]; profiles of the same input add up.
    """
    entries = tuple(getattr(getattr(model, "scene", None), "inputs", None) or ())
    if not entries:
        return None
    parts: dict[str, list[Callable[[float], float]]] = {}
    for entry in entries:
        parts.setdefault(entry.input, []).append(entry.signal())
    return {name: (fns[0] if len(fns) == 1 else (lambda t, fns=fns: sum(f(t) for f in fns)))
            for name, fns in parts.items()}


def _zoh(timepts: np.ndarray, samples: np.ndarray, t: float) -> np.ndarray:
    k = int(np.clip(np.searchsorted(timepts, t, side="right") - 1, 0, timepts.size - 1))
    return samples[k]


def simulate(
    model: NonlinearModel,
    timepts: ArrayLike,
    x0: ArrayLike | None = None,
    inputs: Any = None,
    *,
    method: str = "auto",
    rtol: float = 1e-8,
    atol: float | ArrayLike = 1e-10,
    progress: bool | None = None,
    chunks: int | None = None,
) -> TimeResponse:
    """Integrate a nonlinear model over ``timepts``.

    Parameters
    ----------
    model : NonlinearModel
        A compiled scene (:func:`compile_model`) or any nonlinear model (numpy models need a
        ``"scipy-..."`` method).
    timepts : array_like
        Increasing sample times [s], at least two; integration starts at ``timepts[0]``.
    x0 : array_like, optional
        Initial state [state units]; default ``model.x0`` for compiled scenes (required
        otherwise). Its attitude quaternions are scaled to unit norm (the motion is that of
        the unit quaternion; their norm's deviation counts in ``quaternion_drift``).
    inputs : None, array_like, callable or mapping, optional
        Inputs [input units: N, N m, ...]: ``(n_time, n_inputs)`` samples held constant over each interval (zero-order hold), a
        constant ``(n_inputs,)``, a function ``u(t)``, or a mapping from input names to scalars,
        callables or ``(n_time,)`` samples. CasADi methods hold each input at its value at the
        start of every interval; ``scipy`` methods evaluate callables continuously. None (the
        default): the scene's ``[[inputs]]`` profiles (:class:`linflex.InputProfile`) for a compiled scene that has them, else zero.
    method : str
        ``"auto"`` (default): for CasADi models ``"cvodes"`` when the model is stiff at the
        start of the run, ``"exponential"`` when it is oscillatory (fast lightly damped modes
        against the sample interval), ``"cvodes-adams"`` otherwise (see Notes); for numpy models
        ``"scipy-LSODA"`` (which switches between Adams and BDF itself). The choice is
        ``TimeResponse.method``.
        ``"cvodes"`` (SUNDIALS BDF via CasADi, Newton with the Jacobian from the graph),
        ``"cvodes-adams"`` (Adams-Moulton with functional iteration: no Jacobian, much cheaper
        per step for non-stiff models with many states), ``"idas"``,
        ``"exponential"`` (CasADi models: the linear part about a frozen Jacobian integrated
        exactly by matrix exponentials, the remainder by a fourth-order exponential
        Runge-Kutta scheme, steps of the sample interval over powers of two; exact for linear
        models, see Notes),
        or ``"scipy-RK45"``, ``"scipy-DOP853"``, ``"scipy-RK23"``, ``"scipy-Radau"``,
        ``"scipy-BDF"``, ``"scipy-LSODA"`` (``scipy.integrate.solve_ivp``).
    rtol : float
        Relative tolerance of the integrator [-].
    atol : float or array_like, shape (n_states,)
        Absolute tolerance [state units]: one number for every state, or one per state. Each
        state's local error is kept below ``rtol |x_i| + atol_i``; a per-state tolerance at a
        fraction of each state's natural size (a modal coordinate of 1e-5 beside an attitude of
        1 rad) asks for the same relative accuracy of every state (see Notes).
    progress : bool, optional
        Show a progress bar on stderr; default: when stderr is a terminal and the run has more
        than 200 samples.
    chunks : int, optional
        Number of pieces the run is split into, a positive integer (at most one piece per
        sample interval is made); the integrator restarts and quaternions are
        renormalized at each boundary (default 1, or 50 with a progress bar). The compiled
        equations use the normalized attitude matrix, so a drift of the quaternion norm
        (reported as ``quaternion_drift``) does not change the motion. With sampled
        controllers the integrator restarts (and renormalizes) at every sample and command
        instant instead.

    Returns
    -------
    TimeResponse
        With sampled controllers in the model (``model.compiled.sampled_controllers``: a
        scene's controllers with ``sample_time``), the run is a sampled-data simulation: the
        plant is integrated between the sample instants ``timepts[0] + k sample_time`` (and
        the instants their commands take effect, ``delay`` later), the controllers step at the
        samples on the measured outputs (plus their seeded noise), and their held commands
        (after saturation, rate limit, quantization) add to their actuators' inputs, which
        ``u`` reports.

    Raises
    ------
    ShapeError
        For malformed ``timepts``, ``x0`` (a zero quaternion too), ``inputs``, ``atol`` or
        ``chunks``.
    ModelError
        When ``rtol`` is not a finite positive number.
    MethodUnavailableError
        For an unknown method, or a CasADi method on a numpy model.
    ConvergenceError
        When the integrator fails.

    Notes
    -----
    Stiffness test of ``"auto"``: the eigenvalues ``lambda`` of ``df/dx`` at ``(x0, u(t0),
    t0)``. Lightly damped modes (damping ratio at most 0.5) and unstable ones must be resolved
    by any method, so their largest ``|lambda|`` (at least ``2 pi`` over the time span) is the
    pace of the run; the model is stiff when a heavily damped mode decays more than
    ``STIFFNESS_RATIO`` (10) times faster than that pace: then BDF's stability pays for its
    Newton iterations, otherwise Adams (no Jacobian, larger steps at tight tolerances) is
    cheaper. Lightly damped flexible modes make a model oscillatory, not stiff: a modal model of
    a structure with undamped modes up to 170 rad/s runs 5 to 7 times faster with Adams
    (``benchmarks/simulation.py``). Adams still resolves every oscillation of the fastest mode:
    its steps grow with that frequency. When the fastest lightly damped mode turns through more
    than ``OSCILLATION_PER_SAMPLE`` (3) radians per sample interval on average and more than
    ``OSCILLATION_RADIANS`` (1000) over the run, the model has at least ``OSCILLATION_STATES``
    (30) states and does not depend on time explicitly, ``"auto"`` takes ``"exponential"``,
    whose steps are set by the sample interval, the inputs and the slow (nonlinear) motion, not
    by the modes. (Below 30 states a step's fixed cost in Python outweighs the steps Adams adds;
    a prescribed motion, such as a spin-up profile, varies the linear part in time, which a
    frozen Jacobian follows only in small steps. The thresholds are measured on the models of
    ``benchmarks/simulation.py``: the structure with undamped modes to 53 rad/s, 42 states, 1600
    radians over 300 samples, runs 2 times faster than with Adams, the 16-state flexible
    spacecraft, 5000 radians over 1000 samples, 3 times slower.)

    The exponential integrator (``linflex/simulation/_exponential.py``; S. Krogstad, J. Comput.
    Phys. 203 (2005) 72-88, and M. Hochbruck and A. Ostermann, Acta Numerica 19 (2010)
    209-286) splits ``f = J x + N(x)`` about the model's exact Jacobian ``J``, frozen while the
    error test passes and taken anew where it rejects a step (``TimeResponse.n_linearizations``).
    The linear part is exact (``phi`` functions of ``h J`` by a scaled Taylor series and
    doublings, checked, cached per step size); for a linear model the result is the exact
    zero-order-hold recursion in one step per sample, whatever the frequencies. The local error
    estimates are the difference to an embedded third-order solution and a third divided
    difference of ``N`` over the step and the one before (it sees fast content the frozen J
    leaves in ``N``); their root mean square over the states, each over ``rtol max(|x_i|,
    |x+_i|) + atol_i``, is kept below 1, as CVODES and scipy do (a per-state ``atol`` is used as
    given). Nonlinear coupling puts fast content in ``N`` that a frozen Jacobian leaves there:
    the Jacobian's columns of a fast mode change with the slower deflections and rates within a
    few steps, and that change times the fast mode's oscillation is in ``N``. A Jacobian taken at
    every step would remove most of it but costs about ``n`` evaluations of ``f`` and a ``phi``
    each; so the steps resolve the fast mode where the tolerance asks for its content (the
    arrays of ``benchmarks/simulation.py`` with an axial mode take four times the steps to the
    same tip accuracy of 1e-8 as those without), and Adams can be cheaper.
    Compiled flexible models (speeds with a constant modal mass block) are stepped in their
    momentum form ``(q, p = M(q) u)`` and returned in their own state: there the stiffness
    enters the momenta's rates with its constant coefficient, while in ``u' = M(q)^-1 (...)`` a
    stiff mode's force reaches every speed through the deflection-dependent ``M(q)^-1``, a
    change of the Jacobian that a frozen ``J`` leaves, stiff, in ``N``
    (``linflex/simulation/_momentum.py``; on the solar arrays of ``benchmarks/simulation.py``
    with their axial mode about twice the tip accuracy per step, the steps' error measured in
    the speeds).

    A per-state ``atol`` reaches CVODES (which takes one absolute tolerance) as a scaling of the
    states: it integrates ``z_i = x_i / w_i`` with ``w_i = atol_i / min(atol)`` and the absolute
    tolerance ``min(atol)``, whose error test ``|e_z| <= rtol |z| + min(atol)`` is the requested
    ``|e_x| <= rtol |x| + atol_i`` exactly; scipy's methods take the vector as it is.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import NonlinearModel, simulate
    >>> decay = NonlinearModel(lambda x, u, t: -x, states=["x"])
    >>> r = simulate(decay, np.linspace(0, 1, 3), [1.0], method="scipy-RK45", rtol=1e-10, atol=1e-12)
    >>> round(float(r["x"][-1]), 6)
    0.367879
    """
    if not isinstance(model, NonlinearModel):
        hint = ("; a linear system's time responses are forced_response, step_response, impulse_response and "
                "initial_response") if _is_linear_system_like(model) else ""
        if isinstance(model, (Scene, str, os.PathLike)):
            hint = "; compile the scene first: linflex.compile_model(scene)"
        raise ModelError(f"model must be a linflex NonlinearModel or compiled Model, got {type(model).__name__}{hint}")
    if method not in (_AUTO,) + CASADI_METHODS + SCIPY_METHODS:
        raise MethodUnavailableError(f"method {method!r} is unknown; choose one of "
                                     f"{', '.join((_AUTO,) + CASADI_METHODS + SCIPY_METHODS)}")
    if method in CASADI_METHODS and not model.is_casadi:
        raise MethodUnavailableError(f"method {method!r} needs a CasADi model; this one is made of numpy callables "
                                     "(use a 'scipy-...' method)")
    timepts = _checked_timepts(timepts)
    rtol = check_positive(rtol, "rtol")
    atol = _absolute_tolerance(atol, model.n_states)
    if x0 is None:
        if getattr(model, "x0", None) is None:
            raise ShapeError("x0 is required for a model without an initial state")
        x0 = model.x0
    x = np.array(real_vector(x0, "x0", model.n_states))
    quats = tuple(getattr(model, "quaternions", ()))
    drift0 = _normalized_quaternions(model, x, quats)
    if inputs is None:
        inputs = scene_inputs(model)
    U, u_cont = _input_samples(model, timepts, inputs)
    jacobian0 = None  # df/dx at (x0, U[0], t0) where auto took it: the exponential stepper's first
    if method == _AUTO:
        method, jacobian0 = ("scipy-LSODA", None) if not model.is_casadi else _auto_method(model, x, U[0], timepts)
    n_t = timepts.size
    show = (stderr_is_terminal() and n_t > 200) if progress is None else bool(progress)
    if chunks is None:
        chunks = 50 if show else 1
    elif not isinstance(chunks, numbers.Integral) or isinstance(chunks, bool) or chunks < 1:
        raise ShapeError(f"chunks must be a positive integer, got {chunks!r}")
    chunks = int(min(chunks, n_t - 1))
    bounds = np.linspace(0, n_t - 1, chunks + 1).round().astype(int)
    # Restart the integrator where a held input jumps (multistep methods dislike a kink in the
    # history); inputs that change at every sample are left to the integrator's step control.
    jumps = np.flatnonzero(np.any(U[1:-1] != U[:-2], axis=1)) + 1 if n_t > 2 else np.zeros(0, int)
    if 0 < jumps.size <= 500:
        bounds = np.union1d(bounds, jumps)

    sampled = tuple(getattr(getattr(model, "compiled", None), "sampled_controllers", None) or ())
    if sampled:
        return _sampled_response(model, sampled, timepts, x, U, u_cont, method, rtol, atol, quats, show, drift0)
    X = np.zeros((n_t, model.n_states))
    X[0] = x
    drift = drift0
    bar = Progress(show, n_t - 1, "simulate")
    start = time.perf_counter()
    step, counts = stepper(model, method, rtol, atol, U, u_cont, timepts, jacobian0)
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b <= a:
            continue
        X[a + 1:b + 1] = step(timepts[a:b + 1], X[a], U[a:b + 1])
        for k in quats:
            norms = np.linalg.norm(X[a + 1:b + 1, k:k + 4], axis=1)
            drift = max(drift, float(np.max(np.abs(norms - 1))))
            X[b, k:k + 4] /= norms[-1]
        bar.update(b)
    bar.close()
    seconds = time.perf_counter() - start

    Y = _outputs(model, timepts, X, U)
    monitors = None
    if getattr(model, "energy", None) is not None:
        monitors = _monitor_function(model, timepts, X)
    return TimeResponse(
        time=frozen_array(timepts), x=frozen_array(X), y=frozen_array(Y), u=frozen_array(U),
        states=model.states, outputs=model.outputs, inputs=model.inputs,
        quaternion_drift=drift, method=method, rtol=float(rtol), atol=_reported(atol), seconds=seconds,
        monitors=monitors, **_counts(counts),
    )


def _normalized_quaternions(model: NonlinearModel, x: np.ndarray, quats: tuple[int, ...]) -> float:
    """Scale the quaternions of the initial state ``x`` to unit norm, in place, as the run
    renormalizes them; return the largest ``| |q| - 1 |`` [-] (the run's first drift).

    The compiled equations use the normalized attitude matrix, so the motion is that of the unit
    quaternion; the states returned are then unit quaternions from the first sample on (rather
    than keeping the given norm up to the first renormalization).

    Raises
    ------
    ShapeError
        For a quaternion of zero norm (no attitude).
    """
    drift = 0.0
    for k in quats:
        norm = float(np.linalg.norm(x[k:k + 4]))
        if not norm > 0.0:
            names = ", ".join(model.states[k:k + 4])
            raise ShapeError(f"x0[{k}:{k + 4}] ({names}) is a zero quaternion; an attitude needs a unit quaternion "
                             "(1, 0, 0, 0 for the reference attitude)")
        x[k:k + 4] /= norm
        drift = max(drift, abs(norm - 1.0))
    return drift


def _counts(counts) -> dict:
    return {"n_steps": counts.steps, "n_rejected": counts.rejected, "n_evaluations": counts.evaluations,
            "n_linearizations": counts.linearizations}


def _absolute_tolerance(atol, n_states: int) -> float | np.ndarray:
    """``atol`` checked: a positive float, or a positive vector of one per state."""
    try:
        arr = np.asarray(atol, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"atol must be a positive number or one per state, got {atol!r}") from err
    if arr.ndim == 0:
        if not (np.isfinite(arr) and arr > 0):
            raise ShapeError(f"atol must be a positive number, got {atol}")
        return float(arr)
    if arr.shape != (n_states,):
        raise ShapeError(f"atol has shape {arr.shape}; a number or one per state, shape ({n_states},), was expected")
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise ShapeError("atol: every per-state tolerance must be a positive number")
    return arr


def _reported(atol) -> float | np.ndarray:
    return atol if isinstance(atol, float) else frozen_array(atol)


def _sampled_response(model, sampled, timepts, x, U, u_cont, method, rtol, atol, quats, show,
                      drift0: float) -> TimeResponse:
    """:func:`simulate` of a model with sampled controllers (see :mod:`._sampled`)."""
    from ._sampled import sampled_run, user_inputs

    bar = Progress(show, timepts.size - 1, "simulate")
    start = time.perf_counter()
    # The held commands change the inputs at every sample: the integrator sees them as pieces.
    step, counts = stepper(model, method, rtol, atol, U, None, timepts)
    X, U_all, drift = sampled_run(model, sampled, timepts, x, user_inputs(timepts, U, u_cont), step, quats, bar)
    drift = max(drift, drift0)
    bar.close()
    seconds = time.perf_counter() - start
    monitors = _monitor_function(model, timepts, X) if getattr(model, "energy", None) is not None else None
    return TimeResponse(
        time=frozen_array(timepts), x=frozen_array(X), y=frozen_array(_outputs(model, timepts, X, U_all)),
        u=frozen_array(U_all), states=model.states, outputs=model.outputs, inputs=model.inputs,
        quaternion_drift=drift, method=method, rtol=float(rtol), atol=_reported(atol), seconds=seconds,
        monitors=monitors, **_counts(counts),
    )


def _monitor_function(model, timepts, X):
    """Energy and momentum along the run, computed when first asked for."""

    def evaluate():
        n_t = timepts.size
        targs = ((X.T, np.asarray(model.param_values).reshape(-1, 1)) if model.params else (X.T,)) + (timepts.reshape(1, -1),)
        mon = getattr(model, "monitors", None)
        if mon is not None:
            e_, h_ = mon.map(n_t)(*targs)
        else:
            e_, h_ = model.energy.map(n_t)(*targs), model.momentum.map(n_t)(*targs)
        return frozen_array(np.asarray(e_, float).reshape(-1)), frozen_array(np.asarray(h_, float).T)
    return evaluate


def _outputs(model: NonlinearModel, timepts, X, U) -> np.ndarray:
    n_t = timepts.size
    if model.n_outputs == 0:
        return np.zeros((n_t, 0))
    if model.is_casadi:
        pargs = (np.asarray(model.param_values).reshape(-1, 1),) if model.params else ()
        Y = model.h.map(n_t)(X.T, U.T, *pargs, timepts.reshape(1, -1))
        return np.asarray(Y, float).T.reshape(n_t, model.n_outputs)
    return np.array([model.evaluate_raw(X[k], U[k], timepts[k])[1] for k in range(n_t)])


def _auto_method(model: NonlinearModel, x0: np.ndarray, u0: np.ndarray,
                 timepts: np.ndarray) -> tuple[str, np.ndarray | None]:
    """The CasADi method ``"auto"`` chooses (see ``simulate``'s Notes), with df/dx at
    ``(x0, u0, t0)`` [1/s] where the exponential integrator is chosen (its first Jacobian)."""
    span = float(timepts[-1] - timepts[0])
    A = jacobian_function(model)(x0, u0, model.param_values, timepts[0]).full()
    stiffness, pace = _stiffness(A, span)
    if stiffness > STIFFNESS_RATIO:
        return "cvodes", None
    if (model.n_states >= OSCILLATION_STATES and autonomous(model)
            and pace * span > max(OSCILLATION_PER_SAMPLE * (timepts.size - 1), OSCILLATION_RADIANS)):
        return EXPONENTIAL, A
    return "cvodes-adams", None


def _stiffness(A: np.ndarray, span: float) -> tuple[float, float]:
    """``(stiffness, pace)`` of the Jacobian ``A`` [1/s] over a run of ``span`` [s]: the decay
    rate of the fastest heavily damped mode over the pace of the run, and that pace [rad/s]
    (see ``simulate``'s Notes)."""
    if not np.all(np.isfinite(A)):
        return np.inf, 0.0  # let BDF's error control sort it out
    lam = np.linalg.eigvals(A)
    size = np.abs(lam)
    damped = -lam.real > 0.5 * size
    pace = max(float(np.max(size[~damped], initial=0.0)), 2 * np.pi / span)
    return float(np.max(-lam.real[damped], initial=0.0)) / pace, pace


def _is_linear_system_like(obj) -> bool:
    """A linflex, python-control or scipy.signal linear system (or a (num, den) pair)."""
    try:
        as_linear_system(obj, "model", discrete=True, delay=True)
    except LinflexError:
        return False
    return True
