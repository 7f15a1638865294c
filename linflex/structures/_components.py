"""Component modes and reduction of structures (Banerjee, *Flexible Multibody Dynamics*, ch. 7).

Every function works on symmetric stiffness ``K`` and mass ``M`` matrices (from
:func:`assemble_beams` or any finite-element code) and index sets of freedoms, and returns a
frozen result with the reduced matrices, the basis and what was kept. Equations and the
corrections of the book's misprints: docs/reference/component-modes-reduction.md.

Partition into boundary freedoms ``b`` (interfaces) and interior freedoms ``i``::

    K = [k_ii  k_ib]      M = [m_ii  m_ib]
        [k_bi  k_bb]          [m_bi  m_bb]
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..system._errors import ModelError
from ..system._galerkin import GalerkinBases
from ..system._linear import SecondOrderSystem
from ..system._signals import check_positive, frozen_array, real_matrix, real_vector
from ._modal_data import _modal_damping, _mode_count

__all__ = [
    "ComponentReduction",
    "EffectiveMass",
    "StructuralModes",
    "Synthesis",
    "component_damping",
    "constraint_modes",
    "craig_bampton",
    "frequency_filter",
    "guyan",
    "modal_effective_mass",
    "modal_truncation_vectors",
    "structural_modes",
    "svd_component_reduction",
    "synthesize",
]




def _check_km(K: ArrayLike, M: ArrayLike, names: tuple[str, str] = ("K", "M")) -> tuple[NDArray, NDArray]:
    try:
        K, M = np.asarray(K, dtype=float), np.asarray(M, dtype=float)
    except (TypeError, ValueError) as err:
        raise ModelError(f"{' and '.join(names)} must be square matrices of numbers: {err}") from err
    n = K.shape[0] if K.ndim == 2 else -1
    for name, X in zip(names, (K, M)):
        if X.shape != (n, n):
            raise ModelError(f"{name} has shape {X.shape}; square matrices of the same size are expected")
        if not np.all(np.isfinite(X)):
            raise ModelError(f"{name} has non-finite entries")
        if not np.allclose(X, X.T, rtol=1e-10, atol=1e-12 * max(np.abs(X).max(), 1e-300)):
            raise ModelError(f"{name} is not symmetric")
    return K, M


def _indices(index: ArrayLike, n: int, what: str, *, allow_empty: bool = False) -> NDArray[np.int_]:
    """Sorted distinct freedom indices from integers or from a boolean mask of length ``n``
    (numpy's two ways; a mask read as integers would be the freedoms 0 and 1)."""
    raw = np.asarray(index)
    if raw.dtype == bool and raw.size and raw.shape != (n,):
        raise ModelError(f"{what}: a boolean mask must have one entry per freedom ({n}), got shape {raw.shape}")
    if raw.dtype == bool and raw.size:
        raw = np.flatnonzero(raw)
    if raw.size and (raw.dtype.kind not in "iuf" or not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw))):
        raise ModelError(f"{what}: freedom indices must be integers (or a boolean mask), got {raw.tolist()}")
    idx = np.unique(raw.astype(int).ravel())
    if (idx.size == 0 and not allow_empty) or (idx.size and (idx.min() < 0 or idx.max() >= n)):
        raise ModelError(f"{what}: indices must lie in 0..{n - 1}, got {np.asarray(index).tolist()}")
    return idx


@dataclass(frozen=True)
class StructuralModes:
    """Vibration modes with unit modal mass: ``Phi^T M Phi = I``, ``Phi^T K Phi = diag(w^2)``.

    Attributes
    ----------
    frequencies : ndarray, shape (k,)
        Natural frequencies [rad/s], ascending; a negative eigenvalue (a mechanism, or
        round-off of a rigid-body mode) is reported as a negative frequency
        ``-sqrt(|lambda|)``, never hidden.
    shapes : ndarray, shape (n, k)
        Unit-mass mode shapes ``Phi`` [per unit modal coordinate: kg^-1/2 for translations,
        kg^-1/2 m^-1 for rotations].
    """

    frequencies: NDArray[np.float64]
    shapes: NDArray[np.float64]


