"""The result of a linearization: the linear system with its accuracy and its cost."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem, NonlinearModel, OperatingPoint, SecondOrderSystem

__all__ = ["JacobianBlocks", "Linearization", "LinearizationProblem", "MethodResult"]


@dataclass(frozen=True)
class LinearizationProblem:
    """What a linearization method receives: the model and the checked operating point.

    Attributes
    ----------
    model : NonlinearModel
        The model.
    x : ndarray, shape (n_states,)
        The state [state units].
    u : ndarray, shape (n_inputs,)
        The inputs [input units].
    p : ndarray, shape (n_params,)
        The parameter values [parameter units].
    t : float
        Time [s].
    scale : ndarray, shape (n_states + n_inputs,)
        Characteristic magnitude of each state then each input (zeros when not given) [their
        units].
    """

    model: NonlinearModel
    x: NDArray[np.float64]
    u: NDArray[np.float64]
    p: NDArray[np.float64]
    t: float
    scale: NDArray[np.float64]


@dataclass(frozen=True)
class MethodResult:
    """What a linearization method returns to :func:`linearize` (numpy arrays).

    Attributes
    ----------
    f0 : ndarray, shape (n_states,)
        State derivative at the point [state units/s].
    y0 : ndarray, shape (n_outputs,)
        Outputs at the point [output units].
    J : ndarray, shape (n_states + n_outputs, n_states + n_inputs)
        The stacked Jacobian ``[[A, B], [C, D]]``.
    error : ndarray, shape like ``J``
        Per-entry absolute error estimate (zeros for an exact method) [entry units].
    converged : ndarray of bool, shape like ``J``
        Per-entry convergence flags.
    n_evaluations : int
        Calls of the model (or of its compiled derivative function).
    setup_seconds : float
        Time spent building derivative graphs [s].
    second_order : SecondOrderSystem or None
        The second-order form, when the method provides it.
    stiffness, damping : Mapping of str to ndarray, or None
        ``second_order.K`` and ``.D`` by origin, when the method provides them.
    """

    f0: NDArray[np.float64]
    y0: NDArray[np.float64]
    J: NDArray[np.float64]
    error: NDArray[np.float64]
    converged: NDArray[np.bool_]
    n_evaluations: int
    setup_seconds: float = 0.0
    second_order: SecondOrderSystem | None = None
    stiffness: Mapping | None = None
    damping: Mapping | None = None

    @classmethod
    def exact(cls, f0, y0, A, B, C, D, *, setup_seconds: float = 0.0, **second_order) -> MethodResult:
        """The result of an exact method (error estimate zero, every entry converged, one call).

        Parameters
        ----------
        f0, y0 : ndarray
            State derivative [state units/s] and outputs [output units] at the point.
        A, B, C, D : ndarray
            The Jacobians.
        setup_seconds : float
            Time spent building derivative graphs [s].
        **second_order
            ``second_order``, ``stiffness`` and ``damping`` when the method provides them.

        Returns
        -------
        MethodResult
        """
        J = np.block([[A, B], [C, D]])
        return cls(np.asarray(f0, float).reshape(-1), np.asarray(y0, float).reshape(-1), J, np.zeros_like(J),
                   np.ones(J.shape, dtype=bool), 1, setup_seconds, **second_order)


@dataclass(frozen=True)
class JacobianBlocks:
    """Per-entry data laid out like the four Jacobians ``A, B, C, D`` (error bounds or flags).

    Attributes
    ----------
    A, B, C, D : ndarray
        Read-only blocks of shapes ``(n_states, n_states)``, ``(n_states, n_inputs)``,
        ``(n_outputs, n_states)``, ``(n_outputs, n_inputs)``; error bounds carry the units of the
        matching Jacobian entries (state units/s per state or input unit, output units per
        state or input unit).
    """

    A: NDArray
    B: NDArray
    C: NDArray
    D: NDArray

    @classmethod
    def split(cls, J: NDArray, n_states: int, n_outputs: int, n_inputs: int) -> JacobianBlocks:
        """Split a stacked ``[[A, B], [C, D]]`` array into its four read-only blocks.

        ::

                     n_states   n_inputs
                   +----------+--------+
          n_states |    A     |   B    |
                   +----------+--------+
         n_outputs |    C     |   D    |
                   +----------+--------+

        Parameters
        ----------
        J : ndarray, shape (n_states + n_outputs, n_states + n_inputs)
            The stacked array (units of the Jacobian entries, or flags).
        n_states, n_outputs, n_inputs : int
            Block sizes.

        Returns
        -------
        JacobianBlocks
            Read-only copies of the four blocks.
        """
        n = n_states
        blocks = (J[:n, :n], J[:n, n:], J[n:, :n], J[n:, n:])
        out = []
        for block in blocks:
            block = np.array(block)
            block.setflags(write=False)
            out.append(block)
        return cls(*out)

    def stacked(self) -> NDArray:
        """The blocks back as one ``[[A, B], [C, D]]`` array.

        Returns
        -------
        ndarray, shape (n_states + n_outputs, n_states + n_inputs)
            A new array, in the units of the blocks.
        """
        return np.block([[self.A, self.B], [self.C, self.D]])


@dataclass(frozen=True)
class Linearization:
    """A linear model about an operating point, with its error estimate and its cost.

    The linear system is in deviation variables: with ``dx = x - op.x``, ``du = u - op.u`` and
    ``dy = y - y_op``, it reads ``dx' = A dx + B du + residual`` and ``dy = C dx + D du``;
    ``residual`` is zero (to the equilibrium tolerance) at an equilibrium.

    Attributes
    ----------
    sys : LinearSystem
        ``A, B, C, D`` with the model's state, input and output names.
    op : OperatingPoint
        The point linearized about.
    residual : ndarray, shape (n_states,)
        ``f(op.x, op.u, op.t)``, the affine term, in state units per second.
    y_op : ndarray, shape (n_outputs,)
        ``h(op.x, op.u, op.t)``, the outputs at the operating point [output units].
    is_equilibrium : bool
        Whether the scaled residual is below the equilibrium tolerance.
    error_estimate : JacobianBlocks
        Per-entry estimate of the absolute error of each Jacobian entry, in that entry's units
        (zeros for ``autodiff``, the round-off level for ``complex-step``).
    converged : JacobianBlocks
        Per-entry flags: whether the entry met the method's accuracy test.
    n_evaluations : int
        Calls of the model (``f`` and ``h`` together count once); for ``autodiff`` the calls of
        the compiled Jacobian function, plus the real probes of a graph with non-smooth operations.
    seconds : float
        Wall time of the linearization [s], ``setup_seconds`` included.
    setup_seconds : float
        Wall time spent building derivative graphs [s] (``autodiff``, ``kane``; 0 when reused).
    method : str
        The method's name.
    settings : Mapping
        The options the method ran with (its registered options, defaults filled in), and
        ``equilibrium_tol`` and ``allow_non_equilibrium``.
    second_order : SecondOrderSystem or None
        None unless the method provides it; of the registered methods only ``"kane"`` does
        (the others see ``f`` and ``h`` only, not the coordinates and speeds a second-order
        form needs). ``M d'' + D d' + K d = B [du; d_aux]`` in the degrees of freedom ``d``
        (the coordinates, each quaternion replaced by its small rotation ``<joint>.rx/ry/rz``
        [rad] in body axes, and ``<speed>.integral`` for a speed no coordinate follows, such
        as a wheel's), with the outputs; its inputs are the model's inputs and then its
        auxiliary states (controller states), through which they couple. Its eigenvalues
        are those of ``sys`` (without a quaternion's norm mode, with a zero per integral).
        About a motion that is not steady (along a trajectory) it is the frozen-time form:
        the kinematical matrices are taken at the instant, their rates left out.
    stiffness, damping : Mapping of str to ndarray, or None
        None unless the method provides them (``"kane"`` only, from the origins of the loads
        in the compiled scene): ``K`` and ``D`` of ``second_order`` split by origin, summing
        to them: ``"inertia"`` (centrifugal stiffness, Coriolis and gyroscopic damping),
        ``"geometric_stiffness"``, ``"structure"`` (modal stiffness and damping), each
        effect's name (``"joint_springs"``, ``"gravity"``, ``"gravity_gradient"``, ...),
        ``"actuators"`` (with the ``control`` effect: the controller's stiffness and damping),
        ``"disturbances"``, ``"constraints"`` (loop joints) and ``"kinematics"`` for damping
        from the kinematical equations. Units are those of ``second_order.K`` and ``.D``:
        [generalized force per dof unit] and [generalized force per dof rate], e.g. [N m/rad]
        and [N m s/rad] for a rotation, [N/m] and [N s/m] for a displacement.
    """

    sys: LinearSystem
    op: OperatingPoint
    residual: NDArray[np.float64]
    y_op: NDArray[np.float64]
    is_equilibrium: bool
    error_estimate: JacobianBlocks
    converged: JacobianBlocks
    n_evaluations: int
    seconds: float
    setup_seconds: float
    method: str
    settings: Mapping
    second_order: SecondOrderSystem | None = None
    stiffness: Mapping | None = None
    damping: Mapping | None = None

    @property
    def max_relative_error_estimate(self) -> float:
        """The largest estimated error relative to its row's largest Jacobian entry [-].

        Each row of ``[[A, B], [C, D]]`` is one equation; normalizing by the row's infinity
        norm keeps entries that are exactly zero meaningful.
        """
        J = np.block([[self.sys.A, self.sys.B], [self.sys.C, self.sys.D]])
        err = self.error_estimate.stacked()
        if J.size == 0:
            return 0.0
        row_norm = np.max(np.abs(J), axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(row_norm > 0, err / row_norm, np.where(err > 0, np.inf, 0.0))
        return float(np.max(rel))

    @property
    def all_converged(self) -> bool:
        """True when every entry met its accuracy test."""
        return bool(np.all(self.converged.stacked()))

    def __repr__(self) -> str:
        return (
            f"Linearization(method={self.method!r}, n_states={self.sys.n_states}, "
            f"inputs={self.sys.n_inputs}, outputs={self.sys.n_outputs}, "
            f"max_relative_error_estimate={self.max_relative_error_estimate:.2e}, "
            f"n_evaluations={self.n_evaluations}, seconds={self.seconds:.3g})"
        )

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        return html_summary(f"Linearization ({self.method})", [
            ("method", self.method), ("states", self.sys.states), ("inputs", self.sys.inputs),
            ("outputs", self.sys.outputs), ("is_equilibrium", self.is_equilibrium),
            ("max_relative_error_estimate", self.max_relative_error_estimate),
            ("all_converged", self.all_converged), ("n_evaluations", self.n_evaluations),
            ("seconds", self.seconds), ("second_order", self.second_order is not None),
            ("stiffness_origins", tuple(self.stiffness) if self.stiffness else None)])
