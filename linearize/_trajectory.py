"""Linearization along a simulated nominal motion, and frozen-time modal tables."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from linflex import ModelError, NonlinearModel, OperatingPoint, ShapeError, TimeResponse
from linflex.system import check_positive, real_array

from ._linearization import Method, linearize
from ._result import Linearization

__all__ = ["FrozenTimeModes", "TrajectoryLinearization", "linearize_along"]


@dataclass(frozen=True)
class FrozenTimeModes:
    """Eigenvalues of the frozen-time linear models along a trajectory, tracked in time.

    Column ``j`` of every array follows one eigenvalue branch through time (consecutive
    instants are matched by minimum total distance), so a column plotted against ``times``
    shows how one mode's frequency and damping evolve, for example during a spin-up.

    Attributes
    ----------
    times : ndarray, shape (n_times,)
        [s].
    eigenvalues : ndarray, shape (n_times, n_states), complex
        [1/s].
    frequencies : ndarray, shape (n_times, n_states)
        Natural frequencies ``|lambda|`` [rad/s].
    damping : ndarray, shape (n_times, n_states)
        Damping ratios ``-Re(lambda) / |lambda|`` [-] (NaN where ``lambda = 0``).

    Notes
    -----
    Frozen-time eigenvalues describe a time-varying system only while its coefficients change
    slowly compared with the modes themselves; they are not a stability proof.
    """

    times: NDArray[np.float64]
    eigenvalues: NDArray[np.complex128]
    frequencies: NDArray[np.float64]
    damping: NDArray[np.float64]


@dataclass(frozen=True)
class TrajectoryLinearization:
    """Linearizations at instants of a nominal motion (a linear time-varying model).

    Attributes
    ----------
    times : ndarray, shape (n_times,)
        The instants [s].
    linearizations : tuple of Linearization
        One per instant, each in deviation variables about the nominal state and input at that
        instant; ``residual`` is the nominal motion's state rate there (the affine term).
    seconds : float
        Wall time of all linearizations [s].
    """

    times: NDArray[np.float64]
    linearizations: tuple[Linearization, ...]
    seconds: float

    @property
    def max_relative_error_estimate(self) -> float:
        """The worst of the linearizations' own relative error estimates [-]."""
        return max(lin.max_relative_error_estimate for lin in self.linearizations)

    def frozen_time_modes(self) -> FrozenTimeModes:
        """Frozen-time eigenvalues, tracked from instant to instant.

        Returns
        -------
        FrozenTimeModes
            Eigenvalues [1/s], natural frequencies [rad/s] and damping ratios [-] at ``times``
            [s], one column per tracked branch.
        """
        eig = [np.linalg.eigvals(lin.sys.A) for lin in self.linearizations]
        tracked = [np.sort_complex(eig[0])]
        for current in eig[1:]:
            previous = tracked[-1]
            cost = np.abs(previous[:, None] - current[None, :])
            rows, cols = scipy.optimize.linear_sum_assignment(cost)
            ordered = np.empty_like(current)
            ordered[rows] = current[cols]
            tracked.append(ordered)
        eigenvalues = np.array(tracked)
        frequencies = np.abs(eigenvalues)
        with np.errstate(divide="ignore", invalid="ignore"):
            damping = np.where(frequencies > 0, -eigenvalues.real / frequencies, np.nan)
        return FrozenTimeModes(self.times, eigenvalues, frequencies, damping)


def linearize_along(
    model: NonlinearModel,
    response,
    times: ArrayLike | None = None,
    *,
    method: Method = "auto",
    digits: float | None = None,
    scale: ArrayLike | None = None,
    time_tol: float = 1e-9,
) -> TrajectoryLinearization:
    """Linearize a model at instants of a simulated nominal motion.

    Parameters
    ----------
    model : NonlinearModel
        The model that produced ``response`` (its state and input names must match).
    response : TimeResponse
        The nominal motion, from :func:`linflex.simulate`.
    times : array_like, optional
        Instants [s]; each must be a sample time of ``response`` (within ``time_tol``), so that
        no interpolation error enters the nominal state. Default: every sample.
    method : str
        As for :func:`linearize`.
    digits : float, optional
        As for :func:`linearize` (methods ``"perturbation"`` and ``"central"``); default: the
        method's.
    scale : array_like, optional
        As for :func:`linearize`.
    time_tol : float
        Largest distance [s] between a requested instant and a sample time.

    Returns
    -------
    TrajectoryLinearization

    Raises
    ------
    ModelError
        When ``response`` is not a TimeResponse, names differ between the model and the
        response, an instant is not a sample time (the message gives the nearest one), or
        ``time_tol`` is not a finite non-negative number.
    ShapeError
        When ``times`` is not a non-empty vector of finite instants.

    Examples
    --------
    A pendulum released from 0.5 rad: ``A[1, 0] = -9.81 cos(theta)`` along the swing.

    >>> import casadi as ca
    >>> import numpy as np
    >>> from linflex import NonlinearModel, simulate
    >>> from linflex.linearize import linearize_along
    >>> x, u = ca.SX.sym("x", 2), ca.SX.sym("u", 1)
    >>> pend = NonlinearModel.from_casadi(ca.vertcat(x[1], -9.81 * ca.sin(x[0]) + u[0]), x, u,
    ...                                   states=["theta", "omega"], inputs=["torque"])
    >>> nominal = simulate(pend, np.linspace(0.0, 1.0, 5), [0.5, 0.0])
    >>> along = linearize_along(pend, nominal, [0.0, 1.0])
    >>> round(float(along.linearizations[0].sys.A[1, 0]), 4), round(-9.81 * float(np.cos(0.5)), 4)
    (-8.6091, -8.6091)
    """
    start = time.perf_counter()
    if not isinstance(response, TimeResponse):
        raise ModelError(f"response must be a TimeResponse (from linflex.simulate), got {type(response).__name__}")
    if tuple(response.states) != model.states or tuple(response.inputs) != model.inputs:
        raise ModelError("response: its state and input names differ from the model's; simulate this model")
    time_tol = check_positive(time_tol, "time_tol", allow_zero=True)
    sample_times = np.asarray(response.time, dtype=float)
    if times is None:
        wanted = sample_times
    else:
        wanted = np.atleast_1d(real_array(times, "times", "vector"))
        if wanted.ndim != 1:
            raise ShapeError(f"times must be a vector of instants [s], got an array of shape {wanted.shape}")
        if not np.all(np.isfinite(wanted)):
            i = int(np.flatnonzero(~np.isfinite(wanted))[0])
            raise ShapeError(f"times[{i}] is not finite ({wanted[i]})")
        if wanted.size == 0:
            raise ShapeError("times is empty; give at least one instant [s] (or None: every sample)")
    indices = []
    for t in wanted:
        i = int(np.argmin(np.abs(sample_times - t)))
        if abs(sample_times[i] - t) > time_tol:
            raise ModelError(f"times: {t} s is not a sample time of the response (nearest {sample_times[i]} s); "
                             "simulate with this instant among timepts")
        indices.append(i)
    linearizations = tuple(
        linearize(model, OperatingPoint(response.x[i], response.u[i], sample_times[i]), method=method,
                  scale=scale, allow_non_equilibrium=True, **({} if digits is None else {"digits": digits}))
        for i in indices
    )
    return TrajectoryLinearization(sample_times[indices], linearizations, time.perf_counter() - start)