def structural_modes(K: ArrayLike, M: ArrayLike, n_modes: int | None = None) -> StructuralModes:
    """The lowest ``n_modes`` (default all) modes of ``K phi = w^2 M phi``.


    Parameters
    ----------
    K, M : array_like, shape (n, n)
        Symmetric stiffness [N/m, N m/rad] and positive definite mass [kg, kg m^2] matrices.
    n_modes : int, optional
        Number of lowest modes; all by default.

    Returns
    -------
    StructuralModes
        Frequencies [rad/s] ascending and unit-mass mode shapes (columns).

    Raises
    ------
    ModelError
        For non-symmetric or wrongly shaped matrices, or ``M`` not positive definite.

    Examples
    --------
    Three 1 kg masses in a chain of 1 N/m springs, fixed at one end:

    >>> import numpy as np
    >>> from linflex import structural_modes
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> modes = structural_modes(K, np.eye(3))
    >>> [round(float(w), 4) for w in modes.frequencies]
    [0.445, 1.247, 1.8019]
    """
    K, M = _check_km(K, M)
    n = K.shape[0]
    n_modes = n if n_modes is None else _mode_count(n_modes, "n_modes", n)
    try:
        lam, phi = scipy.linalg.eigh(K, M, subset_by_index=[0, n_modes - 1])
    except np.linalg.LinAlgError as err:
        raise ModelError(f"M is not positive definite: {err}") from err
    return StructuralModes(frozen_array(np.sign(lam) * np.sqrt(np.abs(lam))), frozen_array(phi))


def constraint_modes(K: ArrayLike, boundary: ArrayLike) -> tuple[NDArray, NDArray]:
    """Constraint modes ``Psi_c`` (n x n_b, rows in the original order) and ``R_bb``.

    ``Psi_c`` is the static shape of a unit displacement of each boundary freedom with the other
    boundary freedoms held and no interior load; ``R_bb = k_bb - k_bi k_ii^-1 k_ib`` are the
    boundary reactions (zero for a statically determinate boundary: the shapes are then the
    component's rigid-body modes).

    Parameters
    ----------
    K : array_like, shape (n, n)
        Stiffness matrix [N/m, N m/rad].
    boundary : array_like of int
        Indices of the boundary freedoms (or a boolean mask of length n).

    Returns
    -------
    Psi_c : ndarray, shape (n, n_b)
        Constraint modes (unit boundary displacements).
    R_bb : ndarray, shape (n_b, n_b)
        Boundary reactions [N/m, N m/rad].

    Examples
    --------
    A free chain of three masses held at one end: the constraint mode is the rigid translation.

    >>> import numpy as np
    >>> from linflex import constraint_modes
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> psi, r_bb = constraint_modes(K, [0])
    >>> psi.ravel().round(6).tolist(), abs(float(r_bb[0, 0])) < 1e-12
    ([1.0, 1.0, 1.0], True)
    """
    K, _ = _check_km(K, K, ("K", "K"))
    n = K.shape[0]
    b = _indices(boundary, n, "boundary")
    i = np.setdiff1d(np.arange(n), b)
    Psi = np.zeros((n, b.size))
    Psi[b, np.arange(b.size)] = 1.0
    try:
        Psi[i] = -scipy.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, b)], assume_a="sym")
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ModelError(f"k_ii is singular: the boundary does not restrain the component ({err})") from err
    R = K[np.ix_(b, b)] + K[np.ix_(b, i)] @ Psi[i]
    return frozen_array(Psi), frozen_array((R + R.T) / 2)


