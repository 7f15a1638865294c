"""The spectrum policy: one place that decides what the eigenvalues of ``A`` mean.

Every frequency-domain and stability routine of linflex asks this module, and only this module,
three questions about the poles of a system:

1. **Scale.** ``system_scale(A, B, C, D)`` [1/s]: the 1-norm of ``A`` after the one balancing
   rule of linflex (:func:`joint_balance`: states scaled by powers of 2 to balance ``A`` together
   with ``B`` and ``C``), and for a square system (a loop) at least the balanced 1-norm of the
   closed loop ``A - B (I + D)^-1 C``: the frequencies at which the loop acts, so that the
   ``1e-16`` pole of ``6.99 / (s - 1e-16)`` is rounding like the exact ``6.99 / s`` (1 when
   both norms vanish). Backward-stable eigenvalue, Schur and
   Hessenberg computations perturb ``A`` by about ``eps * scale``; every rounding threshold below
   is a multiple of it.
2. **At the origin (rigid-body poles, integrators).** With the user's ``rigid_tol`` [1/s]: every
   eigenvalue with ``|lambda| <= rigid_tol``. By default: the largest group of smallest
   eigenvalues (clusters apart by a factor 10 in modulus above ``1e3 eps scale``) whose sum
   vanishes to rounding, ``|sum| <= 1e3 eps scale``, and so does their
   whole polynomial (``|c_j| <= 1e3 binom(k, j) eps scale^j``: two undamped slow pairs sum to
   zero but are no rounding split), each cluster of ``k`` of them no wider than
   ``100 eps^(1/k) scale`` and separated from the next eigenvalue by a factor 10
   (:func:`rigid_mask`). A Jordan block of size ``k`` at the origin perturbed by
   rounding (a double integrator with a ``1e-16`` entry left by a transfer-function conversion)
   splits into ``k`` eigenvalues on a circle of radius ``(eps scale^k)^(1/k)`` that keep a zero
   sum: all of them are labelled rigid, whichever way the perturbation goes (``0`` and
   ``1e-16``, or ``+-1e-8 j``), so the margins of the perturbed and of the exact system agree.
3. **On the imaginary axis (undamped modes).** A non-rigid eigenvalue is on the axis when
   ``|Re lambda| <= axis_tol(lambda) = max(100 eps scale, 1e-12 |lambda|)``, or when
   ``|Re lambda| <= min(100 eps max|A_ij|, 1e-8 |lambda|)`` (the rounding of the data in the
   user's coordinates, which balancing does not shrink on a diagonal entry, for a pole it leaves
   with a damping ratio below 1e-8; :meth:`Spectrum.axis_tol`). With the user's ``rigid_tol``:
   ``|Re lambda| <= rigid_tol``. Its centre is taken as ``j Im(lambda)`` exactly. Closed-loop
   poles on the axis by the same rule are not asymptotically stable
   (:meth:`Spectrum.count_unstable`).

Consequences, applied by the callers:

- open-loop right half-plane poles are the eigenvalues neither rigid nor on the axis with
  ``Re lambda > 0``; rigid and on-axis poles are not counted in ``P`` but indented;
- the Nyquist contour passes every axis pole on a half circle to the right (:func:`indentations`:
  radius ``min(1e-2 d, max(1e3 r, 1e-6 d))``, ``d`` the distance to the nearest other pole,
  ``r`` the rounding radius of the pole; ``sqrt(5 r d)`` when the other pole is closer);
- frequency grids never hold a point within ``axis_tol`` of an on-axis pole
  (:func:`avoid_axis_poles`): such a point would evaluate a singular ``j omega I - A``;
- near-cancellations (a pole and a zero within rounding of each other) are not removed: they
  are evaluated as they are, and the a-posteriori error estimate of the evaluation says how
  much of ``G`` survives rounding.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex.system import check_positive

__all__ = ["Spectrum", "joint_balance", "system_scale", "rigid_mask", "classify", "indentations", "avoid_axis_poles",
           "EPS"]

EPS = float(np.finfo(float).eps)
#: Largest |lambda| / scale of a rigid-body eigenvalue: a Jordan block of size k at the origin is
#: split by rounding into k eigenvalues of size (eps * scale^k)^(1/k) ~ eps^(1/k) * scale, which is
#: 1.2e-4 * scale for k = 4 (a quadruple integrator).
RIGID_CLUSTER_RTOL = 1e-3
#: Largest |sum of the group's eigenvalues| / (scale * eps): the trace of the block is well
#: conditioned even when the eigenvalues of a Jordan block are not.
RIGID_TRACE_FACTOR = 1e3
#: Smallest ratio between the modulus of the first eigenvalue outside the rigid group and the
#: largest inside it.
RIGID_GAP = 10.0
#: Rounding floor of a real part, in units of eps * scale.
AXIS_FLOOR_FACTOR = 100.0
#: Relative rounding floor of a real part, in units of |lambda|.
AXIS_RTOL = 1e-12
#: Largest damping ratio |Re lambda| / |lambda| that rounding of the data (in the user's coordinates,
#: see :meth:`Spectrum.axis_tol`) may leave on an undamped pole.
AXIS_DATA_RTOL = 1e-8


def joint_balance(A, B=None, C=None) -> NDArray[np.float64]:
    """State scales ``t`` (powers of 2) of the balancing rule: ``A -> T^-1 A T``, ``B -> T^-1 B``,
    ``C -> C T`` with ``T = diag(t)``.

    LAPACK ``gebal`` (no permutation) on the square padding of ``[[A, B], [C, 0]]``, so that the
    states are balanced together with the inputs and outputs that give them their meaning. Balancing
    ``A`` alone can shrink a nearly nilpotent ``A`` (a double integrator with a ``1e-16`` left by a
    conversion) to a norm of ``1e-16``, after which rounding-level entries look like the whole
    system; with ``B`` and ``C`` in the balance it cannot. When that balance leaves ``A`` ten times
    larger than no balancing, the states are not scaled.
    """
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    B = np.zeros((n, 0)) if B is None else np.asarray(B, dtype=float)
    C = np.zeros((0, n)) if C is None else np.asarray(C, dtype=float)
    m, p = B.shape[1], C.shape[0]
    if n == 0:
        return np.ones(0)
    q = max(m, p)
    S = np.zeros((n + q, n + q))
    S[:n, :n], S[:n, n:n + m], S[n:n + p, :n] = A, B, C
    _, (scale, _) = scipy.linalg.matrix_balance(S, permute=False, separate=True)
    ts = scale[:n]
    Aj = A * (1.0 / ts)[:, None] * ts[None, :]
    if not np.isfinite(np.linalg.norm(Aj, 1)) or np.linalg.norm(Aj, 1) > 10 * np.linalg.norm(A, 1):
        return np.ones(n)
    return ts


def system_scale(A: NDArray[np.float64], B=None, C=None, D=None) -> float:
    """Frequency scale [1/s] of a system: the 1-norm of ``A`` under the balancing rule
    (:func:`joint_balance`), and for a square system (a loop) at least the balanced 1-norm of its
    closed loop ``A - B (I + D)^-1 C``; 1.0 when both vanish.

    A pole's distance to the axis is rounding or not relative to the frequencies at which the
    system acts. ``A`` alone does not give them when it is (nearly) nilpotent: ``6.99 / (s -
    1e-16)`` has ``||A|| = 1e-16``, yet the loop acts at 6.99 rad/s (its crossover and closed-loop
    pole), where ``1e-16`` is 1.4e-17 of the frequency, below the rounding of any computation; with
    ``A`` alone the pole would be its own scale and count as unstable, unlike the exact ``6.99 /
    s``. The closed loop brings in ``B``, ``C`` and ``D`` in units of ``A`` (a loop's gain is
    dimensionless), unlike a norm of ``B`` or ``C`` alone.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix [1/s].
    B, C : ndarray, optional
        Input and output matrices: with them the states are balanced together with the signals
        (recommended: without them a nearly nilpotent ``A`` balances to a rounding-level norm).
    D : ndarray, optional
        Feedthrough [-] of a square system (zero when omitted).

    Returns
    -------
    float
        The scale [1/s] against which rounding thresholds are measured.
    """
    A = np.asarray(A, dtype=float)
    if A.shape[0] == 0:
        return 1.0
    if B is None and C is None:
        balanced, _ = scipy.linalg.matrix_balance(A, permute=False)
        scale = float(min(np.linalg.norm(balanced, 1), np.linalg.norm(A, 1)))
    else:
        ts = joint_balance(A, B, C)
        scale = float(np.linalg.norm(A * (1.0 / ts)[:, None] * ts[None, :], 1))
        scale = max(scale, _closed_loop_scale(A, B, C, D))
    return scale if scale > 0 and np.isfinite(scale) else 1.0


def _closed_loop_scale(A, B, C, D) -> float:
    """Balanced 1-norm [1/s] of ``A - B (I + D)^-1 C`` for a square system (0 otherwise, or when
    ``I + D`` is singular to working precision: the loop is not well posed)."""
    if B is None or C is None:
        return 0.0
    B, C = np.asarray(B, dtype=float), np.asarray(C, dtype=float)
    m = B.shape[1]
    if m == 0 or C.shape[0] != m:
        return 0.0
    I_D = np.eye(m) + (np.zeros((m, m)) if D is None else np.asarray(D, dtype=float))
    with np.errstate(all="ignore"):
        if not np.all(np.isfinite(I_D)) or np.linalg.cond(I_D) > 1e12:
            return 0.0
        Acl = A - B @ np.linalg.solve(I_D, C)
        if not np.all(np.isfinite(Acl)):
            return 0.0
        balanced, _ = scipy.linalg.matrix_balance(Acl, permute=False)
        return float(min(np.linalg.norm(balanced, 1), np.linalg.norm(Acl, 1)))


def rigid_mask(eigs: NDArray[np.complex128], A: NDArray[np.float64], rigid_tol: float | None,
               scale: float | None = None):
    """Which eigenvalues are rigid-body (zero) eigenvalues, and the radius used [1/s].

    Parameters
    ----------
    eigs : ndarray of complex
        Eigenvalues of ``A`` [1/s].
    A : ndarray
        The state matrix [1/s] (for its scale).
    rigid_tol : float or None
        ``|lambda| <= rigid_tol`` [1/s] when given; the default rule of the module docstring
        otherwise.
    scale : float, optional
        ``system_scale(A)`` [1/s] if already known.

    Returns
    -------
    mask : ndarray of bool
        True for the rigid-body eigenvalues.
    radius : float
        Largest ``|lambda|`` [1/s] in the group (``rigid_tol`` when given).
    """
    eigs = np.asarray(eigs, dtype=complex)
    mask = np.zeros(eigs.shape, dtype=bool)
    if rigid_tol is not None:
        tol = check_positive(rigid_tol, "rigid_tol", allow_zero=True)
        return np.abs(eigs) <= tol, tol
    if eigs.size == 0:
        return mask, 0.0
    scale = system_scale(A) if scale is None else scale
    order = np.argsort(np.abs(eigs), kind="stable")
    mods = np.abs(eigs[order])
    n_small = int(np.count_nonzero(mods <= RIGID_CLUSTER_RTOL * scale))
    # clusters of the small eigenvalues, separated by gaps of RIGID_GAP in modulus above the
    # rounding floor (a double integrator whose diagonal took a 1e-16 of a large entry of A is
    # split into 0 and 7e-11: one cluster, not an exact zero and a lone pole)
    floor = RIGID_TRACE_FACTOR * EPS * scale
    bounds = [0] + [j for j in range(1, n_small + 1)
                    if j == n_small or mods[j] > RIGID_GAP * max(mods[j - 1], floor)]
    best = 0
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi <= lo:
            continue
        k = hi - lo
        # a Jordan block of size k at the origin scatters into k eigenvalues of modulus about
        # eps^(1/k) * scale with a vanishing sum
        radius_ok = mods[hi - 1] <= 100 * EPS ** (1.0 / k) * scale
        gap_ok = hi == mods.size or mods[hi] >= RIGID_GAP * mods[hi - 1]
        if radius_ok and gap_ok and _vanishes_to_rounding(eigs[order[:hi]] / scale):
            best = hi
        else:
            break
    rigid = order[:best]
    mask[rigid] = True
    radius = float(np.abs(eigs[rigid]).max()) if best else 0.0
    return mask, radius


def _vanishes_to_rounding(mu: NDArray[np.complex128]) -> bool:
    """Whether eigenvalues ``mu`` (in units of the scale) can be a zero block split by rounding.

    The group's polynomial ``prod (x - mu_i) = x^k + c_1 x^(k-1) + ... + c_k`` is the factor of
    ``det(x I - A / scale)`` that a perturbation of ``A`` by ``eps * scale`` moves away from
    ``x^k``: each ``c_j`` is a sum of ``binom(k, j)`` principal minors, each one at most
    ``eps`` with one perturbed entry, so ``|c_j| <= 1e3 eps`` (``|c_1| = |sum mu|``, the trace
    rule) and ``|c_j| <= 1e3 binom(k, j) eps`` for ``j >= 2``. Undamped slow pairs pass the trace
    rule (a conjugate pair on the axis sums to exactly zero) but not this one: ``+-j w`` gives
    ``c_2 = w^2``, which is at the rounding level only for ``w <= 1.5e-6 scale``.
    """
    c = np.poly(mu)[1:]
    k = mu.size
    j = np.arange(1, k + 1)
    binom = np.array([math.comb(k, int(i)) for i in j], dtype=float)
    bound = RIGID_TRACE_FACTOR * EPS * np.where(j == 1, 1.0, binom)
    return bool(np.all(np.abs(c) <= bound))


@dataclass(frozen=True)
class Spectrum:
    """The poles of a system classified by the spectrum policy (see the module docstring).

    Attributes
    ----------
    poles : ndarray of complex
        Eigenvalues of ``A`` [1/s].
    scale : float
        ``system_scale(A)`` [1/s].
    rigid : ndarray of bool
        Poles treated as exactly at the origin.
    axis : ndarray of bool
        Poles treated as exactly on the imaginary axis (the rigid ones included).
    rigid_radius : float
        Largest ``|lambda|`` [1/s] of the rigid group (``rigid_tol`` when given).
    rigid_tol : float or None
        The user's tolerance [1/s], or None for the default rule.
    data_scale : float
        Largest ``|A_ij|`` [1/s] in the user's coordinates (see :meth:`axis_tol`).
    """

    poles: NDArray[np.complex128]
    scale: float
    rigid: NDArray[np.bool_]
    axis: NDArray[np.bool_]
    rigid_radius: float
    rigid_tol: float | None
    data_scale: float = 0.0

    @property
    def rhp(self) -> NDArray[np.bool_]:
        """Poles in the open right half-plane beyond the axis tolerance."""
        return ~self.axis & (self.poles.real > 0)

    @property
    def n_rhp(self) -> int:
        """Number of open right half-plane poles."""
        return int(np.count_nonzero(self.rhp))

    @property
    def n_axis(self) -> int:
        """Number of poles on the imaginary axis (rigid ones included)."""
        return int(np.count_nonzero(self.axis))

    def axis_tol(self, lam) -> NDArray[np.float64]:
        """Largest ``|Re lambda|`` [1/s] of an eigenvalue ``lam`` treated as on the axis.

        ``max(100 eps scale, 1e-12 |lambda|)``, the rounding of a backward-stable eigenvalue
        computation; and, for a pole whose damping ratio it leaves below ``1e-8``, the rounding
        of the data itself, ``100 eps max|A_ij|`` in the user's coordinates: a modal realization
        holds ``w^2`` (``7.3e5`` for a mode at 856 rad/s), a conversion that rounds it leaves
        ``1e-16 w^2`` on any entry, and on a diagonal entry no balancing shrinks it (a diagonal
        similarity leaves diagonals unchanged). Such an entry on an undamped mode at 0.079 rad/s
        of the same loop gives it ``Re lambda = 3.7e-11``: 300 eps times the balanced scale, yet a
        damping ratio of 5e-10. The cap on the damping ratio keeps states scaled 1e9 apart (whose
        largest entry is no measure of rounding) from turning damped modes into undamped ones.
        """
        if self.rigid_tol is not None:
            return np.full(np.shape(lam), float(self.rigid_tol))
        data = np.minimum(AXIS_FLOOR_FACTOR * EPS * self.data_scale, AXIS_DATA_RTOL * np.abs(lam))
        return np.maximum(self.rounding_tol(lam), data)

    def rounding_tol(self, lam) -> NDArray[np.float64]:
        """``max(100 eps scale, 1e-12 |lambda|)`` [1/s] (``rigid_tol`` when given): how far from
        the axis a backward-stable computation may put an eigenvalue ``lam`` that is on it.

        The radius of an axis pole (:meth:`axis_frequencies`, the indentations) and the side of
        the axis of a closed-loop pole (:meth:`count_unstable`) are measured with it, not with
        the data term of :meth:`axis_tol`: a closed-loop pole 1e-8 right of a weakly coupled
        undamped mode at 255 rad/s is computed to 1e-13 and is unstable.
        """
        if self.rigid_tol is not None:
            return np.full(np.shape(lam), float(self.rigid_tol))
        return np.maximum(AXIS_FLOOR_FACTOR * EPS * self.scale, AXIS_RTOL * np.abs(lam))

    def on_axis(self, lam) -> NDArray[np.bool_]:
        """Whether each eigenvalue ``lam`` [1/s] (a closed-loop pole, say) is on the imaginary
        axis to rounding: ``|Re lambda| <= max(rounding_tol(lambda), 1e-12 |lambda|)`` (the
        relative term stays with a user's ``rigid_tol``: an eigenvalue's rounding grows with its
        modulus, not with the rigid group's radius). One rule for the Nyquist contour's
        indentations, the closed loop's unstable count and its hidden modes."""
        lam = np.asarray(lam, dtype=complex)
        return np.abs(lam.real) <= np.maximum(self.rounding_tol(lam), AXIS_RTOL * np.abs(lam))

    def count_unstable(self, lam) -> int:
        """Number of eigenvalues ``lam`` [1/s] (closed-loop poles, say) in the closed right
        half-plane by this policy: ``Re lambda > 0``, or on the axis to rounding (:meth:`on_axis`,
        the scale being this system's). A double integrator under a pure gain
        has its closed-loop poles exactly on the axis, and its 1e-16 perturbation puts them at
        ``-5e-17 +- 2.6 j``: neither is asymptotically stable.

        Parameters
        ----------
        lam : array_like of complex
            Eigenvalues [1/s].

        Returns
        -------
        int
            How many are not in the open left half-plane to rounding.
        """
        lam = np.asarray(lam, dtype=complex)
        return int(np.count_nonzero((lam.real > 0) | self.on_axis(lam)))

    def marginal_tol(self) -> float:
        """Real-part threshold [1/s] that separates the marginal poles from the stable ones.

        Returns
        -------
        float
            The largest of: ``100 sqrt(eps max(1, scale))`` (the round-off spread of a double
            root at the origin, the threshold of :func:`linflex.linearize.split_stable` since
            its first version); ten times the rigid radius and ten times the largest ``|Re
            lambda|`` of an on-axis pole (a reordered Schur form recomputes a Jordan block's
            eigenvalues within its rounding radius; 10 is the gap of the rigid-group rule). The
            user's ``rigid_tol`` when given.
        """
        if self.rigid_tol is not None:
            return float(self.rigid_tol)
        re = np.abs(self.poles.real[self.axis])
        spread = 100.0 * float(np.sqrt(EPS * max(1.0, self.scale)))
        return float(max(spread, 10 * self.rigid_radius, 10 * re.max(initial=0.0)))

    def axis_frequencies(self) -> list[tuple[float, float]]:
        """``(w_p, r_p)`` of every distinct axis pole with ``w_p >= 0`` [rad/s]: the pole sits
        at ``j w_p`` (conjugates implied) within a rounding radius ``r_p``."""
        out: list[tuple[float, float]] = []
        if np.any(self.rigid):
            out.append((0.0, max(self.rigid_radius, float(np.abs(self.poles[self.rigid]).max()))))
        p = self.poles[self.axis & ~self.rigid]
        p = p[p.imag >= 0]
        for z in sorted(p, key=lambda z: z.imag):
            r = max(abs(z.real), float(self.rounding_tol(z)))
            wz = float(abs(z.imag))
            if out and abs(out[-1][0] - wz) <= out[-1][1] + r + 1e-8 * wz:
                out[-1] = (out[-1][0], max(out[-1][1], r, abs(out[-1][0] - wz)))
            else:
                out.append((wz, r))
        return out


def classify(A: NDArray[np.float64], rigid_tol: float | None = None,
             poles: NDArray[np.complex128] | None = None, B=None, C=None, D=None) -> Spectrum:
    """Classify the eigenvalues of ``A`` by the spectrum policy.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix [1/s].
    rigid_tol : float, optional
        Tolerance [1/s]: ``|lambda| <= rigid_tol`` is at the origin, ``|Re lambda| <=
        rigid_tol`` on the axis. Default: the rounding rules of the module docstring.
    poles : ndarray of complex, optional
        Eigenvalues of ``A`` if already computed.
    B, C : ndarray, optional
        Input and output matrices, for the scale (:func:`system_scale`).
    D : ndarray, optional
        Feedthrough [-], for the scale of a square system (zero when omitted).

    Returns
    -------
    Spectrum
        Poles, scale and masks.
    """
    A = np.asarray(A, dtype=float)
    if poles is None:
        poles = scipy.linalg.eigvals(A, check_finite=False) if A.shape[0] else np.zeros(0, complex)
    poles = np.asarray(poles, dtype=complex)
    scale = system_scale(A, B, C, D)
    rigid, radius = rigid_mask(poles, A, rigid_tol, scale)
    data_scale = float(np.max(np.abs(A))) if A.size else 0.0
    spec = Spectrum(poles=poles, scale=scale, rigid=rigid, axis=rigid, rigid_radius=radius,
                    rigid_tol=None if rigid_tol is None else float(rigid_tol),
                    data_scale=data_scale if np.isfinite(data_scale) else 0.0)
    axis = rigid | (np.abs(poles.real) <= spec.axis_tol(poles))
    return dataclasses.replace(spec, axis=axis)


def indentations(spec: Spectrum, others: NDArray[np.complex128] | None = None) -> list[tuple[float, float]] | None:
    """Half-circle indentations ``(w_p, radius)`` [rad/s] of the Nyquist contour.

    Each axis pole ``j w_p`` of rounding radius ``r_p`` is passed at ``radius = min(1e-2 d,
    max(1e3 r_p, 1e-6 d))``, ``d`` the distance to the nearest other pole (of ``spec`` or
    ``others``, the closed-loop poles say) or other axis pole. When that radius does not both
    clear the rounding of the pole (``> 10 r_p``) and stay clear of the others (``< d / 2``), the
    geometric mean ``sqrt(10 r_p d / 2)`` of the two limits is used (a closed-loop pole within
    ``1e-7`` rad/s of a weakly coupled undamped mode); when even those cross, ``sqrt(r_p d)``
    provided it lies between ``2 r_p`` and ``d / 2``; None otherwise.
    """
    axis = spec.axis_frequencies()
    others = np.zeros(0, complex) if others is None else np.asarray(others, dtype=complex)
    rest = np.concatenate([spec.poles[~spec.axis], others])
    out = []
    for wp, rp in axis:
        dist = np.abs(rest - 1j * wp)
        dist = dist[dist > 10 * rp]
        dist = np.concatenate([dist, [abs(wq - wp) for wq, _ in axis if wq != wp]])
        d_near = float(dist.min()) if dist.size else max(1.0, wp, spec.scale)
        eps = min(1e-2 * d_near, max(1e3 * rp, 1e-6 * d_near))
        if eps <= 10 * rp or eps >= 0.5 * d_near:
            # another pole (a closed-loop pole beside a weakly coupled undamped mode) closer than
            # 1e3 times the rounding radius: the geometric mean of the two limits clears both
            if 10 * rp < 0.5 * d_near:
                eps = float(np.sqrt(10 * rp * 0.5 * d_near))
            elif 2 * rp < 0.5 * d_near:
                # still closer (a closed-loop pole 12 rounding radii from a rigid cluster)
                eps = float(np.sqrt(rp * d_near))
            else:
                return None
        out.append((wp, eps))
    return out


#: The relative distance [-] to an on-axis pole within which :func:`avoid_axis_poles` moves a grid
#: point: an evaluation there has a relative error of about ``eps / distance`` times the pole's
#: share of ``G`` (a hidden mode's residue, zero to rounding, too: 1.5e-4 at 1.5e-9 of the
#: antisymmetric array mode of the example scene without damping), which this keeps below 1e-8.
AXIS_CLEARANCE = 1e-7


def avoid_axis_poles(omega: NDArray[np.float64], spec: Spectrum) -> NDArray[np.float64]:
    """Move grid points that sit on an on-axis pole (within its rounding radius, at least
    :data:`AXIS_CLEARANCE` ``w_p``) to ``w_p (1 -+ 1e-6)``: the two sides of the resonance instead
    of a singular evaluation."""
    omega = np.asarray(omega, dtype=float)
    axis = [(wp, rp) for wp, rp in spec.axis_frequencies() if wp > 0]
    if not axis or omega.size == 0:
        return omega
    wp = np.array([a[0] for a in axis])
    rp = np.array([max(a[1], AXIS_CLEARANCE * a[0]) for a in axis])
    near = np.abs(omega[:, None] - wp[None, :]) <= rp[None, :]
    hit = near.any(axis=1)
    if not np.any(hit):
        return omega
    centres = wp[near.any(axis=0)]
    out = [omega[~hit], centres * (1 - 1e-6), centres * (1 + 1e-6)]
    return np.unique(np.concatenate(out))
