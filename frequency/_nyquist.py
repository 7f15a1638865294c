"""Nyquist contour, encirclement count and the Nyquist criterion, for SISO and MIMO loops."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, pade
from linflex.system import check_positive

from ._checks import checked_system
from ._loop import Loop
from ._response import _check_positive_int, _features, pole_zero_grid
from ._sampled import axis_evaluator, engine_system
from ._spectrum import EPS, classify, indentations, joint_balance, rigid_mask

__all__ = ["NyquistResponse", "nyquist_response", "count_encirclements"]


@dataclass(frozen=True)
class NyquistResponse:
    """The loop evaluated along the Nyquist contour, with the Nyquist criterion applied.

    Attributes
    ----------
    s : numpy.ndarray of complex
        Laplace variable [1/s] along the closed contour, traversed clockwise: up the imaginary axis from ``-j omega_max`` to
        ``+j omega_max`` with half-circles of radius ``indent_radius`` to the right of every
        imaginary-axis pole of ``L``, then back along a half-circle of radius ``omega_max``
        through the right half-plane.
    values : numpy.ndarray of complex
        ``L(s)`` [-] for a SISO loop; ``det(I + L(s)) - 1`` for a MIMO loop, so that in both cases
        the critical point is ``-1`` and ``1 + values`` is the return difference (determinant).
    on_axis : numpy.ndarray of bool
        True where ``s`` lies on the imaginary axis (the frequency-response part).
    encirclements : int
        ``N``: clockwise encirclements of ``-1`` by ``values`` (of the origin by the return
        difference).
    open_loop_unstable_poles : int
        ``P``: poles of ``L`` with positive real part (imaginary-axis poles are indented around
        and not counted).
    closed_loop_unstable_poles : int
        ``Z = N + P``, the Nyquist criterion.
    indentations : numpy.ndarray of complex
        Centres of the indentations (imaginary-axis poles of ``L``) [1/s].
    indent_radius : float
        Radius of the indentations [rad/s].
    omega_max : float
        Radius of the large half-circle [rad/s].
    min_distance : float
        Smallest ``|1 + values|`` [-] along the contour: how close the contour came to a closed-loop
        pole (a small value makes the count fragile).
    seconds : float
        Wall time of the contour evaluation and count [s].
    """

    s: NDArray[np.complex128]
    values: NDArray[np.complex128]
    on_axis: NDArray[np.bool_]
    encirclements: int
    open_loop_unstable_poles: int
    closed_loop_unstable_poles: int
    indentations: NDArray[np.complex128]
    indent_radius: float
    omega_max: float
    min_distance: float
    seconds: float

    def _display_fields(self):
        return [("encirclements", self.encirclements), ("open_loop_unstable_poles", self.open_loop_unstable_poles),
                ("closed_loop_unstable_poles", self.closed_loop_unstable_poles),
                ("min_distance", self.min_distance), ("n_points", self.s.size), ("omega_max [rad/s]", self.omega_max),
                ("indentations", self.indentations.size), ("indent_radius [rad/s]", self.indent_radius),
                ("seconds", self.seconds)]

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("NyquistResponse", self._display_fields())

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        return html_summary("NyquistResponse", self._display_fields())

    def plot(self, **kwargs):
        """Nyquist plot of this response: see :func:`linflex.frequency.nyquist_plot`.

        Parameters
        ----------
        **kwargs
            Keyword arguments of :func:`~linflex.frequency.nyquist_plot` (``ax``, ...).

        Returns
        -------
        PlotHandle
            As :func:`~linflex.frequency.nyquist_plot`.
        """
        # drawing depends on results, never the reverse (_draw imports no computing module)
        from ._draw import draw_nyquist

        if "max_magnitude" in kwargs:
            kwargs["max_magnitude"] = check_positive(kwargs["max_magnitude"], "max_magnitude")
        return draw_nyquist(self, **kwargs)


def _arc(center: complex, radius: float, theta0: float, theta1: float, n: int) -> NDArray[np.complex128]:
    th = np.linspace(theta0, theta1, n)
    return center + radius * np.exp(1j * th)


# ----------------------------------------------------------------------------------------------
# The one encirclement count (used by nyquist_response and by linflex.stability)

#: The phase of det(I + L) is tracked until no step along the contour exceeds this [deg].
_MAX_STEP_DEG = 15.0


#: Relative accuracy [-] below which det(I + L) computed from the entries of ``I + L`` is
#: replaced by the determinant identity (see :func:`_return_difference`).
_DET_RTOL = 1e-8


def _return_difference(ev, s: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """``det(I + L(s))`` [-] at the points ``s`` [1/s].

    From the entries of ``I + L`` where that is accurate. Near a multiple pole of a MIMO loop
    (a 1/s^4 chain seen by both channels) ``L`` is nearly of rank one with huge entries and their
    determinant cancels: its rounding error ``m eps prod_i |row_i(I + L)|`` (Hadamard) can exceed
    the value. At such points the determinant identity ``det(I + L(s)) = det(I + D) det(s I -
    A_cl) / det(s I - A)``, ``A_cl = A - B (I + D)^-1 C``, is evaluated instead (LU factors of the
    two balanced pencils: backward stable, no cancellation between entries of ``L``).
    """
    G = ev.at(s)
    m = G.shape[1]
    M = np.eye(m)[None] + G
    f = np.linalg.det(M)
    sys = getattr(ev, "sys", None)
    if m == 1 or sys is None or not sys.n_states:
        return f
    with np.errstate(over="ignore", invalid="ignore"):
        bound = m * EPS * np.prod(np.linalg.norm(M, axis=2), axis=1)
        bad = ~(np.abs(f) > bound / _DET_RTOL)
    if not np.any(bad):
        return f
    A, B, C, D = (np.asarray(x, dtype=float) for x in (sys.A, sys.B, sys.C, sys.D))
    t = joint_balance(A, B, C)
    A, B, C = A * (1.0 / t)[:, None] * t[None, :], B * (1.0 / t)[:, None], C * t[None, :]
    ID = np.eye(m) + D
    Acl = A - B @ np.linalg.solve(ID, C)
    sb = np.asarray(s, dtype=complex)[bad]
    eye = np.eye(A.shape[0])[None]
    s1, l1 = np.linalg.slogdet(sb[:, None, None] * eye - Acl[None])
    s0, l0 = np.linalg.slogdet(sb[:, None, None] * eye - A[None])
    with np.errstate(divide="ignore", invalid="ignore"):
        f = f.astype(complex)
        f[bad] = np.linalg.det(ID) * (s1 / s0) * np.exp(np.clip(l1 - l0, -700.0, 700.0))
    return f


def _phase_change(ev, path, t0: float, t1: float, t_init: NDArray[np.float64], max_points: int) -> float | None:
    """Unwrapped phase change of det(I + L(path(t))) for t from t0 to t1 (None if unresolved)."""
    t = np.unique(np.concatenate([[t0, t1], t_init[(t_init > t0) & (t_init < t1)]]))
    v = _return_difference(ev, path(t))
    for _ in range(40):
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.degrees(np.abs(np.angle(v[1:] / v[:-1])))
        bad = ~(d <= _MAX_STEP_DEG)
        bad &= (t[1:] - t[:-1]) > 1e-13 * np.maximum(np.abs(t[1:]), 1e-300)
        if not bad.any():
            break
        if t.size + bad.sum() > max_points:
            return None
        i = np.flatnonzero(bad)
        mid = 0.5 * (t[i] + t[i + 1])
        t = np.insert(t, i + 1, mid)
        v = np.insert(v, i + 1, _return_difference(ev, path(mid)))
    with np.errstate(divide="ignore", invalid="ignore"):
        steps = np.angle(v[1:] / v[:-1])
    if not np.all(np.isfinite(steps)) or np.max(np.abs(np.degrees(steps)), initial=0.0) > 2 * _MAX_STEP_DEG:
        return None
    return float(np.sum(steps))


def count_encirclements(ev, spec, cl_poles, grid, *, max_points: int = 200_000) -> int | None:
    """Net **clockwise** encirclements ``N`` of -1 by ``L`` (of the origin by ``det(I + L)``).

    The convention of linflex (``NyquistResponse.encirclements`` and
    ``StabilityMargins.nyquist_encirclements``): along the Nyquist contour -- up the imaginary
    axis, half circles to the right of every axis pole of the spectrum policy
    (:func:`~._spectrum.indentations`), closed through infinity where ``det(I + L) -> det(I +
    D)`` -- the closed loop has ``Z = N + P`` right half-plane poles, ``P`` the open-loop ones
    (Nyquist criterion; Desoer and Wang 1980 for the MIMO determinant). So ``N = -P`` for a
    stable closed loop, and ``L = 2/(s - 1)`` (``P = 1``, ``Z = 0``) has ``N = -1``.

    The phase of ``det(I + L)`` is tracked until no step exceeds 15 deg; real systems are
    symmetric about the real axis, so the half path ``w >= 0`` is traversed and its phase change
    doubled. None when a closed-loop pole lies on the contour or the curve could not be resolved.

    Parameters
    ----------
    ev : TransferEvaluator
        Evaluator of the square open loop ``L``.
    spec : Spectrum
        Classified open-loop poles.
    cl_poles : ndarray of complex
        Closed-loop poles [1/s] (the indentations must not enclose them).
    grid : ndarray
        Frequencies [rad/s] that resolve ``L``, used as initial points.
    max_points : int
        Cap on the points of each contour piece.

    Returns
    -------
    int or None
        ``N``.
    """
    cl_poles = cl_all = np.asarray(cl_poles, dtype=complex)
    # closed-loop poles at the origin by the rigid-group rule (a rigid mode that the loop neither
    # sees nor drives stays at the origin, split by rounding into +-1e-7 j) cancel against as many
    # open-loop rigid poles in det(I + L): they are not on the contour, the origin is indented
    cl_rigid, _ = rigid_mask(cl_poles, np.zeros((0, 0)), None, scale=spec.scale)
    if 0 < np.count_nonzero(cl_rigid) <= np.count_nonzero(spec.rigid):
        cl_poles = cl_poles[~cl_rigid]
    if np.any(spec.on_axis(cl_poles)):
        return None  # a closed-loop pole on the contour (to rounding, by the spectrum policy)
    indents = indentations(spec, cl_poles)
    if indents is None:
        return None
    D = ev.D
    total = 0.0
    grid = np.asarray(grid, dtype=float)
    grid = grid[grid > 0]
    start = 0.0
    if indents and indents[0][0] == 0.0:
        eps0 = indents.pop(0)[1]
        th = np.linspace(0, np.pi / 2, 17)
        # a rigid group of k poles (a Jordan block split by rounding) is evaluated with a relative
        # error of about eps ||A|| / |s|^k, which its computed spread can underestimate: widen the
        # indentation (x10) while the evaluator's own estimate on the arc exceeds 1e-3, staying
        # within half the distance to every other pole
        # (every closed-loop pole outside the arc bounds the widening, those the rigid-group rule
        # took for cancelling ones included: a 1/s^4 chain under a gain of 1e-8 has closed-loop
        # poles of modulus 0.01 that pass that rule and are unstable)
        others = np.concatenate([spec.poles[~spec.rigid], cl_all])
        others = others[np.abs(others) > 10 * eps0]
        limit = 0.5 * float(np.min(np.abs(others), initial=np.inf))
        limit = min(limit, 0.5 * min([w for w, _ in indents], default=np.inf))
        while True:
            ev.at(eps0 * np.exp(1j * th))
            if np.max(ev.last_error, initial=0.0) <= 1e-3 or 10 * eps0 >= limit:
                break
            eps0 *= 10.0
        dphi = _phase_change(ev, lambda t: eps0 * np.exp(1j * t), 0.0, np.pi / 2, th, max_points)
        if dphi is None:
            return None
        total += dphi
        start = eps0
    hi = max(grid.max(initial=1.0), 10 * max([w for w, _ in indents], default=1.0))
    # extend until det(I + L) has settled to det(I + D) (the big arc adds nothing then)
    f_inf = np.linalg.det(np.eye(D.shape[0]) + D)
    for _ in range(30):
        if abs(_return_difference(ev, np.array([1j * hi]))[0] - f_inf) <= 1e-3 * abs(f_inf):
            break
        hi *= 10.0
    else:
        return None
    ends = [start]
    for wp, eps in indents:
        ends += [wp - eps, wp + eps]
    ends.append(hi)
    lo = start if start > 0 else (grid.min() if grid.size else 1e-3)
    init = np.concatenate([grid, np.geomspace(lo, hi, 200)])
    for k in range(0, len(ends), 2):
        a, b = ends[k], ends[k + 1]
        dphi = _phase_change(ev, lambda t: 1j * t, a, b, init, max_points)
        if dphi is None:
            return None
        total += dphi
        if k // 2 < len(indents):
            wp, eps = indents[k // 2]
            th = np.linspace(-np.pi / 2, np.pi / 2, 33)
            dphi = _phase_change(ev, lambda t, wp=wp, eps=eps: 1j * wp + eps * np.exp(1j * t), -np.pi / 2, np.pi / 2,
                                 th, max_points)
            if dphi is None:
                return None
            total += dphi
    total += float(np.angle(f_inf / _return_difference(ev, np.array([1j * hi]))[0]))
    # counterclockwise turns of det(I + L) along the contour traversed upwards = P - Z
    turns = 2 * total / (2 * np.pi)
    n = int(round(turns))
    return -n if abs(turns - n) < 0.05 else None


def _closed_loop_poles(L) -> NDArray[np.complex128]:
    """Eigenvalues of ``A - B (I + D)^-1 C`` [1/s], the poles of the negative-feedback loop."""
    m = L.n_inputs
    try:
        Minv = np.linalg.solve(np.eye(m) + L.D, np.eye(m))
    except np.linalg.LinAlgError as err:
        raise ModelError("I + D is singular: the feedback loop is not well posed") from err
    if not L.n_states:
        return np.zeros(0, complex)
    return scipy.linalg.eigvals(L.A - L.B @ Minv @ L.C, check_finite=False)


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
        The loop's closed-loop poles, and the hidden ones on the axis [1/s] (the origin included
        for states outside :meth:`~linflex.system.LinearSystem.connected_part`).
    """
    cl = np.asarray(cl_poles, dtype=complex)
    if sys.is_discrete or sys.has_delay or sys.n_states == 0:
        return cl, cl[:0]
    from scipy.optimize import linear_sum_assignment

    hidden = np.zeros(cl.size, dtype=bool)
    kept = set(sys.connected_part().states)
    cut = np.array([i for i, name in enumerate(sys.states) if name not in kept], dtype=int)
    if cut.size:
        # states outside the connected part (no input reaches them, or they reach no output, through
        # the sparsity of A, B, C: the yaw and pitch axes of a roll loop) keep A's block-triangular
        # form under any feedback: their eigenvalues are closed-loop poles, exactly, and hidden; those
        # on the axis, the origin included (a rigid axis not in the loop, a Jordan block that the
        # numerical test below cannot split), are left out
        lam = scipy.linalg.eigvals(sys.A[np.ix_(cut, cut)])
        on = spec.on_axis(lam) | (np.abs(lam) <= 10 * spec.rigid_radius)
        if np.any(on):
            _, match = linear_sum_assignment(np.abs(lam[on, None] - cl[None, :]))
            hidden[match] = True
    axis = (spec.on_axis(cl) & (cl.imag != 0)
            & (np.abs(cl) > 10 * spec.rigid_radius)) & ~hidden
    if not np.any(axis):
        return cl[~hidden], cl[hidden]

    Minv = np.linalg.inv(np.eye(sys.n_inputs) + sys.D)
    lam, W, V = scipy.linalg.eig(sys.A - sys.B @ Minv @ sys.C, left=True, right=True)
    idx = np.flatnonzero(axis)
    _, match = linear_sum_assignment(np.abs(cl[idx, None] - lam[None, :]))
    lam, V, W = lam[match], V[:, match], W[:, match]
    nCB = float(np.linalg.norm(sys.C, 2)) * float(np.linalg.norm(sys.B, 2))
    order = np.argsort(lam.imag, kind="stable")
    breaks = np.flatnonzero(np.abs(np.diff(lam[order])) > CLUSTER_RTOL * np.abs(lam[order][1:])) + 1
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