@dataclass(frozen=True)
class ComponentReduction(GalerkinBases):
    """A Rayleigh-Ritz reduction ``u = T q`` of a component.

    Attributes
    ----------
    T : ndarray (n, m)
        The basis, rows in the original freedom order [physical dof units per generalized
        coordinate].
    M, K : ndarray (m, m)
        ``T^T M T`` and ``T^T K T``, the reduced mass and stiffness [generalized units:
        kg and N/m per coordinate squared].
    kept : tuple of str
        What each column of ``T`` is: ``"mode k"``, ``"mtv k"``, ``"boundary j"`` (freedom j).
    frequencies : ndarray
        Frequencies of the reduced model [rad/s] (all of its modes).
    fixed_interface_frequencies : ndarray
        Craig-Bampton: frequencies of the kept fixed-interface modes [rad/s]; else empty.
    seconds : float
        Wall time of the reduction [s] (NaN when the result was built by hand).

    Notes
    -----
    The common shape of every reduction result (``linflex.linearize``'s balanced and modal
    truncation, minimal realization, projected modes) is available as properties: ``sys`` (the
    reduced undamped :class:`SecondOrderSystem`, no inputs or outputs: a component has no
    transfer function of its own), ``V`` and ``W`` (both ``T``: a Galerkin projection),
    ``order`` (columns of ``T``), ``error_bound`` and ``measured_error`` (None: component modes
    have neither an a-priori bound nor a transfer function to measure; judge them by
    ``frequencies`` against the full model).
    """

    T: NDArray[np.float64]
    M: NDArray[np.float64]
    K: NDArray[np.float64]
    kept: tuple[str, ...]
    frequencies: NDArray[np.float64]
    fixed_interface_frequencies: NDArray[np.float64]
    seconds: float = float("nan")

    @property
    def sys(self) -> SecondOrderSystem:
        """The reduced component as an undamped :class:`SecondOrderSystem` without inputs or outputs."""
        m = self.T.shape[1]
        return SecondOrderSystem(self.M, np.zeros((m, m)), self.K, np.zeros((m, 0)),
                                 dofs=[name.replace(" ", "") for name in self.kept])


    @property
    def measured_error(self) -> None:
        """None: a component has no inputs and outputs, hence no transfer function to measure."""
        return None


def _reduction(K, M, T, kept, fixed=(), t0=None) -> ComponentReduction:
    # the Galerkin step T^T M T, T^T K T of the core; linflex.linearize._projection.project_second_order
    # is the same congruence on a SecondOrderSystem (the core cannot import the linearize layer)
    Mr, Kr = T.T @ M @ T, T.T @ K @ T
    Mr, Kr = (Mr + Mr.T) / 2, (Kr + Kr.T) / 2
    return ComponentReduction(frozen_array(T), frozen_array(Mr), frozen_array(Kr), tuple(kept),
                              structural_modes(Kr, Mr).frequencies, frozen_array(fixed),
                              float("nan") if t0 is None else time.perf_counter() - t0)


def craig_bampton(K: ArrayLike, M: ArrayLike, boundary: ArrayLike, n_modes: int, *,
                  mtv: bool = False) -> ComponentReduction:
    """Hurty-Craig-Bampton reduction: ``n_modes`` fixed-interface modes and the constraint modes.

    ::

        T = [phi_k  (Psi_mtv)  -k_ii^-1 k_ib]      columns: modes, MTVs, boundary freedoms
            [  0       0            I       ]

    With ``mtv=True``, modal truncation vectors of the boundary inertia loads
    ``-[m_ii m_ib] Psi_c`` are added (reference notes section 6, App. 7.A).

    Parameters
    ----------
    K, M : array_like, shape (n, n)
        Stiffness [N/m, N m/rad] and mass [kg, kg m^2] matrices of the free component.
    boundary : array_like of int
        Indices of the boundary (interface) freedoms (or a boolean mask of length n).
    n_modes : int
        Number of fixed-interface modes to keep.
    mtv : bool, optional
        Add the modal truncation vectors of the boundary inertia loads.

    Returns
    -------
    ComponentReduction
        The basis ``T``, reduced matrices and frequencies [rad/s].

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import craig_bampton
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> cb = craig_bampton(K, np.eye(3), [0], 1)
    >>> cb.kept, [round(float(w), 4) for w in cb.fixed_interface_frequencies]
    (('mode 0', 'boundary 0'), [0.618])
    """
    t0 = time.perf_counter()
    K, M = _check_km(K, M)
    n = K.shape[0]
    b = _indices(boundary, n, "boundary")
    i = np.setdiff1d(np.arange(n), b)
    n_modes = _mode_count(n_modes, "n_modes", i.size, " interior freedoms")
    Psi, _ = constraint_modes(K, b)
    fixed = structural_modes(K[np.ix_(i, i)], M[np.ix_(i, i)], n_modes)
    columns = [np.zeros((n, n_modes))]
    columns[0][i] = fixed.shapes
    kept = [f"mode {k}" for k in range(n_modes)]
    if mtv:
        loads = -(M[np.ix_(i, np.arange(n))] @ Psi)
        vectors, _ = _mtv(K[np.ix_(i, i)], M[np.ix_(i, i)], fixed.shapes, loads)
        block = np.zeros((n, vectors.shape[1]))
        block[i] = vectors
        columns.append(block)
        kept += [f"mtv {k}" for k in range(vectors.shape[1])]
    columns.append(np.array(Psi))
    kept += [f"boundary {j}" for j in b]
    return _reduction(K, M, np.hstack(columns), kept, fixed.frequencies, t0)


