"""The closed loop of a stability analysis: the sensitivity evaluator of a loop, with its
closed-loop poles and (single loops) the open loop's zeros, for :mod:`._margins`."""

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
    I_D = np.eye(m) + sys.D
    if not np.all(np.isfinite(I_D)) or np.linalg.cond(I_D) > 1e14:
        raise ModelError(f"loop {channel}: I + D is singular, the feedback loop is not well posed")
    Minv = np.linalg.inv(I_D)
    if m > 1:
        return TransferEvaluator(LinearSystem(sys.A - sys.B @ Minv @ sys.C, sys.B @ Minv, -Minv @ sys.C, Minv),
                                 rtol=_RTOL_S)
    ev_L = axis_evaluator(sys, rtol=_RTOL_L)
    modal = getattr(ev_L, "modal", None)
    if (sys.n_states >= MODAL_ROOTS_MIN and not sys.is_discrete and not sys.has_delay
            and isinstance(modal, _Modal) and modal.k <= BLOCK_DENSE_MAX):
        # the closed-loop poles and the zeros as roots of the modal sums, O(n^2) after L's modal
        # form, when every closed-loop pole is found (checked); a dense Hessenberg form otherwise
        cl_poles = closed_loop_poles(modal, sys)
        if cl_poles is not None:
            return _LoopSensitivity(ev_L, cl_poles, modal_roots(modal, sys, 0.0))
    try:
        cl_poles, zs = loop_roots(sys.A, sys.B, sys.C, sys.D)
    except (np.linalg.LinAlgError, ValueError, ArithmeticError, ConvergenceError):
        cl_poles, zs = scipy.linalg.eigvals(sys.A - sys.B @ Minv @ sys.C, check_finite=False), None
    return _LoopSensitivity(ev_L, cl_poles, zs)


class _LoopSensitivity(SensitivityEvaluator):
    """``S = 1 / (1 + L)`` from the evaluator of ``L``, with the closed-loop poles and the open
    loop's zeros (``zeros``, grid hints; None if not computed) of one Hessenberg form
    (:func:`linflex.frequency._zeros.loop_roots`)."""

    def __init__(self, ev_L, poles, zeros) -> None:
        super().__init__(ev_L, poles)
        self.zeros = zeros


#: A cluster of closed-loop eigenvalues on the axis whose residue ``C P B`` (``P`` its spectral
#: projector) has singular values below ``HIDDEN_RTOL |C| |B| |P|`` holds that many fewer modes
#: the loop sees and drives: about the square root of the unit roundoff, the accuracy of the
#: eigenvectors of a repeated eigenvalue.
HIDDEN_RTOL = 1.5e-8
#: Closed-loop eigenvalues on the axis within this relative distance [-] form one cluster (a
#: repeated eigenvalue: two identical arrays' modes, one not seen and one not driven).
CLUSTER_RTOL = 1e-8


def loop_poles(sys: LinearSystem, cl_poles, spec) -> tuple[np.ndarray, np.ndarray]:
    """The closed-loop poles that belong to the loop, and the hidden ones left out.

    A mode of the open loop ``sys`` that the loop does not drive (uncontrollable) or does not
    see (unobservable) is an eigenvalue of every closed loop, whatever the gain: the
    antisymmetric bending of two identical arrays under a hub's attitude control, undamped in
    an undamped structural model. It is in no transfer function of the loop, so margins and
    the Nyquist count cannot act on it: closed-loop poles on the axis (to rounding by ``spec``'s
    policy, away from the origin) that are such modes are left out. A cluster of ``k`` equal
    eigenvalues ``lambda`` with spectral projector ``P`` adds ``C P B / (s - lambda)`` to the
    closed loop's transfer functions, so ``k - rank(C P B)`` of its modes are hidden
    (:data:`HIDDEN_RTOL`; a mode not seen and one not driven at the same frequency are both
    hidden, though neither eigenvector LAPACK returns for the pair need be).

    Parameters
    ----------
    sys : LinearSystem
        The square open loop (continuous, undelayed; any other is returned as it is).
    cl_poles : array_like of complex
        Its closed-loop poles [1/s], ``A - B (I + D)^-1 C``'s eigenvalues.
    spec : Spectrum
        The open loop's classified spectrum (for the rounding tolerances).

    Returns
    -------
    poles, hidden : ndarray of complex
        The loop's closed-loop poles, and the hidden ones on the axis [1/s].
    """
    cl = np.asarray(cl_poles, dtype=complex)
    axis = ((np.abs(cl.real) <= spec.rounding_tol(cl)) & (cl.imag != 0)
            & (np.abs(cl) > 10 * spec.rigid_radius))
    if not np.any(axis) or sys.is_discrete or sys.has_delay or sys.n_states == 0:
        return cl, cl[:0]
    from scipy.optimize import linear_sum_assignment

    Minv = np.linalg.inv(np.eye(sys.n_inputs) + sys.D)
    lam, W, V = scipy.linalg.eig(sys.A - sys.B @ Minv @ sys.C, left=True, right=True)
    idx = np.flatnonzero(axis)
    _, match = linear_sum_assignment(np.abs(cl[idx, None] - lam[None, :]))
    lam, V, W = lam[match], V[:, match], W[:, match]
    nCB = float(np.linalg.norm(sys.C, 2)) * float(np.linalg.norm(sys.B, 2))
    order = np.argsort(lam.imag, kind="stable")
    breaks = np.flatnonzero(np.abs(np.diff(lam[order])) > CLUSTER_RTOL * np.abs(lam[order][1:])) + 1
    hidden = np.zeros(cl.size, dtype=bool)
    for members in np.split(order, breaks):
        Vc, Wc = V[:, members], W[:, members]
        try:
            WV = np.linalg.solve(Wc.conj().T @ Vc, Wc.conj().T)     # (W^H V)^-1 W^H: P = V WV
        except np.linalg.LinAlgError:
            continue   # a defective cluster (a Jordan block): not a set of hidden modes
        residue = sys.C @ Vc @ (WV @ sys.B)
        size = float(np.linalg.norm(Vc, 2) * np.linalg.norm(WV, 2))
        rank = int(np.count_nonzero(np.linalg.svd(residue, compute_uv=False) > HIDDEN_RTOL * nCB * size))
        hidden[idx[members[:members.size - rank]]] = True
    return cl[~hidden], cl[hidden]


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
