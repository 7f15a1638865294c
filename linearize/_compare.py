"""The linear model against the nonlinear one: same operating point, same input, both responses and their difference.

The linearization predicts deviations from the operating point; the nonlinear simulation starts
at the operating point (plus the same initial deviation) under the operating input plus the same
input deviation, held over each sample interval in both runs. Their outputs' difference is of
second order in the amplitude for a smooth model: halving the input quarters it, which
:class:`LinearComparison` lets a user check at a glance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from linflex.simulation import TimeResponse, forced_response, simulate
from linflex.system import LinearSystem, ModelError, NonlinearModel, OperatingPoint, PlotHandle, plot_axes, real_vector

from ._linearization import linearize
from ._result import Linearization

__all__ = ["LinearComparison", "compare_linear_nonlinear"]


@dataclass(frozen=True)
class LinearComparison:
    """Result of :func:`compare_linear_nonlinear`.

    Attributes
    ----------
    time : ndarray, shape (n_time,)
        Sample times [s].
    outputs : tuple of str
        The outputs compared.
    linear : TimeResponse
        The linear model's response: deviations from the operating point (with the response to
        the affine term ``linearization.residual`` about a non-equilibrium point).
    nonlinear : TimeResponse
        The nonlinear simulation (absolute values).
    deviation : ndarray, shape (n_time, n_outputs)
        The nonlinear outputs minus their operating values ``y_op`` [output units].
    difference : ndarray, shape (n_time, n_outputs)
        ``deviation`` minus the linear outputs [output units]: the linearization's error along
        this run (plus the integrator's, at its tolerance).
    relative_difference : ndarray, shape (n_outputs,)
        ``max |difference| / max |deviation|`` per output [-] (nan for an output that does not move).
    linearization : Linearization
        The linear model used.
    """

    time: NDArray[np.float64]
    outputs: tuple[str, ...]
    linear: TimeResponse
    nonlinear: TimeResponse
    deviation: NDArray[np.float64]
    difference: NDArray[np.float64]
    relative_difference: NDArray[np.float64]
    linearization: Linearization

    def plot(self, outputs=None, *, ax=None) -> PlotHandle:
        """Each output: the nonlinear deviation and the linear response, and their difference.

        Parameters
        ----------
        outputs : sequence of str, optional
            Which outputs (default all, at most 6 by default: the ones that move most).
        ax : sequence of matplotlib Axes, optional
            ``2 * len(outputs)`` axes (response, difference per output); a new figure otherwise.

        Returns
        -------
        PlotHandle
            The figure, its axes (response then difference, per output) and lines (nonlinear,
            linear, difference per output).
        """
        if outputs is None:
            order = np.argsort(-np.nan_to_num(np.abs(self.deviation).max(axis=0), nan=0.0))
            names = [self.outputs[i] for i in order[:6]]
        else:
            names = [outputs] if isinstance(outputs, str) else list(outputs)
        columns = []
        for name in names:
            if name not in self.outputs:
                raise ModelError(f"plot: unknown output {name!r}; compared: {', '.join(self.outputs)}")
            columns.append(self.outputs.index(name))
        fig, axes = plot_axes(ax, 2 * len(columns), figsize=(7.0, 2.2 * len(columns) + 0.6))
        lines = []
        for k, (name, j) in enumerate(zip(names, columns)):
            top, bottom = axes[2 * k], axes[2 * k + 1]
            lines += top.plot(self.time, self.deviation[:, j], label="nonlinear (minus operating value)")
            lines += top.plot(self.time, self.linear.y[:, j], "--", label="linear")
            top.set_ylabel(name)
            lines += bottom.plot(self.time, self.difference[:, j], color="tab:red")
            bottom.set_ylabel(f"{name}: difference")
            if k == 0:
                top.legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("time [s]")
        fig.suptitle("Linear against nonlinear, same operating point and input")
        return PlotHandle(fig, tuple(axes), tuple(lines), self)


def compare_linear_nonlinear(model: NonlinearModel, timepts: ArrayLike, inputs: Any = None, *,
                             op: OperatingPoint | None = None, x0_offset=None,
                             linearization: Linearization | None = None, method: str = "auto",
                             rtol: float = 1e-10, atol: float = 1e-12) -> LinearComparison:
    """Run the linearized and the nonlinear model from the same operating point with the same input.

    Parameters
    ----------
    model : NonlinearModel
        A compiled scene or any nonlinear model.
    timepts : array_like
        Increasing sample times [s], at least two.
    inputs : None, array_like, callable or mapping, optional
        The input deviation from ``op.u`` [input units], in any form :func:`linflex.simulate`
        takes; it is sampled at ``timepts`` and held over each interval in both runs.
    op : OperatingPoint, optional
        Default the point of ``linearization`` when one is given, else ``model.x0`` with zero
        inputs (it must be an equilibrium, or the linearization's ``allow_non_equilibrium``
        rules apply).
    x0_offset : array_like or mapping, optional
        Initial state deviation [state units]: all states, or a mapping of state names to
        values; zero by default.
    linearization : Linearization, optional
        A linearization of ``model`` at ``op`` (the same point) to reuse (one about a
        non-equilibrium point, ``allow_non_equilibrium=True``: the linear run includes its
        affine term ``residual``); computed by
        :func:`~linflex.linearize.linearize` (default method) otherwise.
    method, rtol, atol
        The nonlinear simulation's integrator and tolerances (see :func:`linflex.simulate`);
        tight by default so that the difference is the linearization's.

    Returns
    -------
    LinearComparison
        Both responses, the deviation and the difference, with a ``plot()``.

    Raises
    ------
    ModelError
        If the linear model's states, inputs or outputs are not the model's (by name),
        ``linearization`` was made at another point than ``op``, or an offset names an unknown
        state.
    ShapeError
        If ``x0_offset`` has the wrong length or non-finite values.

    Examples
    --------
    A pendulum ``theta'' = -sin(theta) + u`` pushed by a small torque: the difference is of
    third order in the amplitude here (``sin`` has no quadratic term).

    >>> import numpy as np
    >>> from linflex import NonlinearModel, OperatingPoint
    >>> pend = NonlinearModel(lambda x, u, t: np.array([x[1], -np.sin(x[0]) + u[0]]),
    ...                       lambda x, u, t: x[:1], states=["theta", "omega"], inputs=["torque"])
    >>> c = compare_linear_nonlinear(pend, np.linspace(0, 5, 101), [0.01], op=OperatingPoint([0, 0], [0]),
    ...                              method="scipy-DOP853")
    >>> bool(c.relative_difference[0] < 1e-4)
    True
    """
    if linearization is not None and not isinstance(linearization, Linearization):
        raise ModelError(f"linearization must be a Linearization (from linearize), got {type(linearization).__name__}")
    if op is None and linearization is not None:
        op = linearization.op
    if op is None:
        x_op = getattr(model, "x0", None)
        if x_op is None:
            raise ModelError("compare_linear_nonlinear: give op for a model without x0")
        op = OperatingPoint(x_op, np.zeros(model.n_inputs))
    if linearization is not None and linearization.op != op:
        raise ModelError(
            f"compare_linear_nonlinear: linearization was made at x = {linearization.op.x.tolist()[:6]}, "
            f"u = {linearization.op.u.tolist()[:6]}, t = {linearization.op.t} but op is x = {op.x.tolist()[:6]}, "
            f"u = {op.u.tolist()[:6]}, t = {op.t}; pass the linearization at op, or omit op"
        )
    lin = linearization if linearization is not None else linearize(model, op)
    sys = lin.sys
    for what in ("states", "inputs", "outputs"):
        mine, theirs = tuple(getattr(sys, what)), tuple(getattr(model, what))
        if mine != theirs:
            raise ModelError(f"compare_linear_nonlinear: the linear model's {what} are not the model's "
                             f"({list(mine)[:6]} against {list(theirs)[:6]}); pass the linearization of this model")
    dx0 = np.zeros(sys.n_states)
    if isinstance(x0_offset, Mapping):
        for name, value in x0_offset.items():
            if name not in sys.states:
                raise ModelError(f"x0_offset: unknown state {name!r}; states: {', '.join(sys.states[:12])}")
            dx0[sys.states.index(name)] = real_vector(value, f"x0_offset[{name!r}]", 1)[0]
    elif x0_offset is not None:
        dx0 = real_vector(x0_offset, "x0_offset", sys.n_states)
    linear = forced_response(sys, timepts, inputs, dx0)
    if not lin.is_equilibrium:
        # about a non-equilibrium point the linear model is dx' = A dx + B du + f(op): the affine
        # term's response (a constant unit input through f(op), from rest) is added
        f0 = np.asarray(lin.residual, dtype=float)[:, None]
        drift = forced_response(LinearSystem(sys.A, f0, sys.C, np.zeros((sys.n_outputs, 1))), linear.time, [1.0])
        linear = dataclasses.replace(linear, x=linear.x + drift.x, y=linear.y + drift.y)
    du = linear.u                                  # the input deviation as held samples
    nonlinear = simulate(model, linear.time, np.asarray(op.x, dtype=float) + dx0,
                         np.asarray(op.u, dtype=float)[None, :] + du, method=method, rtol=rtol, atol=atol)
    deviation = nonlinear.y - np.asarray(lin.y_op, dtype=float)[None, :]
    difference = deviation - linear.y
    scale = np.abs(deviation).max(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        relative = np.where(scale > 0, np.abs(difference).max(axis=0) / scale, np.nan)
    return LinearComparison(linear.time, sys.outputs, linear, nonlinear, deviation, difference, relative, lin)
