"""Three-dimensional beam (frame) finite elements and the modal data of beam structures.

A :class:`Beam` is a straight member with Euler-Bernoulli bending in two planes, axial and
torsional stiffness and a consistent mass. :func:`beam_modal_data` assembles members into a
structure clamped at the body's reference point, solves the generalized eigenproblem for the
lowest modes, and returns :class:`~linflex.ModalData` ready for a flexible body in large
motion, with the geometric stiffness of the 12 unit inertia loads, 21 with rotary inertia
(Banerjee, *Flexible Multibody Dynamics*, section 5.4;
docs/reference/multibody-formulations-banerjee.md).

Every element integral is a 4-point Gauss quadrature of the same interpolation (cubic Hermite
bending, linear axial and torsion), exact for the polynomial degrees involved. The quadrature
points double as the *mass points* of the modal data: because the consistent mass matrix is
``sum_g w_g rho A N(xi_g)^T N(xi_g)``, the nodal-sum modal integrals of the reference notes
(section 6) evaluated over them are exactly those of the consistent-mass model.

Element degrees of freedom, local axes (x along the member)::

    node 1: u1 v1 w1 tx1 ty1 tz1    node 2: u2 v2 w2 tx2 ty2 tz2
    v' = tz,  w' = -ty   (right-handed rotations)
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..system._errors import ModelError
from ..system._signals import check_positive
from ._modal_data import ModalData, _modal_damping, _mode_count

__all__ = ["Beam", "BeamStructure", "PointMassAt", "assemble_beams", "beam_modal_data"]

_GAUSS_XI, _GAUSS_W = np.polynomial.legendre.leggauss(4)
GAUSS_XI = (_GAUSS_XI + 1) / 2  # on [0, 1]
GAUSS_W = _GAUSS_W / 2  # weights summing to 1


@dataclass(frozen=True)
class Beam:
    """A straight beam member between two points of a body.

    Parameters
    ----------
    start, end : array_like, shape (3,)
        End points in the body frame [m].
    EA : float
        Axial stiffness [N].
    EIy, EIz : float
        Bending stiffness about the local y and z axes [N m^2].
    GJ : float
        Torsional stiffness [N m^2].
    mass_per_length : float
        Mass per unit length [kg/m].
    torsional_inertia_per_length : float
        Polar mass moment of inertia per length, rho J [kg m]; default 0.
    elements : int
        Number of finite elements along the member.
    orientation : array_like, shape (3,), optional
        A vector, not along the member, that fixes the local y axis (the local x-y plane
        contains it); default the body y axis, or the body z axis for a member along y, so
        that a member along body x has local axes equal to the body axes.

    Examples
    --------
    A 2 m aluminium-like member along the body x axis:

    >>> from linflex import Beam
    >>> arm = Beam((0, 0, 0), (2, 0, 0), EA=1e7, EIy=1e4, EIz=1e4, GJ=1e4, mass_per_length=1.5)
    >>> arm.length                                     # [m]
    2.0
    """

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    EA: float
    EIy: float
    EIz: float
    GJ: float
    mass_per_length: float
    torsional_inertia_per_length: float = 0.0
    elements: int = 10
    orientation: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("start", "end"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise ModelError(f"Beam.{name} must be 3 finite coordinates [m], got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        if self.length <= 0:
            raise ModelError(f"Beam: start and end coincide at {self.start}")
        for name in ("EA", "EIy", "EIz", "GJ", "mass_per_length"):
            value = getattr(self, name)
            try:
                object.__setattr__(self, name, check_positive(value, f"Beam.{name}"))
            except ModelError:
                raise ModelError(f"Beam.{name} must be positive, got {value!r}") from None
        try:
            object.__setattr__(self, "torsional_inertia_per_length", check_positive(
                self.torsional_inertia_per_length, "Beam.torsional_inertia_per_length", allow_zero=True))
        except ModelError:
            raise ModelError(f"Beam.torsional_inertia_per_length must be >= 0, got "
                             f"{self.torsional_inertia_per_length!r}") from None
        try:
            object.__setattr__(self, "elements", _mode_count(self.elements, "Beam.elements", 10**9))
        except ModelError:
            raise ModelError(f"Beam.elements must be a positive integer, got {self.elements!r}") from None
        if self.orientation is not None:
            ref = np.asarray(self.orientation, dtype=float) if np.ndim(self.orientation) == 1 else None
            if ref is None or ref.shape != (3,) or not np.all(np.isfinite(ref)) or not np.any(ref):
                raise ModelError(f"Beam.orientation must be a nonzero vector of 3 finite components, got "
                                 f"{self.orientation!r}")
            object.__setattr__(self, "orientation", tuple(float(v) for v in ref))

    @property
    def length(self) -> float:
        """Distance from ``start`` to ``end`` [m]."""
        return float(np.linalg.norm(np.subtract(self.end, self.start)))

    def rotation(self) -> NDArray[np.float64]:
        """Rows are the local x, y, z axes in body components (local = R @ body).

        Returns
        -------
        ndarray, shape (3, 3)
            The rotation matrix [-] from body to local components.

        Raises
        ------
        ModelError
            If ``orientation`` is parallel to the member.
        """
        ex = np.subtract(self.end, self.start) / self.length
        ref = np.asarray(self.orientation if self.orientation is not None
                         else ((0.0, 1.0, 0.0) if abs(ex[1]) < 0.9 else (0.0, 0.0, 1.0)), dtype=float)
        ey = ref - ex * (ref @ ex)
        if np.linalg.norm(ey) < 1e-9 * max(np.linalg.norm(ref), 1.0):
            raise ModelError(f"Beam.orientation {tuple(map(float, ref))} is parallel to the member")
        ey /= np.linalg.norm(ey)
        ez = np.cross(ex, ey)
        return np.vstack([ex, ey, ez])


@dataclass(frozen=True)
class PointMassAt:
    """A lumped mass at a node of a beam structure.

    Parameters
    ----------
    position : array_like, shape (3,)
        The node, body frame [m].
    mass : float
        [kg].
    inertia : array_like, optional
        Rotary inertia about the node: 3 principal values or a 3x3 matrix in body axes
        [kg m^2]; default zero.

    Examples
    --------
    >>> from linflex import PointMassAt
    >>> tip = PointMassAt((2, 0, 0), 5.0, inertia=(0.1, 0.1, 0.2))   # [m], [kg], [kg m^2]
    >>> tip.inertia_matrix().diagonal().tolist()
    [0.1, 0.1, 0.2]
    """

    position: tuple[float, float, float]
    mass: float
    inertia: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        position = np.asarray(self.position, dtype=float) if np.ndim(self.position) == 1 else None
        if position is None or position.shape != (3,) or not np.all(np.isfinite(position)):
            raise ModelError(f"PointMassAt.position must be 3 finite coordinates [m], got {self.position!r}")
        object.__setattr__(self, "position", tuple(float(v) for v in position))
        try:
            object.__setattr__(self, "mass", check_positive(self.mass, "PointMassAt.mass"))
        except ModelError:
            raise ModelError(f"PointMassAt.mass must be positive [kg], got {self.mass!r}") from None
        if np.size(self.inertia) not in (3, 9):
            raise ModelError(f"PointMassAt.inertia must be 3 principal values or a 3x3 matrix [kg m^2], got "
                             f"{self.inertia!r}")
        J = self.inertia_matrix()
        if not np.allclose(J, J.T) or np.min(np.linalg.eigvalsh(J)) < -1e-12 * max(np.abs(J).max(), 1.0):
            raise ModelError(f"PointMassAt.inertia must be symmetric positive semi-definite, got {self.inertia!r}")

    def inertia_matrix(self) -> NDArray[np.float64]:
        """The rotary inertia as a matrix.

        Returns
        -------
        ndarray, shape (3, 3)
            Inertia about the node in body axes [kg m^2] (diagonal when given as 3 values).
        """
        J = np.asarray(self.inertia, dtype=float)
        return np.diag(J) if J.shape == (3,) else J.reshape(3, 3)


@functools.lru_cache(maxsize=256)
def _shape_functions(xi: float, L: float):
    """Translation (3x12) and rotation (3x12) interpolation, and first/second derivatives.

    Returns N_t, N_r, dN (axial strain, torsion rate, v', w' rows), d2N (v'', w'' rows),
    all in local axes; derivatives are with respect to x = xi L. Kept for equal arguments (read-only
    arrays): the elements of a member share their length, and a structure's modal data reads
    them three times (stiffness and mass, mass points, unit loads).
    """
    H = np.array([1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, L * (-xi**2 + xi**3)])
    dH = np.array([-6 * xi + 6 * xi**2, L * (1 - 4 * xi + 3 * xi**2), 6 * xi - 6 * xi**2, L * (-2 * xi + 3 * xi**2)]) / L
    d2H = np.array([-6 + 12 * xi, L * (-4 + 6 * xi), 6 - 12 * xi, L * (-2 + 6 * xi)]) / L**2
    lin = np.array([1 - xi, xi])
    dlin = np.array([-1.0, 1.0]) / L
    v_dofs, w_dofs = [1, 5, 7, 11], [2, 4, 8, 10]
    w_sign = np.array([1.0, -1.0, 1.0, -1.0])  # w' = -ty
    N_t = np.zeros((3, 12))
    N_r = np.zeros((3, 12))
    N_t[0, [0, 6]] = lin
    N_t[1, v_dofs] = H
    N_t[2, w_dofs] = H * w_sign
    N_r[0, [3, 9]] = lin
    N_r[2, v_dofs] = dH  # tz = v'
    N_r[1, w_dofs] = -dH * w_sign  # ty = -w'
    strain = np.zeros((4, 12))
    strain[0, [0, 6]] = dlin  # u'
    strain[1, [3, 9]] = dlin  # tx'
    strain[2, v_dofs] = d2H  # v''
    strain[3, w_dofs] = d2H * w_sign  # w''
    slope = np.zeros((2, 12))
    slope[0, v_dofs] = dH  # v'
    slope[1, w_dofs] = dH * w_sign  # w'
    for matrix in (N_t, N_r, strain, slope):
        matrix.setflags(write=False)
    return N_t, N_r, strain, slope


@functools.lru_cache(maxsize=64)
def _element_matrices(beam: Beam, L: float):
    """Local stiffness, mass and unit-axial-force geometric stiffness (12x12 each, read-only;
    kept for equal arguments: a member's elements are alike)."""
    K = np.zeros((12, 12))
    M = np.zeros((12, 12))
    G = np.zeros((12, 12))
    D = np.diag([beam.EA, beam.GJ, beam.EIz, beam.EIy])
    for xi, w in zip(GAUSS_XI, GAUSS_W):
        N_t, N_r, strain, slope = _shape_functions(xi, L)
        K += w * L * strain.T @ D @ strain
        M += w * L * (beam.mass_per_length * N_t.T @ N_t
                      + beam.torsional_inertia_per_length * np.outer(N_r[0], N_r[0]))
        G += w * L * slope.T @ slope
    for matrix in (K, M, G):
        matrix.setflags(write=False)
    return K, M, G


@dataclass(frozen=True)
class _Mesh:
    nodes: NDArray  # (n_nodes, 3)
    elements: list  # (beam, node_a, node_b, R, T, L, p0): T = diag(R, R, R, R), L the element length


def _mesh(beams: Sequence[Beam], tol: float) -> _Mesh:
    nodes: list[NDArray] = []

    def node_at(point):
        if nodes:
            distance = np.linalg.norm(np.asarray(nodes) - point, axis=1)
            i = int(np.argmax(distance <= tol))
            if distance[i] <= tol:
                return i
        nodes.append(np.asarray(point, dtype=float))
        return len(nodes) - 1

    elements = []
    for beam in beams:
        R = beam.rotation()
        T = scipy.linalg.block_diag(R, R, R, R)
        a, b = np.asarray(beam.start), np.asarray(beam.end)
        for k in range(beam.elements):
            p0 = a + (b - a) * k / beam.elements
            p1 = a + (b - a) * (k + 1) / beam.elements
            elements.append((beam, node_at(p0), node_at(p1), R, T, beam.length / beam.elements, p0))
    return _Mesh(np.array(nodes), elements)


def _element_dofs(na: int, nb: int) -> NDArray:
    return np.concatenate([np.arange(6 * na, 6 * na + 6), np.arange(6 * nb, 6 * nb + 6)])


@dataclass(frozen=True, eq=False)
class BeamStructure:
    """Assembled finite-element matrices of a beam structure (no boundary conditions).

    Attributes
    ----------
    K, M : ndarray, shape (6 n_nodes, 6 n_nodes)
        Stiffness [N/m, N m/rad] and consistent mass [kg, kg m^2] in body axes; the freedoms of
        node ``j`` are ``6 j .. 6 j + 5``: translations x, y, z [m] then rotations [rad].
    nodes : ndarray, shape (n_nodes, 3)
        Node positions [m].
    """

    K: NDArray[np.float64]
    M: NDArray[np.float64]
    nodes: NDArray[np.float64]
    _mesh: _Mesh
    _unit_geometric: list
    _lumped: list
    tol: float

    def dofs(self, point: ArrayLike) -> NDArray[np.int_]:
        """The six freedoms of the node at ``point``.

        Parameters
        ----------
        point : array_like, shape (3,)
            A node position in the body frame [m], matched within ``tol``.

        Returns
        -------
        ndarray of int, shape (6,)
            Indices into ``K`` and ``M``: translations x, y, z [m] then rotations [rad].

        Raises
        ------
        ModelError
            If no node lies at ``point``.
        """
        index = _find_node(self.nodes, point, self.tol, "point")
        return np.arange(6 * index, 6 * index + 6)


def assemble_beams(beams: Beam | Sequence[Beam], *, point_masses: Sequence[PointMassAt] = (),
                   tol: float = 1e-9) -> BeamStructure:
    """Stiffness and consistent mass matrices of beam members and lumped masses.

    Members whose ends coincide (within ``tol`` [m]) are rigidly joined. The result has no
    boundary conditions: a free structure has six rigid-body modes.


    Parameters
    ----------
    beams : Beam or sequence of Beam
        The members.
    point_masses : sequence of PointMassAt, optional
        Lumped masses at nodes.
    tol : float, optional
        Distance [m] under which two points are the same node.

    Returns
    -------
    BeamStructure
        Stiffness and mass matrices and the node positions [m].

    Raises
    ------
    ModelError
        For no members, or a point mass that is not at a node.

    Examples
    --------
    A free 1 m beam in 4 elements: 5 nodes, 30 freedoms, six rigid-body modes, and the first
    bending frequency near the exact 22.37 rad/s (``22.373 sqrt(EI / (m L^4))``):

    >>> import numpy as np
    >>> from linflex import Beam, assemble_beams, structural_modes
    >>> beam = Beam((0, 0, 0), (1, 0, 0), EA=1e3, EIy=1.0, EIz=1.0, GJ=1.0, mass_per_length=1.0,
    ...             torsional_inertia_per_length=0.01, elements=4)
    >>> s = assemble_beams(beam)
    >>> s.K.shape, s.nodes.shape
    ((30, 30), (5, 3))
    >>> w = structural_modes(s.K, s.M).frequencies
    >>> int(np.sum(np.abs(w) < 1e-3)), round(float(w[6]), 1)
    (6, 22.4)
    """
    beams = [beams] if isinstance(beams, Beam) else list(beams)
    if not beams:
        raise ModelError("no beams given")
    for i, beam in enumerate(beams):
        if not isinstance(beam, Beam):
            raise ModelError(f"beams[{i}] must be a Beam, got {type(beam).__name__} {beam!r}")
    tol = check_positive(tol, "tol")
    mesh = _mesh(beams, tol)
    n_dof = 6 * len(mesh.nodes)
    K = np.zeros((n_dof, n_dof))
    M = np.zeros((n_dof, n_dof))
    unit_geometric = []
    lumped = [(_find_node(mesh.nodes, pm.position, tol, f"point_masses[{i}]"), pm) for i, pm in enumerate(point_masses)]
    for index, pm in lumped:
        dofs = np.arange(6 * index, 6 * index + 6)
        M[np.ix_(dofs, dofs)] += scipy.linalg.block_diag(pm.mass * np.eye(3), pm.inertia_matrix())
    for beam, na, nb, _, T, L, _ in mesh.elements:
        k, m, g = _element_matrices(beam, L)
        dofs = _element_dofs(na, nb)
        K[np.ix_(dofs, dofs)] += T.T @ k @ T
        M[np.ix_(dofs, dofs)] += T.T @ m @ T
        unit_geometric.append(T.T @ g @ T)
    for matrix in (K, M):
        matrix.setflags(write=False)
    return BeamStructure(K, M, mesh.nodes, mesh, unit_geometric, lumped, tol)


def beam_modal_data(
    beams: Beam | Sequence[Beam],
    n_modes: int,
    *,
    damping: float | ArrayLike = 0.0,
    clamped: Sequence[ArrayLike] = ((0.0, 0.0, 0.0),),
    nodes: dict[str, ArrayLike] | None = None,
    point_masses: Sequence[PointMassAt] = (),
    geometric_stiffness: bool = True,
    unit_loads: int | None = None,
    tol: float = 1e-9,
) -> ModalData:
    """Modes of a structure of beam members clamped at given points (cantilevered modes).

    Parameters
    ----------
    beams : Beam or sequence of Beam
        Members; ends that coincide (within ``tol`` [m]) are rigidly joined.
    n_modes : int
        Number of lowest modes to keep.
    damping : float or array_like
        Modal damping ratio(s) [-], one for all modes or one per mode.
    clamped : sequence of points, or one point
        Points [m] whose six freedoms are fixed; the body's reference point (origin) by default,
        as the flexible-body formulation requires (the reference frame is the body frame).
    nodes : dict of str to point, optional
        Named attachment points (sensors, actuators, wheels) that must be finite-element nodes;
        every end point of a member is also available as ``"<member index>.start/end"``.
    point_masses : sequence of PointMassAt
        Lumped masses (tip masses, panels, instruments) at nodes; they enter the mass matrix,
        the mass points of the modal data and the unit inertia loads.
    geometric_stiffness : bool
        Compute the projected geometric stiffness of the unit inertia loads.
    unit_loads : {None, 12, 21}
        How many unit inertia loads: 12 (the forces of the mass points' translational inertia)
        or 21 (also the torques of their rotary inertia, Banerjee Eqs. 5.19-5.21); default 21
        when the structure has rotary inertia (``torsional_inertia_per_length`` or a point
        mass's ``inertia``), else 12.
    tol : float
        Distance [m] under which two points are the same node.

    Returns
    -------
    ModalData
        Mass points at the Gauss points of every element (exact for the consistent mass),
        mass-normalized modes, frequencies [rad/s], damping, named nodes and, if requested,
        ``geometric_stiffness`` of shape (``unit_loads``, n_modes, n_modes).

    Raises
    ------
    ModelError
        For a clamped point or named node that is not a node, a structure that is not
        restrained (a part held by no clamped point), a lowest eigenvalue within round-off
        (stiffnesses too disparate for double precision), more modes than freedoms, damping not
        one ratio or one per mode, or ``unit_loads`` not None, 12 or 21.

    Examples
    --------
    A 1 m cantilever: the first bending frequency is ``1.8751^2 sqrt(EI / (m L^4))`` = 3.516 rad/s
    (twice: it bends about y and z alike).

    >>> from linflex import Beam, beam_modal_data
    >>> beam = Beam((0, 0, 0), (1, 0, 0), EA=1e6, EIy=1.0, EIz=1.0, GJ=1.0, mass_per_length=1.0, elements=8)
    >>> data = beam_modal_data(beam, 2)
    >>> [round(float(w), 3) for w in data.frequencies]
    [3.516, 3.516]
    """
    if unit_loads not in (None, 12, 21):
        raise ModelError(f"unit_loads must be None, 12 or 21, got {unit_loads!r}")
    beams = [beams] if isinstance(beams, Beam) else list(beams)
    structure = assemble_beams(beams, point_masses=point_masses, tol=tol)
    if np.shape(clamped) == (3,) and np.ndim(clamped[0]) == 0:  # one point, not a sequence of them
        clamped = [clamped]
    mesh, K, M = structure._mesh, np.array(structure.K), np.array(structure.M)
    n_dof = K.shape[0]
    unit_geometric = structure._unit_geometric
    lumped = structure._lumped
    fixed = []
    for point in clamped:
        index = _find_node(mesh.nodes, point, tol, "clamped")
        fixed.extend(range(6 * index, 6 * index + 6))
    free = np.setdiff1d(np.arange(n_dof), fixed)
    _check_restrained(mesh, fixed)
    lam, Phi = _modes(K, M, free, n_modes)  # mass-normalized: Phi^T M Phi = I

    # Mass points at the Gauss points of each element.
    positions, masses, inertias, translations, rotations = [], [], [], [], []
    for beam, na, nb, R, T, L, p0 in mesh.elements:
        modal = T @ Phi[_element_dofs(na, nb)]  # local element dofs per mode
        for xi, w in zip(GAUSS_XI, GAUSS_W):
            N_t, N_r, _, _ = _shape_functions(xi, L)
            positions.append(p0 + xi * L * R[0])
            masses.append(w * L * beam.mass_per_length)
            inertias.append(w * L * beam.torsional_inertia_per_length * np.outer(R[0], R[0]))
            translations.append(R.T @ N_t @ modal)
            rotations.append(R.T @ N_r @ modal)
    for index, pm in lumped:
        positions.append(mesh.nodes[index])
        masses.append(pm.mass)
        inertias.append(pm.inertia_matrix())
        translations.append(Phi[6 * index:6 * index + 3])
        rotations.append(Phi[6 * index + 3:6 * index + 6])
    positions = np.array(positions)
    masses = np.array(masses)

    named = {}
    for i, beam in enumerate(beams):
        named[f"{i}.start"] = beam.start
        named[f"{i}.end"] = beam.end
    named.update(nodes or {})
    node_names, node_positions, node_translations, node_rotations = [], [], [], []
    for name, point in named.items():
        index = _find_node(mesh.nodes, point, tol, f"nodes[{name!r}]")
        node_names.append(name)
        node_positions.append(mesh.nodes[index])
        node_translations.append(Phi[6 * index:6 * index + 3])
        node_rotations.append(Phi[6 * index + 3:6 * index + 6])

    S = None
    if geometric_stiffness:
        inertias = np.array(inertias)
        rotary = bool(np.any(inertias)) if unit_loads is None else unit_loads == 21
        S = _unit_load_geometric_stiffness(mesh, K, free, Phi, positions, masses, inertias, unit_geometric, lumped,
                                           rotary=rotary)
    return ModalData(
        positions=positions,
        masses=masses,
        inertias=np.array(inertias),
        translations=np.array(translations),
        rotations=np.array(rotations),
        frequencies=np.sqrt(lam),
        damping=_modal_damping(damping, lam.size),
        node_names=tuple(node_names),
        node_positions=np.array(node_positions),
        node_translations=np.array(node_translations),
        node_rotations=np.array(node_rotations),
        geometric_stiffness=S,
        source=f"beam_modal_data: {len(beams)} member(s), {len(mesh.elements)} elements, consistent mass",
    )


def _check_restrained(mesh: _Mesh, fixed: list) -> None:
    """Refuse a structure with a part that no clamped point holds.

    Joints are rigid and every member has positive stiffness in all six freedoms, so the
    structure is restrained exactly when each connected part of the mesh holds a clamped node: a
    topological test, free of the eigenvalues' round-off (a floating part's rigid-body modes come
    out of LAPACK at any frequency up to the round-off of the stiffest member).
    """
    part = list(range(len(mesh.nodes)))

    def root(i: int) -> int:
        while part[i] != i:
            part[i] = part[part[i]]
            i = part[i]
        return i

    for _, na, nb, *_ in mesh.elements:
        part[root(na)] = root(nb)
    held = {root(dof // 6) for dof in fixed}
    loose = [i for i in range(len(mesh.nodes)) if root(i) not in held]
    if loose:
        raise ModelError(f"beam_modal_data: the structure is not restrained: the part with the node at "
                         f"{tuple(float(x) for x in mesh.nodes[loose[0]])} [m] is held by no clamped point (clamp "
                         "it, or join its members: ends closer than tol [m] are one node)")


def _modes(K: NDArray, M: NDArray, free: NDArray, n_modes: int):
    """Lowest eigenpairs of ``K phi = lambda M phi`` on the free freedoms.

    Freedoms without mass (for example torsion when the torsional inertia is zero) are
    condensed statically, which is exact for them: with ``a`` the massive and ``z`` the massless
    freedoms, ``K_zz x_z = -K_za x_a``. The modes are mass-normalized.
    """
    Kff, Mff = K[np.ix_(free, free)], M[np.ix_(free, free)]
    massless = np.all(Mff == 0.0, axis=1)
    a, z = np.flatnonzero(~massless), np.flatnonzero(massless)
    n_modes = _mode_count(n_modes, "n_modes", a.size, " (freedoms with mass)")
    try:
        if z.size:
            recover = -scipy.linalg.solve(Kff[np.ix_(z, z)], Kff[np.ix_(z, a)], assume_a="sym")
            K_aa = Kff[np.ix_(a, a)] + Kff[np.ix_(a, z)] @ recover
        else:
            K_aa = Kff
        # A few modes beyond the last kept one: a cut through a repeated frequency is resolved below.
        extra = min(a.size, n_modes + 6)
        lam, vec_a = scipy.linalg.eigh(K_aa, Mff[np.ix_(a, a)], subset_by_index=[0, extra - 1])
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ModelError(f"beam_modal_data: the modal problem cannot be solved ({err}): the structure is "
                         "not restrained (clamp it) or has no mass") from err
    # Eigenvalues within their round-off (eps times the largest, which eps ||K||_1 / ||M||_1
    # underestimates 3 to 80 times on beams) are one repeated eigenvalue.
    noise = 1e3 * np.finfo(float).eps * np.linalg.norm(K_aa, 1) / np.linalg.norm(Mff[np.ix_(a, a)], 1)
    # Restraint is checked by the mesh's topology (_check_restrained); an eigenvalue within the
    # round-off here comes of stiffnesses too disparate for double precision (absurd units, say),
    # whose modes would be noise. Both scales are unit-free: a soft structure is not refused.
    if lam[0] <= max(1e-10 * abs(lam[-1]), noise):
        raise ModelError(f"beam_modal_data: the lowest eigenvalue {lam[0]:.3g} (rad/s)^2 is round-off (the "
                         f"{lam.size}th is {lam[-1]:.3g}): the structure is not restrained, or its stiffnesses differ "
                         "too much for double precision (check the units: m, N, N m^2, kg/m)")
    lam, vec_a = _canonical_clusters(lam, vec_a, n_modes, noise)
    vec = np.zeros((free.size, n_modes))
    vec[a] = vec_a
    if z.size:
        vec[z] = recover @ vec_a
    Phi = np.zeros((K.shape[0], n_modes))
    Phi[free] = vec
    return lam, Phi


#: Eigenvalues closer than this share of their size (plus their round-off) are one repeated
#: eigenvalue (a symmetric cross-section bends alike in two planes: exact in exact arithmetic,
#: round-off apart in LAPACK's).
REPEATED_SHARE = 1e-9


def _canonical_clusters(lam: NDArray, vec: NDArray, n_modes: int, noise: float = 0.0):
    """The lowest ``n_modes`` eigenpairs with a fixed basis in each repeated eigenvalue's space.

    Within a repeated eigenvalue the eigenvectors are any orthonormal basis of its space, and
    LAPACK's choice moves with round-off: a beam whose ``EI`` changes by 1 % gets its two equal
    bending modes rotated about the beam's axis, and when ``n_modes`` cuts through such a pair the
    kept mode (and so the model) depends on that choice. Here each cluster's basis diagonalizes the
    fixed form ``V^T diag(1, 2, ..., n) V`` (its vectors ordered by that form, largest entry
    positive), so equal structures give the same modes to round-off whatever their scale.
    ``noise`` [eigenvalue units]: the eigenvalues' absolute round-off.
    """
    weights = np.arange(1.0, vec.shape[0] + 1.0)
    start = 0
    vec = vec.copy()
    while start < lam.size:
        stop = start + 1
        while stop < lam.size and lam[stop] - lam[stop - 1] <= REPEATED_SHARE * abs(lam[stop]) + noise:
            stop += 1
        if stop - start > 1:
            V = vec[:, start:stop]
            _, R = np.linalg.eigh(V.T @ (weights[:, None] * V))
            V = V @ R
            biggest = np.argmax(np.abs(V), axis=0)
            vec[:, start:stop] = V * np.sign(V[biggest, np.arange(V.shape[1])])
        start = stop
    return lam[:n_modes], vec[:, :n_modes]


def _find_node(nodes: NDArray, point: ArrayLike, tol: float, what: str) -> int:
    given = point
    try:
        point = np.asarray(point, dtype=float)
    except (TypeError, ValueError):
        point = None
    if point is None or point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ModelError(f"{what}: a point must be 3 finite coordinates [m], got {given!r}")
    distance = np.linalg.norm(nodes - point, axis=1)
    index = int(np.argmin(distance))
    if distance[index] > tol:
        raise ModelError(f"{what}: point {tuple(map(float, point))} is not a node of the beam mesh "
                         f"(nearest node at {tuple(map(float, nodes[index]))}, {distance[index]:.3g} m away)")
    return index


def _unit_inertia_loads(mass: float, x: NDArray) -> NDArray:
    """Columns i = 1..12 of the nodal inertia force ``-m [U3, x1 U3, x2 U3, x3 U3]`` (Eq. 5.16)."""
    return -mass * np.hstack([np.eye(3), x[0] * np.eye(3), x[1] * np.eye(3), x[2] * np.eye(3)])


def _unit_inertia_torques(J: NDArray) -> NDArray:
    """Columns i = 13..21 of the nodal inertia torque ``-[...] (A_13..A_21)`` (Eqs. 5.19-5.21).

    With the factors of :func:`linflex.dynamics._flexible.inertia_load_factors` this is
    ``-(J w' + w x J w)`` for nodal inertia ``J`` (body axes)::

        A_13..15 = w',  A_16 = w1 w2,  A_17 = w2 w3,  A_18 = w3 w1,
        A_19 = w1^2 - w2^2,  A_20 = w2^2 - w3^2,  A_21 = w3^2 - w1^2
    """
    (I11, I12, I13), (_, I22, I23), (_, _, I33) = J
    return -np.array([[I11, I12, I13, I13, I33 - I22, -I12, 0.0, I23, 0.0],
                      [I12, I22, I23, -I23, I12, I11 - I33, 0.0, 0.0, I13],
                      [I13, I23, I33, I22 - I11, -I13, I23, I12, 0.0, 0.0]])


def _unit_load_geometric_stiffness(mesh, K, free, Phi, positions, masses, inertias, unit_geometric, lumped, *,
                                   rotary: bool) -> NDArray:
    """``S^(i) = Phi^T K_g^(i) Phi`` for the unit inertia loads of Banerjee Eqs. 5.15-5.23.

    Load case i = 1..12 puts the nodal inertia force ``-m_G [U3, x1 U3, x2 U3, x3 U3] e_i`` on
    every mass point G (x its undeformed body position); with ``rotary``, load cases 13..21 put
    the inertia torque of its rotary inertia ``J_G`` (:func:`_unit_inertia_torques`) on it. Both
    are applied as consistent nodal loads (through the translation and the rotation
    interpolation); the linear static solution of the clamped structure gives each element's
    axial force, and the element geometric stiffness is that force times the unit-force matrix.
    A couple produces axial forces only where the structure is statically indeterminate (a
    clamped tree carries it by bending and torsion alone), so the last 9 often vanish.
    """
    n_dof = K.shape[0]
    n_loads = 21 if rotary else 12
    loads = np.zeros((n_dof, n_loads))
    g = 0
    for _beam, na, nb, R, T, L, _ in mesh.elements:
        dofs = _element_dofs(na, nb)
        for xi in GAUSS_XI:
            N_t, N_r, _, _ = _shape_functions(xi, L)
            loads[dofs, :12] += T.T @ N_t.T @ R @ _unit_inertia_loads(masses[g], positions[g])
            if rotary:
                loads[dofs, 12:] += T.T @ N_r.T @ R @ _unit_inertia_torques(inertias[g])
            g += 1
    for index, pm in lumped:
        loads[6 * index:6 * index + 3, :12] += _unit_inertia_loads(pm.mass, mesh.nodes[index])
        if rotary:
            loads[6 * index + 3:6 * index + 6, 12:] += _unit_inertia_torques(pm.inertia_matrix())
    displacement = np.zeros((n_dof, n_loads))
    displacement[free] = scipy.linalg.solve(K[np.ix_(free, free)], loads[free], assume_a="pos")
    S = np.zeros((n_loads, Phi.shape[1], Phi.shape[1]))
    for (beam, na, nb, R, _, L, _), kg_unit in zip(mesh.elements, unit_geometric):
        dofs = _element_dofs(na, nb)
        axial = R[0] @ (displacement[dofs[6:9]] - displacement[dofs[0:3]])  # elongation per load case
        force = beam.EA * axial / L
        projected = Phi[dofs].T @ kg_unit @ Phi[dofs]
        S += force[:, None, None] * projected[None]
    return S