def guyan(K: ArrayLike, M: ArrayLike, active: ArrayLike) -> ComponentReduction:
    """Guyan reduction (static condensation) onto the ``active`` freedoms.

    ``u_e = -k_ee^-1 k_ea u_a``; the eigenproblem is ``[T^T K T - w^2 T^T M T] phi = 0`` (the
    book's Eq. 7.14 has the matrices interchanged). Exact for static loads on the active set.

    Parameters
    ----------
    K, M : array_like, shape (n, n)
        Stiffness [N/m, N m/rad] and mass [kg, kg m^2] matrices.
    active : array_like of int
        Indices of the freedoms kept (or a boolean mask of length n).

    Returns
    -------
    ComponentReduction
        The basis ``T``, reduced matrices and frequencies [rad/s].

    Examples
    --------
    A fixed chain of three 1 kg masses and 1 N/m springs condensed onto its free end: the
    static shape is linear and the one frequency lies above the exact 0.445 rad/s.

    >>> import numpy as np
    >>> from linflex import guyan
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> g = guyan(K, np.eye(3), [2])
    >>> g.T.ravel().round(4).tolist(), round(float(g.frequencies[0]), 4)
    ([0.3333, 0.6667, 1.0], 0.4629)
    """
    t0 = time.perf_counter()
    K, M = _check_km(K, M)
    n = K.shape[0]
    a = _indices(active, n, "active")
    T, _ = constraint_modes(K, a)
    return _reduction(K, M, np.array(T), [f"boundary {j}" for j in a], (), t0)


def _mtv(K, M, modes, loads, tol: float = 1e-10):
    """Modal truncation vectors of ``loads`` against unit-mass ``modes`` (section 6)."""
    residual = loads - M @ modes @ (modes.T @ loads)
    u = scipy.linalg.solve(K, residual, assume_a="sym")
    # Compress dependent directions in the M-norm before orthonormalizing (section 6, step 3).
    L = np.linalg.cholesky(M)
    U, sv, _ = np.linalg.svd(L.T @ u, full_matrices=False)
    keep = sv > tol * max(sv.max(initial=0.0), 1e-300)
    u = scipy.linalg.solve_triangular(L.T, U[:, keep], lower=False)
    Ms, Ks = u.T @ M @ u, u.T @ K @ u
    lam, phi = scipy.linalg.eigh((Ks + Ks.T) / 2, (Ms + Ms.T) / 2)
    return u @ phi, np.sqrt(np.abs(lam))


