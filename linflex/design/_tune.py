"""Tune a controller to its margin requirements: the largest bandwidth (or the best objective) that passes.

The requirements are those of the report (``[requirements]``, :class:`~linflex.scene.Requirements`),
checked by the report's own rule (:func:`linflex.stability.report.margin_checks`), so a tuned
design passes the report that reviews it. Each requirement's slack is measured relative to its
bound, so gain (dB), phase (deg), delay (s) and disk margins compare on one scale.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from linflex.scene import Requirements
from linflex.stability import StabilityMargins, stability_margins
from linflex.stability.report import Check, margin_checks
from linflex.system import ConvergenceError, LinflexError, ModelError, frozen_array

__all__ = ["TuneResult", "tune"]

#: The requirements a margin computation can check (sensitivity peaks need the closed loop's
#: sensitivities: use the report).
MARGIN_REQUIREMENTS = ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "disk_margin")

#: The slack given to a design whose closed loop is unstable or whose margins cannot be computed.
_UNSTABLE = -10.0


@dataclass(frozen=True)
class TuneResult:
    """Result of :func:`tune`.

    Attributes
    ----------
    x : ndarray
        The tuned parameters (in the units ``build`` takes them).
    feasible : bool
        Whether every requirement holds at ``x``.
    active : Check or None
        The requirement with the least relative slack at ``x`` (the one that stops the tuning);
        None when the bound of the parameter stopped it first with slack to spare.
    slack : float
        Least relative slack at ``x`` [-]: ``(value - bound) / |bound|`` for margins.
    checks : tuple of Check
        Every required check at ``x`` (value, bound, frequency).
    margins : StabilityMargins
        The margins at ``x``.
    evaluations : int
        Number of margin computations.
    seconds : float
        Wall time [s].
    """

    x: NDArray[np.float64]
    feasible: bool
    active: Check | None
    slack: float
    checks: tuple[Check, ...]
    margins: StabilityMargins
    evaluations: int
    seconds: float


def _requirements(requirements) -> Requirements:
    try:
        req = requirements if isinstance(requirements, Requirements) else Requirements(**dict(requirements or {}))
    except TypeError as err:   # an unknown name: Requirements.__init__ got an unexpected keyword argument
        raise ModelError(f"requirements: {err}; tune checks {', '.join(MARGIN_REQUIREMENTS)}") from None
    values = dict(req.global_values())
    for loop in (req.loops or {}).values():
        values.update(loop)
    unknown = sorted(set(values) - set(MARGIN_REQUIREMENTS))
    if unknown:
        raise ModelError(f"tune checks margins only ({', '.join(MARGIN_REQUIREMENTS)}); "
                         f"{unknown} need the closed loop's sensitivities: check them with the report")
    if not values:
        raise ModelError(f"tune: give at least one requirement among {', '.join(MARGIN_REQUIREMENTS)}")
    return req


def _relative(check: Check) -> float:
    if not np.isfinite(check.slack):
        return _UNSTABLE if check.slack < 0 else np.inf
    return check.slack / max(abs(check.required), 1e-12)


def tune(build: Callable, bounds, requirements, *, objective: Callable | None = None, x0=None,
         xtol: float = 1e-4, max_evaluations: int = 200) -> TuneResult:
    """The parameters that maximize a bandwidth (or minimize ``objective``) subject to margin requirements.

    Parameters
    ----------
    build : callable
        ``build(x)`` returns the loop for parameters ``x``: a :class:`~linflex.frequency.Loop`
        or an open loop :func:`~linflex.stability.stability_margins` takes. ``x`` is a float
        when ``bounds`` is one pair, else an array.
    bounds : (float, float) or sequence of them
        Lower and upper bound of each parameter (in its units, e.g. rad/s for a bandwidth).
    requirements : Requirements or mapping
        Bounds on ``gain_margin_db`` [dB], ``phase_margin_deg`` [deg], ``delay_margin_s`` [s],
        ``disk_margin`` [-], global or per loop (``loops``), as in a scene's ``[requirements]``.
    objective : callable, optional
        ``objective(x)`` to minimize. Default for one parameter: maximize it (the largest
        bandwidth that passes). Required for several parameters.
    x0 : array_like, optional
        Start for several parameters (default the middle of the bounds).
    xtol : float, optional
        Relative tolerance of the tuned parameter [-] (one parameter), 1e-4 by default.
    max_evaluations : int, optional
        Cap on margin computations.

    Returns
    -------
    TuneResult
        The parameters, the active requirement, every check there, the margins.

    Raises
    ------
    ModelError
        For a requirement that is not a margin, bad bounds, or several parameters without an
        objective.
    ConvergenceError
        When no parameter in the bounds passes the requirements (the message gives the best
        slack found and where).

    Notes
    -----
    One parameter: the requirement slack is evaluated on 17 log-spaced points of the bounds
    (linear when the lower bound is not positive), the largest passing point is bracketed with
    its failing neighbour and the boundary found by Brent's method (the slack may jump where a
    crossing appears or a loop goes unstable; the bracket still closes on the jump). Several
    parameters: ``scipy.optimize.minimize`` with COBYLA (derivative-free, as margins are not
    smooth in the parameters) and the slack as an inequality constraint.

    Examples
    --------
    The largest bandwidth of a PD on a 50 kg m^2 rigid body with a 0.2 s delay margin (the
    closed form is PM / (d wc / w) = 3.68556 rad/s):

    >>> import numpy as np
    >>> from linflex import LinearSystem
    >>> from linflex.design import pid_from_bandwidth
    >>> from linflex.frequency import Loop
    >>> plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / 50]], [[1, 0], [0, 1]])
    >>> def loop(w):
    ...     g = pid_from_bandwidth([50.0], w)
    ...     gain = LinearSystem(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[g.kp[0], g.kd[0]]])
    ...     return Loop(plant, gain,
    ...                 sensors=["y0", "y1"], actuators=["u0"])
    >>> r = tune(loop, (0.05, 20.0), {"delay_margin_s": 0.2}, xtol=1e-6)
    >>> round(float(r.x[0]), 3), r.active.quantity
    (3.686, 'delay_margin_s')
    """
    start = time.perf_counter()
    req = _requirements(requirements)
    try:
        b = np.atleast_2d(np.asarray(bounds, dtype=float))
    except (TypeError, ValueError):
        b = np.zeros((1, 0))
    if b.ndim != 2 or b.shape[1] != 2 or not np.all(np.isfinite(b)) or np.any(b[:, 0] >= b[:, 1]):
        raise ModelError(f"bounds must be (low, high) pairs of numbers with low < high, got {bounds!r}")
    if not (isinstance(xtol, (int, float, np.number)) and np.isfinite(xtol) and 0 < xtol < 1):
        raise ModelError(f"xtol must be a relative tolerance in (0, 1), got {xtol!r}")
    if x0 is not None and np.shape(x0) != (b.shape[0],) and b.shape[0] > 1:
        raise ModelError(f"x0 must hold one value per parameter, shape ({b.shape[0]},), got shape {np.shape(x0)}")
    scalar = np.ndim(bounds) == 1
    cache: dict[tuple, tuple[float, tuple[Check, ...], StabilityMargins | None]] = {}
    failures: list[LinflexError] = []

    def evaluate(x) -> tuple[float, tuple[Check, ...], StabilityMargins | None]:
        key = tuple(np.round(np.atleast_1d(x), 15))
        if key not in cache:
            if len(cache) >= max_evaluations:
                raise ConvergenceError(f"tune: {max_evaluations} margin computations without converging")
            try:
                margins = stability_margins(build(float(key[0]) if scalar else np.array(key)))
            except LinflexError as err:
                if isinstance(err, ConvergenceError):
                    raise
                failures.append(err)
                cache[key] = (_UNSTABLE, (), None)
                return cache[key]
            checks = tuple(c for c in margin_checks(margins, req) if c.required is not None)
            slack = min((_relative(c) for c in checks), default=np.inf)
            cache[key] = (slack, checks, margins)
        return cache[key]

    if scalar:
        x = _tune_one(lambda v: evaluate(v)[0], b[0], objective, xtol)
    else:
        if objective is None:
            raise ModelError("tune: several parameters need an objective to minimize")
        x = _tune_many(lambda v: evaluate(v)[0], b, objective, x0)
    slack, checks, margins = evaluate(x)
    if len(failures) == len(cache):   # not one margin computed: build(x) or its loop is at fault, not the bounds
        raise ModelError(f"tune: the margins of build(x) could not be computed at any of the {len(cache)} "
                         f"parameters tried (x = {[float(v) for v in next(iter(cache))]} first): {failures[0]}") from failures[0]
    if margins is None or slack < 0:
        best = max(cache.items(), key=lambda item: item[1][0])
        raise ConvergenceError(f"tune: no parameters within the bounds pass the requirements; the best relative "
                               f"slack is {best[1][0]:.3g} at x = {[float(v) for v in best[0]]}")
    active = min(checks, key=_relative) if checks else None
    at_bound = scalar and objective is None and x >= b[0, 1]
    if at_bound and active is not None and _relative(active) > 10 * xtol:
        active = None
    return TuneResult(frozen_array(np.atleast_1d(x)), True, active, float(slack), checks, margins, len(cache),
                      time.perf_counter() - start)


def _tune_one(slack: Callable[[float], float], bounds, objective, xtol: float) -> float:
    lo, hi = float(bounds[0]), float(bounds[1])
    grid = np.geomspace(lo, hi, 17) if lo > 0 else np.linspace(lo, hi, 17)
    values = np.array([slack(v) for v in grid])
    passing = np.flatnonzero(values >= 0)
    if passing.size == 0:
        return float(grid[int(np.argmax(values))])
    if objective is not None:   # the best objective among the passing points, then refined between neighbours
        k = int(min(passing, key=lambda i: objective(grid[i])))
        left, right = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
        res = scipy.optimize.minimize_scalar(lambda v: objective(v) if slack(v) >= 0 else np.inf,
                                             bounds=(left, right), method="bounded", options={"xatol": xtol * abs(grid[k])})
        return float(res.x) if res.fun <= objective(grid[k]) else float(grid[k])
    k = int(passing[-1])
    if k == grid.size - 1:
        return hi
    a, c = grid[k], grid[k + 1]
    root = scipy.optimize.brentq(slack, a, c, xtol=xtol * abs(a), rtol=max(xtol, 4 * np.finfo(float).eps))
    # Brent's root can sit on the failing side of a jump: step back inside the bracket until it passes.
    while slack(root) < 0 and root > a:
        root = max(a, root - xtol * abs(a))
    return float(root)


def _tune_many(slack: Callable, bounds: NDArray, objective: Callable, x0) -> NDArray[np.float64]:
    start = bounds.mean(axis=1) if x0 is None else np.asarray(x0, dtype=float)
    res = scipy.optimize.minimize(objective, start, method="COBYLA", bounds=[tuple(b) for b in bounds],
                                  constraints=[{"type": "ineq", "fun": slack}], options={"maxiter": 150})
    return np.asarray(res.x, dtype=float)

