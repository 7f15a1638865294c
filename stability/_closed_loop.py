"""The closed loop of a stability analysis: the sensitivity evaluator of a loop, with its
closed-loop poles and (single loops) the open loop's zeros, and one channel of a multivariable
loop with the others closed (loop-at-a-time), for :mod:`._margins`."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import scipy.linalg

from linflex import ConvergenceError, LinearSystem, ModelError
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._modal_forms import BLOCK_DENSE_MAX, _Modal
from linflex.frequency._modal_roots import closed_loop_poles, modal_roots
from linflex.frequency._sampled import SensitivityEvaluator, axis_evaluator
from linflex.frequency._zeros import loop_roots

#: Modal rounding [-] above which a point of L is re-evaluated by a backward-stable solve: the
#: crossings are refined to 1e-12 in log w, which needs L to about 1e-10.
_RTOL_L = 1e-10
#: The same for the sensitivity S, which only sets the disk margins (reported to 4 digits); S
#: vanishes at low frequency on a loop with integrators, where its modal sum cancels.
_RTOL_S = 1e-8
#: From this order on, a single loop's closed-loop poles and zeros are the roots of its modal sums
#: (:func:`~linflex.frequency._modal_roots.closed_loop_poles`, O(n^2)) rather than the eigenvalues
#: of a Hessenberg form (O(n^3), about as much again as the loop's eigendecomposition).
MODAL_ROOTS_MIN = 200


def _closed_loop(sys: LinearSystem, channel: str):
    """An evaluator of the sensitivity ``S = (I + L)^-1`` whose ``poles`` are the closed-loop poles,
    the eigenvalues of ``A - B (I + D)^-1 C``.

    A single loop's ``S = 1 / (1 + L)`` is evaluated from the evaluator of ``L``
    (:class:`~linflex.frequency._sampled.SensitivityEvaluator`, relative error that of ``L``
    times ``|L| |S|``), so one modal form serves both and the closed-loop poles are eigenvalues
    only (no eigenvectors), from the Hessenberg form that also gives the zeros of ``L``
    (``evaluator.zeros``), or from order ``MODAL_ROOTS_MIN`` on as the roots of the modal sums of
    ``L``'s own modal form; ``evaluator.ev_L`` is that evaluator of ``L``. A multivariable ``S``
    is evaluated from its own realization (``|L| |S|`` would be the condition number of ``L``).
    """
    m = sys.n_inputs
    M = _feedback_gain(sys, channel)
    if m > 1:
        return TransferEvaluator(sensitivity_system(sys, channel), rtol=_RTOL_S)
    ev_L = axis_evaluator(sys, rtol=_RTOL_L)
    # a sampled or delayed loop's S is not the rational function of a realization in s
    loop = sys if isinstance(ev_L, TransferEvaluator) else None
    modal = getattr(ev_L, "modal", None)
    if (sys.n_states >= MODAL_ROOTS_MIN and not sys.is_discrete and not sys.has_delay
            and isinstance(modal, _Modal) and modal.k <= BLOCK_DENSE_MAX):
        # the closed-loop poles and the zeros as roots of the modal sums, O(n^2) after L's modal
        # form, when every closed-loop pole is found (checked); a dense Hessenberg form otherwise
        cl_poles = closed_loop_poles(modal, sys)
        if cl_poles is not None:
            return _LoopSensitivity(ev_L, cl_poles, modal_roots(modal, sys, 0.0), loop)
    try:
        cl_poles, zs = loop_roots(sys.A, sys.B, sys.C, sys.D)
    except (np.linalg.LinAlgError, ValueError, ArithmeticError, ConvergenceError):
        cl_poles, zs = scipy.linalg.eigvals(sys.A - sys.B @ M @ sys.C, check_finite=False), None
    return _LoopSensitivity(ev_L, cl_poles, zs, loop)


def _feedback_gain(sys: LinearSystem, channel: str) -> np.ndarray:
    """``(I + D)^-1`` of the loop ``sys``; ``ModelError`` naming ``channel`` when ``I + D`` is
    singular (the feedback loop is not well posed)."""
    I_D = np.eye(sys.n_inputs) + sys.D
    if not np.all(np.isfinite(I_D)) or np.linalg.cond(I_D) > 1e14:
        raise ModelError(f"loop {channel}: I + D is singular, the feedback loop is not well posed")
    return np.linalg.inv(I_D)


def sensitivity_system(sys: LinearSystem, channel: str = "L") -> LinearSystem:
    """A realization of ``S = (I + L)^-1`` of the loop ``sys`` (``L``, negative feedback)::

        A - B M C,  B M,  -M C,  M        M = (I + D)^-1

    Raises ``ModelError`` naming ``channel`` when ``I + D`` is singular."""
    M = _feedback_gain(sys, channel)
    return LinearSystem(sys.A - sys.B @ M @ sys.C, sys.B @ M, -M @ sys.C, M)


def _close_others(sys: LinearSystem, i: int) -> LinearSystem:
    """Loop ``i`` of a square ``L`` broken with the other loops closed by ``u_o = -y_o``.

    ::

        x' = (A - B_o M C_o) x + (B_i - B_o M D_oi) u_i        M = (I + D_oo)^-1
        y_i = (C_i - D_io M C_o) x + (D_ii - D_io M D_oi) u_i
    """
    m = sys.n_inputs
    o = [j for j in range(m) if j != i]
    A, B, C, D = (np.asarray(x) for x in (sys.A, sys.B, sys.C, sys.D))
    if not o:
        return sys
    Doo = D[np.ix_(o, o)]
    try:
        M = np.linalg.inv(np.eye(len(o)) + Doo)
    except np.linalg.LinAlgError as err:
        raise ModelError(f"closing the loops other than {sys.inputs[i]!r}: I + D is singular") from err
    Bo, Co = B[:, o], C[o, :]
    Ai = A - Bo @ M @ Co
    Bi = B[:, [i]] - Bo @ M @ D[np.ix_(o, [i])]
    Ci = C[[i], :] - D[np.ix_([i], o)] @ M @ Co
    Di = D[np.ix_([i], [i])] - D[np.ix_([i], o)] @ M @ D[np.ix_(o, [i])]
    return LinearSystem(Ai, Bi, Ci, Di, states=sys.states, inputs=[sys.inputs[i]], outputs=[sys.outputs[i]])


class _LoopSensitivity(SensitivityEvaluator):
    """``S = 1 / (1 + L)`` from the evaluator of ``L``, with the closed-loop poles and the open
    loop's zeros (``zeros``, grid hints; None if not computed) of one Hessenberg form
    (:func:`linflex.frequency._zeros.loop_roots`). ``loop``: the continuous, undelayed ``L``
    whose :meth:`realization` gives ``S``'s, or None (a sampled or delayed loop)."""

    def __init__(self, ev_L, poles, zeros, loop: LinearSystem | None) -> None:
        super().__init__(ev_L, poles)
        self.zeros = zeros
        self._loop = loop

    def realization(self, max_states: int) -> LinearSystem | None:
        """The state-space system of ``S`` (:func:`sensitivity_system`, formed when asked: the
        disk margin's Hamiltonian iteration on small loops) when ``L`` is dense with at most
        ``max_states`` states, else None."""
        loop = self._loop
        if loop is None or loop.is_sparse or loop.n_states > max_states:
            return None
        return sensitivity_system(loop)


def _estimate_at(ev, omega) -> tuple[float, float]:
    """Largest a-posteriori relative error [-] of ``ev`` at ``omega`` [rad/s], and where."""
    omega = np.asarray(omega, dtype=float)
    omega = omega[np.isfinite(omega) & (omega > 0)]
    if omega.size == 0:
        return 0.0, np.nan
    ev(omega)
    est = np.where(np.isnan(ev.last_error), np.inf, ev.last_error)
    j = int(np.argmax(est))
    return float(est[j]), float(omega[j])


@contextlib.contextmanager
def _rechecked_to(ev, rtol: float) -> Iterator[None]:
    """Within the block, ``ev`` re-checks its points to ``rtol`` [-] where that is looser than its
    own tolerance (a delayed loop's evaluator has none: left as it is). The points it evaluates
    stay in its memo at that accuracy."""
    strict = getattr(ev, "rtol", None)
    if strict is not None:
        ev.rtol = max(strict, rtol)
    try:
        yield
    finally:
        if strict is not None:
            ev.rtol = strict