def modal_truncation_vectors(K: ArrayLike, M: ArrayLike, modes: ArrayLike, loads: ArrayLike, *,
                             tol: float = 1e-10) -> tuple[NDArray, NDArray]:
    """Dickens' modal truncation vectors of the load patterns ``loads`` (n x n_F).

    Returns ``(Psi_mtv, omega_mtv)``: unit-mass vectors, M- and K-orthogonal to the kept unit-mass
    ``modes`` (n x k), with which ``[modes, Psi_mtv]`` reproduces the static response
    ``K^-1 F`` of every load column exactly; directions below ``tol`` (relative, M-norm) are
    dropped as dependent.

    Parameters
    ----------
    K, M : array_like, shape (n, n)
        Stiffness [N/m, N m/rad] and mass [kg, kg m^2] matrices.
    modes : array_like, shape (n, k)
        The kept unit-mass modes.
    loads : array_like, shape (n, n_F)
        Load patterns [N, N m].
    tol : float, optional
        Relative M-norm [-] under which a direction is dropped.

    Returns
    -------
    Psi_mtv : ndarray, shape (n, n_mtv)
        Unit-mass vectors (``Psi^T M Psi = I``), in the units of ``modes``, ``n_mtv <= n_F``.
    omega_mtv : ndarray, shape (n_mtv,)
        Their Rayleigh frequencies ``sqrt(psi^T K psi)`` [rad/s].

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import modal_truncation_vectors, structural_modes
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> modes = structural_modes(K, np.eye(3), 1).shapes
    >>> psi, omega = modal_truncation_vectors(K, np.eye(3), modes, [[0.0], [0.0], [1.0]])
    >>> psi.shape, round(float(omega[0]), 3)
    ((3, 1), 1.291)
    """
    K, M = _check_km(K, M)
    n = K.shape[0]
    modes = np.asarray(modes, dtype=float)
    modes = real_matrix(modes.reshape(n, 0) if modes.size == 0 else modes, "modes", (n, None))
    loads = np.asarray(loads, dtype=float)
    loads = real_matrix(loads.reshape(n, 1) if loads.shape == (n,) else loads, "loads", (n, None))
    try:
        vectors, omega = _mtv(K, M, modes, loads, tol)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning) as err:
        raise ModelError(f"modal truncation vectors need a restrained structure (K nonsingular) and a positive "
                         f"definite M: {err}") from err
    return frozen_array(vectors), frozen_array(omega)


@dataclass(frozen=True)
class EffectiveMass:
    """Modal effective masses of fixed-interface modes (reference notes section 4).

    Attributes
    ----------
    per_mode : ndarray (k, n_b, n_b)
        ``L_k^T L_k / m_k`` per mode, in the boundary directions [kg, kg m, kg m^2 for
        translation-translation, translation-rotation, rotation-rotation entries].
    rigid_mass : ndarray (n_b, n_b)
        ``M_rr = Phi_r^T M Phi_r``, the rigid-body mass about the boundary [kg, kg m, kg m^2].
    attainable : ndarray (n_b, n_b)
        What all fixed-interface modes together can reach: ``M_rr`` minus the boundary residual
        mass ``Phi_rb^T (m_bb - m_bi m_ii^-1 m_ib) Phi_rb`` (corrected Eq. 7.24).
    fractions : ndarray (k, n_b)
        Cumulative share [-] of the attainable diagonal captured by modes ``0..k``.
    frequencies : ndarray (k,)
        [rad/s].
    """

    per_mode: NDArray[np.float64]
    rigid_mass: NDArray[np.float64]
    attainable: NDArray[np.float64]
    fractions: NDArray[np.float64]
    frequencies: NDArray[np.float64]


