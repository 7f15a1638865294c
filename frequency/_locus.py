"""Root locus: closed-loop eigenvalues over a scalar loop gain, tracked branch by branch.

The pieces: :mod:`._locus_result` (the :class:`RootLocus` result), :mod:`._locus_sums` (``L``
and its derivatives from the modal form), :mod:`._locus_tracker` (the Newton/Halley
continuation), :mod:`._locus_breakaway` (double roots), :mod:`._locus_steps` (prediction,
matching, displacement test) and :mod:`._locus_stepper` (the gain steps and their state).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from linflex import LinearSystem, ModelError, ShapeError, pade
from linflex.system import check_positive

from ._checks import checked_system
from ._locus_breakaway import _breakaways
from ._locus_polish import polish_roots
from ._locus_result import RootLocus
from ._locus_stepper import _ClosedLoop, _Stepper
from ._locus_sums import _NoContinuation
from ._locus_tracker import _NewtonTracker
from ._loop import Loop
from ._spectrum import rigid_mask, system_scale
from ._zeros import _invariant_zeros

__all__ = ["RootLocus", "root_locus"]


def root_locus(loop, gains: ArrayLike | None = None, *, k_max: float | None = None, negative: bool = False,
               max_displacement: float = 0.25, breakaway: bool | None = None, max_steps: int = 5000,
               continuation: bool = True) -> RootLocus:
    """Closed-loop eigenvalues over the loop gain, with adaptive steps and branch matching.

    Parameters
    ----------
    loop : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`Loop` (its loop transfer function at the plant input ``L = K P`` is used) or a
        square loop transfer function ``L``; the closed loop is ``u = -k y`` (negative feedback).
    gains : array_like, optional
        The gains to report [-] (inverse units of ``L``). Between consecutive given gains the tracker takes hidden substeps
        so that branch matching stays reliable. Default: an adaptive sequence from 0 to
        ``k_max`` (or ``-k_max`` with ``negative=True``).
    k_max : float, optional
        End of the automatic sequence [-], positive (the complementary locus is
        ``negative=True``); default ``1e4 / |L(s0)|`` at a point ``s0`` of the
        spectral scale (far into the asymptotic regime).
    negative : bool, optional
        Trace the complementary locus (``k <= 0``) instead.
    max_displacement : float, optional
        Largest root movement per step relative to the local root spacing [-]: steps are halved
        above it and doubled below a quarter of it.
    breakaway : bool, optional
        Locate all breakaway/break-in points from a pencil eigenproblem of twice the order and
        put their gains in the sequence (SISO). Default: for an automatic sequence of a SISO
        loop up to 200 states. Otherwise the continuation locates the breakaways it meets
        (Newton on ``L'(s) = 0`` next to the roots that jumped) and reports those.
    max_steps : int, optional
        Limit on gain steps (eigenvalue solves plus continuation steps).
    continuation : bool, optional
        For SISO loops, move the roots from one gain to the next by Newton's method on
        ``1/L(s) + k`` in the modal form (O(n^2) per step) and fall back to a dense eigenvalue
        solve only when a step fails its checks (convergence, distinct roots, trace of the
        closed-loop matrix). ``False`` uses a dense eigenvalue solve at every gain.

    Returns
    -------
    RootLocus

    Raises
    ------
    ModelError
        If ``L`` is not square, ``max_displacement``, ``max_steps`` or ``k_max`` is out of
        range, ``I + k D`` is singular at a gain of the sequence (the loop is ill-posed there),
        or the dense eigenvalue solver does not converge at a gain.
    ShapeError
        If ``gains`` is not a 1-D array of finite numbers, or the loop has no input or no
        output.

    Notes
    -----
    Reference notes section 10.2: each trial gain ``k_new = k rho`` is accepted when the
    matched roots moved less than ``max_displacement`` times their distance to the nearest
    other root (plus a floor at the root's own modulus), else ``rho`` is square-rooted; the
    matching is a linear assignment (``scipy.optimize.linear_sum_assignment``) on distances.
    Breakaway points are the zeros of ``L'(s)`` (a pencil of the cascade ``(sI - A)^-2``, no
    polynomial) where ``k = -1/L(s)`` is real with the sign of the locus.

    The continuation (SISO) evaluates ``L`` and its first three derivatives as Cauchy sums over
    the poles of the modal form (O(n) per root; a rigid-body multiple pole folded in as exact
    partial fractions; a loop whose partial fractions would cancel, such as an integrator chain
    split by round-off, by its Schur form up to 20 states, else by dense solves), predicts each root along its branch (quintic Hermite from the last two
    gains with ``ds/dk = L^2 / L'`` and ``d2s/dk2``), corrects it by Halley's method and stops
    a root as soon as the error estimate of its last update, ``|K| |delta|^3``, is at round-off
    (most roots after one evaluation per gain), iterates only one root of each conjugate pair,
    and, for given gains, corrects up to 8 consecutive gains in one vectorized pass; every gain
    is checked as a single step would be (each root converged to round-off, all roots
    distinct, their sum equal to the trace, the displacement test), and the gains from the
    first failure on are taken one at a time. A double root at ``k_b`` (from the pencil, or
    located by Newton on ``L'(s) = 0`` next to the roots that jumped) is crossed in one step
    once its two roots are isolated near it: they are exempt from the displacement test (the
    others pass it and keep their identities; which of the two continues which branch is a
    convention, offsets turned by 90 degrees) and guessed from the local expansion
    ``s_b +- sqrt(2 L^2 (k - k_b) / L'')``; until then the substeps approach ``k_b``
    geometrically. Likewise the root through infinity at ``1 + k d = 0`` is exempt near that
    gain and guessed from the trace. A failed step is retried once from half the step (two
    roots passing close by); after three failures in a row, dense solves take over for a
    number of gains that doubles with each further failure. The first step leaves the poles
    from first-order guesses ``lambda - k r``. The zeros of a SISO loop come from one standard
    eigenproblem (``A - b c / d``, or the zero dynamics at relative degree up to 3).

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> L = LinearSystem([[0, 1], [0, -2]], [[0], [1]], [[1, 0]])     # 1/(s (s + 2))
    >>> rl = root_locus(L)
    >>> rl.breakaway_points.real.round(6).tolist(), rl.breakaway_gains.round(6).tolist()
    ([-1.0], [1.0])
    """
    t0 = time.perf_counter()
    L = loop.open_loop() if isinstance(loop, Loop) else checked_system(loop, "loop", discrete=True, delay=True)
    if L.has_delay:  # a sampled loop's z^-k are exact states; a continuous delay needs an approximation
        if not L.is_discrete:
            raise ModelError("loop: a root locus needs a rational loop; take linflex.pade(loop, order) "
                             "(a rational approximation with its error reported) of the delayed loop first")
        L = pade(L, 1).sys
    if L.n_inputs != L.n_outputs:
        raise ModelError(f"the loop transfer function must be square, got {L.n_outputs} outputs and {L.n_inputs} inputs")
    max_displacement = check_positive(max_displacement, "max_displacement")
    if not max_displacement < 1:
        raise ModelError(f"max_displacement must be in (0, 1), got {max_displacement!r}")
    if not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise ModelError(f"max_steps must be a positive integer, got {max_steps!r}")
    g = None if gains is None else _validated_gains(gains)
    n, siso = L.n_states, L.shape == (1, 1)
    cl = _ClosedLoop(L)
    tracker = _tracker(L) if siso and n and continuation else None
    if tracker is not None:
        # the modal form's eigenvalues of (balanced) A: the open-loop solve is done there
        poles = tracker.poles
        cl.count += 1
    else:
        poles = cl.eig(0.0)
    zeros = (_siso_zeros(L, tracker) if siso else _invariant_zeros(L.A, L.B, L.C, L.D)) if n else np.zeros(0, dtype=complex)
    sign = -1.0 if negative else 1.0
    if breakaway is None:
        breakaway = siso and n <= 200 and gains is None
    bpts, bgains = (_breakaways(L, sign, tracker) if (breakaway and siso and n)
                    else (np.zeros(0, complex), np.zeros(0)))
    scale = max(float(np.max(np.abs(poles))) if n else 0.0, 1e-12)
    stepper = _Stepper(L, cl, tracker, bpts, bgains, s_ref=1e-3 * max(scale, 1.0),
                       max_displacement=max_displacement, max_steps=max_steps)
    if g is not None:
        out_g, rows = g, stepper.given(g, poles)
    else:
        k_max = _default_k_max(L, poles, zeros) if k_max is None else check_positive(k_max, "k_max")
        if not np.isfinite(k_max) or k_max <= 0:
            raise ModelError(f"k_max must be a positive finite gain, got {k_max!r}")
        forced = sorted(abs(b) for b in bgains if abs(b) < k_max)
        out_g, rows = stepper.automatic(k_max, sign, poles, forced)
    roots = np.array(rows, dtype=complex).reshape(len(out_g), n)
    st = stepper.state
    # the rows of dense eigenvalue solves (and the open loop) are polished; the continuation's
    # are converged already and only estimated (its modal sums, O(n) per root)
    dense = np.array([tracker is None or id(r) in st.dense for r in rows], dtype=bool)
    roots, estimate = polish_roots(L, np.asarray(out_g, dtype=float), roots, dense, tracker)
    if len(st.hint_gains) > len(bgains):
        # the breakaways the continuation located itself
        order = np.argsort(np.abs(st.hint_gains), kind="stable")
        bpts, bgains = st.hint_points[order], st.hint_gains[order]
    arrays = [np.asarray(out_g, dtype=float), roots, poles, zeros, bpts, bgains, estimate]
    for a in arrays:
        a.setflags(write=False)
    return RootLocus(
        gains=arrays[0], roots=roots, open_loop_poles=poles, open_loop_zeros=zeros, breakaway_points=bpts,
        breakaway_gains=bgains, max_step_displacement=st.worst, n_evaluations=cl.count,
        n_continuation_steps=st.n_newton, n_rejected_continuation_steps=st.rejected,
        seconds=time.perf_counter() - t0, error_estimate=arrays[6], dt=L.dt,
    )


def _validated_gains(gains: ArrayLike) -> NDArray[np.float64]:
    """The requested gains, sorted; :class:`ShapeError` unless a 1-D array of finite numbers."""
    try:
        g = np.array(gains, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"gains must be an array of real numbers: {err}") from err
    if g.ndim != 1 or g.size == 0:
        raise ShapeError(f"gains must be a non-empty 1-D array, got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ShapeError(f"gains[{int(np.argmax(~np.isfinite(g)))}] is not finite")
    return np.sort(g)


def _tracker(L: LinearSystem) -> _NewtonTracker | None:
    """The continuation for a SISO loop, or ``None`` when its modal form does not allow it."""
    try:
        return _NewtonTracker(L)
    except (_NoContinuation, np.linalg.LinAlgError, ValueError):
        return None


def _default_k_max(L: LinearSystem, poles: NDArray, zeros: NDArray) -> float:
    """``1e4 / |L(s0)|`` at a point ``s0`` of the spectral scale (off the real axis), far into
    the asymptotic regime; ``1e4`` if ``L(s0)`` vanishes or cannot be evaluated there.

    The spectral scale is the largest modulus of the zeros and the poles that are not rigid-body
    poles at the origin (the spectrum policy's :func:`~._spectrum.rigid_mask`); where there is
    none (a double integrator ``k / s^2``), the loop's own frequency scale
    (:func:`~._spectrum.system_scale`: its closed loop's), so the locus reaches the frequencies at
    which the loop acts and not a rounding-level neighbourhood of the origin."""
    n = L.n_states
    scale = system_scale(L.A, L.B, L.C, L.D) if n else 1.0
    rigid, _ = rigid_mask(poles, L.A, None, scale)
    z = np.concatenate([poles[~rigid], zeros])
    zmax = float(np.max(np.abs(z))) if z.size else 0.0
    s0 = max(zmax if zmax > 0 else scale, 1e-6) * (0.73 + 0.41j)
    try:
        G = L.D + L.C @ np.linalg.solve(s0 * np.eye(n) - L.A, L.B) if n else L.D
    except np.linalg.LinAlgError:
        return 1e4   # s0 is a pole (the chance of hitting one exactly is nil, but not zero)
    gmag = float(np.max(np.abs(G)))
    return 1e4 / gmag if gmag > 0 and np.isfinite(gmag) else 1e4


def _siso_zeros(L: LinearSystem, tracker=None) -> NDArray[np.complex128]:
    """Zeros of a SISO loop from one standard eigenvalue problem of order ``n - rho``.

    With a block-wise modal form (``tracker.modal``): the Aberth iteration on its sums
    (:mod:`._modal_roots`, O(n^2)) when all ``n - rho`` roots converge.

    ``d != 0``: the eigenvalues of ``A - b c / d``. ``d = 0``, relative degree ``rho``
    (``c A^j b = 0`` for ``j < rho - 1``, to round-off): the zero dynamics (output held at
    zero) ``N = (I - b (c A^(rho-1) b)^-1 c A^(rho-1)) A`` on its invariant subspace, the
    kernel of ``[c; c A; ...; c A^(rho-1)]`` (orthonormal basis ``Q`` from a QR
    factorization), so the zeros are ``eig(Q^T N Q)``. Used only when the rank-one term is
    at most 1e3 times ``A`` in norm, which keeps the errors at round-off of ``A``; otherwise,
    or for ``rho > 3``, the pencil reduction of :func:`_invariant_zeros`."""
    if tracker is not None and tracker.modal is not None:
        from ._modal_roots import _relative_degree, modal_roots

        rho = _relative_degree(L.A, L.B[:, 0], L.C[0], float(L.D[0, 0]))
        roots = modal_roots(tracker.modal, L, 0.0)
        if rho is not None and roots.size == L.n_states - rho:
            return roots
    A, b, c, d = L.A, L.B[:, 0], L.C[0], float(L.D[0, 0])
    n = A.shape[0]
    normA = max(float(np.linalg.norm(A, 1)), 1e-300)
    nb = float(np.linalg.norm(b))
    if d != 0:
        if nb * float(np.linalg.norm(c)) <= 1e3 * normA * abs(d):
            return scipy.linalg.eigvals(A - np.outer(b, c) / d, check_finite=False)
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    rows = [c]
    for _ in range(min(3, n)):
        g = float(rows[-1] @ b)
        if abs(g) > 1e-12 * nb * float(np.linalg.norm(rows[-1])):
            rho = len(rows)
            break
        rows.append(rows[-1] @ A)
    else:
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    cA = rows[-1] @ A
    if rho >= n or nb * float(np.linalg.norm(cA)) > 1e3 * normA * abs(g):
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    Q = np.linalg.qr(np.array(rows).T, mode="complete")[0][:, rho:]
    AQ = A @ Q
    N = Q.T @ AQ - np.outer(Q.T @ b, (cA @ Q) / g)
    return scipy.linalg.eigvals(N, check_finite=False)