def nyquist_response(loop, omega_max: float | None = None, *, indent_radius: float | None = None,
                     max_refinements: int = 20, rigid_tol: float | None = None) -> NyquistResponse:
    """Evaluate a loop along the Nyquist contour and count encirclements of -1.

    Parameters
    ----------
    loop : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`Loop` (its loop transfer function broken at the plant input, ``L = K P``, is
        used) or a square loop transfer function ``L`` of a negative-feedback loop. A sampled
        loop is traversed on its w-plane image (``z = (1 + s dt/2)/(1 - s dt/2)``: ``s`` of the
        result are w-plane points, the values those of ``L(z)``, unstable meaning outside the
        unit circle); a delayed continuous loop with ``exp(-s tau)`` exact.
    omega_max : float, optional
        Radius of the large half-circle [rad/s]; default the top of :func:`frequency_grid`.
    indent_radius : float, optional
        Radius of the indentations around imaginary-axis poles [rad/s]; default the smallest
        radius of the spectrum policy (:func:`~linflex.frequency._spectrum.indentations`).
    max_refinements : int, optional
        Rounds of point insertion where the phase of the return difference jumps by more than
        pi/4 between contour points.
    rigid_tol : float, optional
        Tolerance [1/s] of the spectrum policy (``frequency/_spectrum.py``): poles with
        ``|lambda| <= rigid_tol`` are at the origin, with ``|Re lambda| <= rigid_tol`` on the
        axis. Default: the rounding rules of that policy.

    Returns
    -------
    NyquistResponse

    Raises
    ------
    ShapeError
        If ``L`` is not square or has no channels.
    ModelError
        For complex matrices, a non-positive ``omega_max`` or ``indent_radius``, a
        ``max_refinements`` that is not a non-negative integer, or a singular ``I + D``.

    Notes
    -----
    ``N`` is the count of ``count_encirclements`` in frequency/_nyquist.py (clockwise, the convention shared with
    :func:`~linflex.stability.stability_margins`); the sampled contour returned here is refined
    until every phase increment of the return difference is below pi/4. The closed loop
    has ``Z = N + P`` poles in the right half-plane (MIMO via the determinant, Desoer and Wang
    1980). Poles on the imaginary axis (a rigid-body double integrator at the origin) are
    excluded by half-circles to their right, so they are not counted in ``P``. A closed-loop pole
    on the axis (a double integrator under a pure gain: ``1 / s^2`` closes to ``s^2 + 1``) puts the
    curve through -1 (``min_distance`` 0), where no count is defined: ``Z`` then counts the
    closed-loop eigenvalues not in the open left half-plane (to rounding, those on the axis
    included, as :func:`~linflex.stability.stability_margins` does) and ``N = Z - P``.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> L = LinearSystem([[0, 1], [0, -1]], [[0], [1]], [[4, 0]])   # 4 / (s (s + 1)): stable loop
    >>> r = nyquist_response(L)
    >>> r.encirclements, r.open_loop_unstable_poles, r.closed_loop_unstable_poles
    (0, 0, 0)
    """
    t0 = time.perf_counter()
    _check_positive_int(max_refinements, "max_refinements", allow_zero=True)
    L = loop.open_loop() if isinstance(loop, Loop) else loop
    L = checked_system(L, "loop", square=True, discrete=True, delay=True)
    siso = L.shape == (1, 1)
    # sampled loops on their w-plane image, delays exact (frequency/_sampled.py); the closed-loop
    # poles of a delayed continuous loop (a 6th-order Pade's) only place the indentations
    evaluator = axis_evaluator(L, "auto", 1e-11)
    delayed = L.has_delay and not L.is_discrete
    L, L_cl = engine_system(L), (pade(L, 6).sys if delayed else None)
    spec = classify(L.A, rigid_tol, poles=evaluator.poles, B=L.B, C=L.C, D=L.D)
    P = spec.n_rhp
    axis = spec.axis_frequencies()
    centers = np.array(sorted({complex(0, s * wp) for wp, _ in axis for s in (-1, 1)}, key=lambda c: c.imag),
                       dtype=complex)
    closed = L if L_cl is None else L_cl
    cl_poles, _ = loop_poles(closed, _closed_loop_poles(closed), spec)   # hidden modes are not the loop's
    if indent_radius is None:
        radii = indentations(spec, cl_poles)
        if radii is None:  # the policy's radius is not available: 1 % of the nearest other pole
            radii = [(wp, 1e-2 * max(rp, float(np.min(np.abs(spec.poles[~spec.axis] - 1j * wp), initial=1.0))))
                     for wp, rp in axis]
        r = min([rad for _, rad in radii], default=1e-4 * spec.scale)
    else:
        r = check_positive(indent_radius, "indent_radius")
    _, zs = _features(L, spec.poles, False)
    grid = pole_zero_grid(spec, zs)
    W = float(grid[-1]) if omega_max is None else check_positive(omega_max, "omega_max")
    w = np.concatenate([-grid[::-1], [0.0], grid])
    w = w[np.abs(w) <= W]
    for c in centers:
        w = w[np.abs(w - c.imag) > r]
    pieces, axis_flags = [], []
    cuts = [c.imag for c in centers]
    edges = [-W] + [x for c in cuts for x in (c - r, c + r)] + [W]
    for k in range(len(cuts) + 1):
        lo, hi = edges[2 * k], edges[2 * k + 1]
        seg = w[(w >= lo) & (w <= hi)]
        seg = np.unique(np.concatenate([[lo], seg, [hi]]))
        pieces.append(1j * seg)
        axis_flags.append(np.ones(len(seg), dtype=bool))
        if k < len(cuts):
            arc = _arc(centers[k], r, -np.pi / 2, np.pi / 2, 41)[1:-1]
            pieces.append(arc)
            axis_flags.append(np.zeros(len(arc), dtype=bool))
    big = _arc(0j, W, np.pi / 2, -np.pi / 2, 81)[1:-1]
    pieces.append(big)
    axis_flags.append(np.zeros(len(big), dtype=bool))
    s = np.concatenate(pieces)
    flags = np.concatenate(axis_flags)

    def f_of(spts):
        if siso:
            return evaluator.at(spts)[:, 0, 0]
        return _return_difference(evaluator, spts) - 1.0

    vals = f_of(s)
    for _ in range(max_refinements):
        ret = 1.0 + np.append(vals, vals[:1])
        with np.errstate(divide="ignore", invalid="ignore"):   # a point on -1: a closed-loop pole
            dphi = np.angle(ret[1:] / ret[:-1])
        jump = np.abs(dphi) > np.pi / 4
        if not np.any(jump):
            break
        idx = np.nonzero(jump)[0]
        nxt = (idx + 1) % len(s)
        mids = 0.5 * (s[idx] + s[nxt])
        # keep midpoints of axis segments on the axis
        both_axis = flags[idx] & flags[nxt]
        mids = np.where(both_axis, 1j * mids.imag, mids)
        mvals = f_of(mids)
        s = np.insert(s, idx + 1, mids)
        vals = np.insert(vals, idx + 1, mvals)
        flags = np.insert(flags, idx + 1, both_axis)
    ret = 1.0 + np.append(vals, vals[:1])
    with np.errstate(divide="ignore", invalid="ignore"):
        total = float(np.sum(np.angle(ret[1:] / ret[:-1])))
    N = count_encirclements(evaluator, spec, cl_poles, grid)
    if N is None:
        cl = np.asarray(cl_poles, dtype=complex)
        if np.isfinite(total) and not np.any(spec.on_axis(cl)):
            N = int(round(-total / (2 * np.pi)))   # the adaptive count unresolved: the sampled contour's
        else:
            # a closed-loop pole on the contour (on the axis, to rounding): the curve passes through
            # -1 and its count is not defined; Z from the closed-loop eigenvalues, those on the axis
            # not asymptotically stable (as stability_margins counts them), and N = Z - P
            N = spec.count_unstable(cl) - P
    for arr in (s, vals, flags, centers):
        arr.setflags(write=False)
    return NyquistResponse(
        s=s, values=vals, on_axis=flags, encirclements=N, open_loop_unstable_poles=P,
        closed_loop_unstable_poles=N + P, indentations=centers, indent_radius=r, omega_max=W,
        min_distance=float(np.min(np.abs(1.0 + vals))), seconds=time.perf_counter() - t0,
    )