def modal_effective_mass(K: ArrayLike, M: ArrayLike, boundary: ArrayLike,
                         n_modes: int | None = None) -> EffectiveMass:
    """Effective masses of the lowest ``n_modes`` fixed-interface modes about a determinate boundary.

    Parameters
    ----------
    K, M : array_like, shape (n, n)
        Stiffness [N/m, N m/rad] and mass [kg, kg m^2] matrices of the free component.
    boundary : array_like of int
        Indices of a statically determinate set of boundary freedoms (or a boolean mask).
    n_modes : int, optional
        Number of fixed-interface modes; all by default.

    Returns
    -------
    EffectiveMass
        Per-mode effective masses [kg, kg m^2], the rigid and attainable masses and the
        cumulative fractions.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import modal_effective_mass
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> em = modal_effective_mass(K, np.eye(3), [0])
    >>> float(em.rigid_mass[0, 0]), float(em.attainable[0, 0]), round(float(em.fractions[0, 0]), 4)
    (3.0, 2.0, 0.9472)
    """
    K, M = _check_km(K, M)
    n = K.shape[0]
    b = _indices(boundary, n, "boundary")
    i = np.setdiff1d(np.arange(n), b)
    Phi_r, _ = constraint_modes(K, b)
    fixed = structural_modes(K[np.ix_(i, i)], M[np.ix_(i, i)], n_modes)
    phi = np.zeros((n, fixed.shapes.shape[1]))
    phi[i] = fixed.shapes
    L = phi.T @ M @ Phi_r  # (k, n_b); m_k = 1 (unit modal mass)
    per_mode = np.einsum("ka,kb->kab", L, L)
    Mrr = Phi_r.T @ M @ Phi_r
    Mbb_res = M[np.ix_(b, b)] - M[np.ix_(b, i)] @ scipy.linalg.solve(M[np.ix_(i, i)], M[np.ix_(i, b)], assume_a="pos")
    attainable = Mrr - Phi_r[b].T @ Mbb_res @ Phi_r[b]
    diag = np.diagonal(attainable)
    with np.errstate(divide="ignore", invalid="ignore"):
        fractions = np.where(diag > 0, np.cumsum(np.diagonal(per_mode, axis1=1, axis2=2), axis=0) / diag, np.nan)
    return EffectiveMass(frozen_array(per_mode), frozen_array(Mrr), frozen_array(attainable), frozen_array(fractions),
                         fixed.frequencies)


def frequency_filter(frequencies: ArrayLike, damping: ArrayLike, time_step: float):
    """Ghosh's frequency filtering for explicit integration with step ``time_step`` [s].

    Modes above ``w_max = (2 pi / dt) / 10`` get frequency ``w_max``, damping term
    ``2 zeta w_max`` (the book omits the frequency factor) and load gain ``w_max^2 / w^2``, so
    their static gain is unchanged. Returns ``(frequencies, damping, load_gains, w_max)``.

    Parameters
    ----------
    frequencies : array_like
        Modal frequencies [rad/s].
    damping : array_like
        Damping ratios [-].
    time_step : float
        Integration step [s].

    Returns
    -------
    frequencies : ndarray
        Filtered frequencies [rad/s] (``w_max`` above it).
    damping : ndarray
        Damping ratios [-] (unchanged; the damping term follows the new frequency).
    load_gains : ndarray
        Factors [-] on each mode's load, ``w_max^2 / w^2`` for filtered modes, else 1.
    w_max : float
        The cut-off frequency [rad/s].

    Raises
    ------
    ModelError
        If ``time_step`` is not positive.

    Examples
    --------
    With a 0.1 s step, ``w_max`` is 2 pi rad/s; the 100 rad/s mode is moved there:

    >>> from linflex import frequency_filter
    >>> w, zeta, gain, w_max = frequency_filter([1.0, 100.0], [0.01, 0.01], 0.1)
    >>> [round(float(x), 4) for x in w], [round(float(x), 5) for x in gain]
    ([1.0, 6.2832], [1.0, 0.00395])
    """
    w = real_vector(frequencies, "frequencies", np.size(frequencies))
    z = _modal_damping(damping, w.size)
    try:
        check_positive(time_step, "time_step")
    except ModelError:
        raise ModelError(f"time_step must be positive [s], got {time_step!r}") from None
    w_max = 2 * np.pi / time_step / 10
    filtered = w >= w_max
    gains = np.where(filtered, (w_max / np.where(w > 0, w, 1.0)) ** 2, 1.0)
    return np.where(filtered, w_max, w), z, gains, w_max


