"""LQR and LQG on a linearized plant, through python-control, with signal names kept.

python-control solves the Riccati equations (``control.lqr``, ``control.lqe``: SLICOT or
scipy); this module keeps linflex's names on the gains and returns the LQG compensator as a
:class:`~linflex.LinearSystem` ready for :class:`~linflex.frequency.Loop`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex.system import LinearSystem, ModelError, as_linear_system, frozen_array

__all__ = ["LQGDesign", "LQRDesign", "lqg", "lqr"]


@dataclass(frozen=True)
class LQRDesign:
    """A state-feedback gain ``u = -K x`` (result of :func:`lqr`).

    Attributes
    ----------
    K : ndarray, shape (n_inputs, n_states)
        The gain, in input units per state unit.
    inputs, states : tuple of str
        Names of its rows and columns.
    closed_loop_poles : ndarray of complex
        Eigenvalues of ``A - B K`` [1/s].
    riccati : ndarray, shape (n_states, n_states)
        The stabilizing solution ``X`` of the control Riccati equation.
    residual : float
        Relative residual of the Riccati equation at ``X`` [-] (a posteriori check of the solve).
    """

    K: NDArray[np.float64]
    inputs: tuple[str, ...]
    states: tuple[str, ...]
    closed_loop_poles: NDArray[np.complex128]
    riccati: NDArray[np.float64]
    residual: float


@dataclass(frozen=True)
class LQGDesign:
    """An LQG compensator (result of :func:`lqg`).

    Attributes
    ----------
    controller : LinearSystem
        From the plant's measured outputs to its inputs, in :class:`~linflex.frequency.Loop`'s
        negative-feedback sign (``u = -controller y``): states ``xhat.<state>``.
    regulator : LQRDesign
        The state-feedback part.
    L : ndarray, shape (n_states, n_outputs)
        The Kalman gain.
    estimator_poles : ndarray of complex
        Eigenvalues of ``A - L C`` [1/s].
    """

    controller: LinearSystem
    regulator: LQRDesign
    L: NDArray[np.float64]
    estimator_poles: NDArray[np.complex128]


def _weight(value, n: int, name: str, *, definite: bool = False) -> NDArray[np.float64]:
    """A symmetric ``(n, n)`` weight from a matrix, ``n`` diagonal entries or one scalar, checked positive
    semidefinite (``definite``: positive definite)."""
    try:
        W = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be a finite ({n}, {n}) matrix or {n} diagonal entries, got {value!r}") from None
    if W.ndim == 0 or (W.ndim == 1 and W.size in (1, n)):
        W = np.diag(np.broadcast_to(W, (n,)).astype(float))
    if W.shape != (n, n) or not np.all(np.isfinite(W)):
        raise ModelError(f"{name} must be a finite ({n}, {n}) matrix or {n} diagonal entries, got "
                         f"{'non-finite entries' if W.shape == (n, n) else f'shape {W.shape}'}")
    scale = max(np.linalg.norm(W), 1e-300)
    if np.linalg.norm(W - W.T) > 1e-12 * scale:
        raise ModelError(f"{name} must be symmetric")
    low = float(np.linalg.eigvalsh(0.5 * (W + W.T)).min(initial=np.inf))
    if low <= 0 if definite else low < -1e-12 * scale:
        raise ModelError(f"{name} must be positive {'definite' if definite else 'semidefinite'}; its smallest "
                         f"eigenvalue is {low:.3g}")
    return W


def lqr(plant, Q, R) -> LQRDesign:
    """The linear-quadratic regulator of ``plant``: ``u = -K x`` minimizing ``int x'Qx + u'Ru dt``.

    Parameters
    ----------
    plant : LinearSystem or any system :func:`linflex.as_linear_system` takes
        Continuous time.
    Q : array_like
        State weight, ``(n, n)`` or its diagonal [1/state unit^2].
    R : array_like
        Input weight, ``(m, m)`` or its diagonal [1/input unit^2], positive definite.

    Returns
    -------
    LQRDesign
        The gain with the plant's input and state names, the closed-loop poles and the
        Riccati residual.

    Raises
    ------
    ModelError
        For weights of the wrong shape, or when python-control finds no stabilizing solution
        (an uncontrollable unstable or undamped mode); its message is kept.

    Examples
    --------
    A double integrator with unit weights: ``K = [1, sqrt(3)]`` (closed form).

    >>> from linflex import LinearSystem
    >>> d = lqr(LinearSystem([[0, 1], [0, 0]], [[0], [1]]), [1.0, 1.0], 1.0)
    >>> d.K.round(12).tolist()
    [[1.0, 1.732050807569]]
    """
    import control

    sys = as_linear_system(plant, "plant")
    if sys.n_states == 0 or sys.n_inputs == 0:
        raise ModelError(f"lqr: the plant has {sys.n_states} states and {sys.n_inputs} inputs: there is nothing to "
                         "regulate or nothing to regulate with")
    Qm, Rm = _weight(Q, sys.n_states, "Q"), _weight(R, sys.n_inputs, "R", definite=True)
    try:
        K, X, poles = control.lqr(sys.A, sys.B, Qm, Rm)
    except Exception as err:  # python-control raises ControlArgument, ValueError or a SLICOT error
        raise ModelError(f"lqr: python-control found no stabilizing solution: {err}") from err
    K, X = np.asarray(K, dtype=float), np.asarray(X, dtype=float)
    res = sys.A.T @ X + X @ sys.A - X @ sys.B @ np.linalg.solve(Rm, sys.B.T @ X) + Qm
    residual = float(np.linalg.norm(res) / max(np.linalg.norm(Qm) + 2 * np.linalg.norm(sys.A) * np.linalg.norm(X), 1e-300))
    return LQRDesign(frozen_array(K), sys.inputs, sys.states, frozen_array(poles, dtype=complex),
                     frozen_array(X), residual)


def lqg(plant, Q, R, process_noise, measurement_noise) -> LQGDesign:
    """An LQG compensator: :func:`lqr` gains on a Kalman estimate of the state.

    ``xhat' = A xhat + B u + L (y - C xhat - D u)``, ``u = -K xhat``, with the Kalman gain ``L``
    for process noise entering through ``B`` (intensity ``process_noise``) and measurement noise
    ``measurement_noise`` (python-control's ``lqe``).

    Parameters
    ----------
    plant : LinearSystem or any system :func:`linflex.as_linear_system` takes
        Continuous time, from inputs ``u`` to measurements ``y``.
    Q, R : array_like
        Regulator weights, as in :func:`lqr`.
    process_noise : array_like
        Intensity of the noise on the inputs, ``(m, m)`` or diagonal [input unit^2 s].
    measurement_noise : array_like
        Intensity of the measurement noise, ``(p, p)`` or diagonal [output unit^2 s].

    Returns
    -------
    LQGDesign
        The compensator in :class:`~linflex.frequency.Loop` sign (inputs: the plant's outputs;
        outputs: the plant's inputs), ready for ``Loop(plant, design.controller, sensors=...,
        actuators=...)``.

    Raises
    ------
    ModelError
        As :func:`lqr`, and when no stabilizing estimator exists.

    Examples
    --------
    A double integrator measured in position:

    >>> from linflex import LinearSystem
    >>> d = lqg(LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]]), [1.0, 1.0], 1.0, 1.0, 1.0)
    >>> d.controller.inputs, d.controller.outputs, d.controller.n_states
    (('y0',), ('u0',), 2)
    """
    import control

    sys = as_linear_system(plant, "plant")
    regulator = lqr(sys, Q, R)
    W = _weight(process_noise, sys.n_inputs, "process_noise")
    if sys.n_outputs == 0:
        raise ModelError("lqg: the plant has no outputs: there is nothing to estimate the state from")
    V = _weight(measurement_noise, sys.n_outputs, "measurement_noise", definite=True)
    try:
        L, _, est_poles = control.lqe(sys.A, sys.B, sys.C, W, V)
    except Exception as err:  # python-control raises several types
        raise ModelError(f"lqg: python-control found no stabilizing estimator: {err}") from err
    L = np.asarray(L, dtype=float)
    K = regulator.K
    Ac = sys.A - sys.B @ K - L @ sys.C + L @ sys.D @ K
    # u = -K xhat: in Loop's sign (plant input = -beta) the controller outputs beta = K xhat.
    controller = LinearSystem(Ac, L, K, np.zeros((sys.n_inputs, sys.n_outputs)),
                              states=[f"xhat.{s}" for s in sys.states], inputs=sys.outputs, outputs=sys.inputs)
    return LQGDesign(controller, regulator, frozen_array(L), frozen_array(est_poles, dtype=complex))