@dataclass(frozen=True)
class Synthesis:
    """System model from component bases and interface constraints (section 7).

    ``p = S eta`` maps independent system coordinates to the stacked component coordinates;
    ``M = S^T mu S``, ``K = S^T kappa S``; ``modes`` are unit-mass system modes in ``eta``.

    Attributes
    ----------
    S : ndarray, shape (n_p, n_eta)
        Constraint null-space basis [-]: ``eta`` are a subset of the components' coordinates.
    M, K : ndarray, shape (n_eta, n_eta)
        System mass and stiffness, in the units of the components' generalized coordinates
        ([kg] and [N/m] for physical displacements).
    frequencies : ndarray, shape (n_eta,)
        System natural frequencies [rad/s], ascending.
    modes : ndarray, shape (n_eta, n_eta)
        Unit-mass system modes in ``eta``.
    dependent : ndarray of int
        Indices of the component coordinates eliminated by the constraints.
    """

    S: NDArray[np.float64]
    M: NDArray[np.float64]
    K: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    modes: NDArray[np.float64]
    dependent: NDArray[np.int_]


def synthesize(component_masses: Sequence[ArrayLike], component_stiffnesses: Sequence[ArrayLike],
               constraints: ArrayLike, *, tol: float = 1e-10) -> Synthesis:
    """Component mode synthesis with linear interface constraints ``c p = 0``.

    The dependent coordinates are chosen by QR with column pivoting of ``c`` (robust, detects
    redundant rows); ``S = [-c_dd^-1 c_di; I]`` (re-ordered), so ``c S = 0``.

    Parameters
    ----------
    component_masses, component_stiffnesses : sequence of array_like
        Each component's mass [kg, kg m^2] and stiffness [N/m, N m/rad] in its own coordinates.
    constraints : array_like, shape (n_c, n_total)
        The constraint matrix ``c`` on the stacked component coordinates.
    tol : float, optional
        Relative pivot under which a constraint row counts as redundant.

    Returns
    -------
    Synthesis
        ``S``, the system matrices, frequencies [rad/s] and modes, and the dependent coordinates.

    Examples
    --------
    Two free 1 kg / 1 N/m / 1 kg oscillators joined end to end make a 1-2-1 kg chain:

    >>> import numpy as np
    >>> from linflex import synthesize
    >>> K1 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    >>> s = synthesize([np.eye(2), np.eye(2)], [K1, K1], [[0.0, 1.0, -1.0, 0.0]])
    >>> [round(float(w), 4) for w in s.frequencies]
    [0.0, 1.0, 1.4142]
    """
    component_masses, component_stiffnesses = list(component_masses), list(component_stiffnesses)
    if not component_masses or len(component_masses) != len(component_stiffnesses):
        raise ModelError(f"synthesize needs one mass and one stiffness matrix per component, got "
                         f"{len(component_masses)} and {len(component_stiffnesses)}")
    pairs = [_check_km(k, m, (f"component_stiffnesses[{j}]", f"component_masses[{j}]"))
             for j, (m, k) in enumerate(zip(component_masses, component_stiffnesses))]
    mu = scipy.linalg.block_diag(*[m for _, m in pairs])
    kappa = scipy.linalg.block_diag(*[k for k, _ in pairs])
    c = np.atleast_2d(np.asarray(constraints, dtype=float))
    if c.ndim != 2 or c.shape[1] != mu.shape[0]:
        raise ModelError(f"constraints have shape {c.shape}: {mu.shape[0]} columns (component coordinates) expected")
    if not np.all(np.isfinite(c)):
        raise ModelError("constraints have non-finite entries")
    _, R, piv = scipy.linalg.qr(c, pivoting=True, mode="economic")
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > tol * max(diag.max(initial=0.0), 1e-300)))
    d, free = piv[:rank], np.sort(piv[rank:])
    if free.size == 0:
        raise ModelError(f"the constraints (rank {rank}) fix all {mu.shape[0]} component coordinates: nothing is "
                         "left to move")
    S = np.zeros((mu.shape[0], free.size))
    S[free, np.arange(free.size)] = 1.0
    S[d] = -np.linalg.lstsq(c[:, d], c[:, free], rcond=None)[0]
    Ms, Ks = S.T @ mu @ S, S.T @ kappa @ S
    modes = structural_modes((Ks + Ks.T) / 2, (Ms + Ms.T) / 2)
    return Synthesis(frozen_array(S), frozen_array(Ms), frozen_array(Ks), modes.frequencies, modes.shapes,
                     frozen_array(d, dtype=None))  # indices


def svd_component_reduction(projected: ArrayLike, *, tol: float = 1e-8) -> tuple[NDArray, NDArray]:
    """SVD of a component's block of the system modes (Eqs. 7.56-7.58).

    ``projected`` is ``A_i`` (component coordinates x system modes). Returns ``(U_hat, sigma)``:
    the left singular vectors whose singular values exceed ``tol * sigma_max`` (the new basis
    is ``phi_i U_hat``) and all singular values, so the choice can be judged.

    Parameters
    ----------
    projected : array_like, shape (n_i, n_modes)
        The component's block of the system modes.
    tol : float, optional
        Relative singular value threshold [-].

    Returns
    -------
    U_hat : ndarray, shape (n_i, r)
        The kept left singular vectors [-] (orthonormal).
    sigma : ndarray, shape (min(n_i, n_modes),)
        All singular values, decreasing, in the units of ``projected``.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import svd_component_reduction
    >>> U_hat, sigma = svd_component_reduction(np.array([[1.0, 0.0], [0.0, 1e-12]]))
    >>> U_hat.shape, sigma.tolist()
    ((2, 1), [1.0, 1e-12])
    """
    A = real_matrix(projected, "projected", (None, None))
    U, sigma, _ = np.linalg.svd(A, full_matrices=False)
    keep = sigma > tol * max(sigma.max(initial=0.0), 1e-300)
    return frozen_array(U[:, keep]), frozen_array(sigma)


def component_damping(M: ArrayLike, modes: ArrayLike, frequencies: ArrayLike, damping: ArrayLike, *,
                      form: str = "mass-weighted") -> NDArray:
    """A damping matrix giving unit-mass ``modes`` the ratios ``damping`` (section 9).

    ``"mass-weighted"``: ``C = M Phi (2 Xi Omega) Phi^T M``, which leaves every other mode
    undamped and uncoupled; ``"pseudo-inverse"``: the book's ``Phi^+T (2 Xi Omega) Phi^+``,
    which damps and couples the others. Both give ``Phi^T C Phi = 2 Xi Omega``.

    Parameters
    ----------
    M : array_like, shape (n, n)
        Mass matrix [kg, kg m^2].
    modes : array_like, shape (n, k)
        Unit-mass modes.
    frequencies : array_like, shape (k,)
        Their frequencies [rad/s].
    damping : array_like, shape (k,)
        Damping ratios [-].
    form : {"mass-weighted", "pseudo-inverse"}, optional

    Returns
    -------
    ndarray, shape (n, n)
        The damping matrix [N s/m, N m s/rad].

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import component_damping, structural_modes
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> m = structural_modes(K, np.eye(3))
    >>> C = component_damping(np.eye(3), m.shapes, m.frequencies, [0.01, 0.01, 0.01])
    >>> modal = m.shapes.T @ C @ m.shapes
    >>> bool(np.allclose(modal, np.diag(2 * 0.01 * m.frequencies)))
    True
    """
    M, _ = _check_km(M, M, ("M", "M"))
    Phi = real_matrix(modes, "modes", (M.shape[0], None))
    k = Phi.shape[1]
    w = real_vector(frequencies, "frequencies", k)
    D = np.diag(2 * _modal_damping(damping, k) * w)
    if form == "mass-weighted":
        C = M @ Phi @ D @ Phi.T @ M
    elif form == "pseudo-inverse":
        P = np.linalg.pinv(Phi)
        C = P.T @ D @ P
    else:
        raise ModelError(f"form must be 'mass-weighted' or 'pseudo-inverse', got {form!r}")
    return frozen_array((C + C.T) / 2)
