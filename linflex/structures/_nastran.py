"""NASTRAN models: Craig-Bampton components and their matrices, read through pyyeti.

Finite-element models of spacecraft come from NASTRAN as Craig-Bampton (CB) components: a mass
and a stiffness matrix on the a-set, which holds the boundary (b-set) freedoms of the interface
grid points and the modal (q-set) coordinates of the fixed-interface modes (SPOINTs). Two file
kinds are read, both with pyyeti (``pip install "linflex[nastran]"``):

- ``.op4`` written by ``EXTSEOUT(..., MATOP4=...)``: matrices ``KXX``/``MXX`` (or ``KAA``/``MAA``);
  the freedom map comes from the ``.asm`` (``ASMBULK``) or ``.pch`` (``EXTBULK``) file of the
  same name next to it;
- ``.op2`` written by the nas2cam DMAP (with its ``.op4`` of the same name): the USET table and
  ``MAA``/``KAA`` of one superelement.

:func:`read_nastran` returns a :class:`NastranModel`; :func:`nastran_modal_data` (and
:func:`linflex.load_modal_data` for these suffixes) turns it into a :class:`~linflex.ModalData` of a
body whose interface grid points are rigidly attached to the body frame (the b-set moves as one
rigid body: the cantilevered flexible body of the large-motion formulation,
docs/reference/multibody-formulations-banerjee.md, section 5).

Reduced matrices do not say where the mass of the interior sits. The modal data therefore holds
*equivalent* mass points that reproduce the CB mass matrix exactly in the body frame: the rigid
mass ``R^T M_bb R`` (mass, centre of mass, inertia), the rigid-elastic coupling ``R^T M_bq`` and
the modal mass ``M_qq``: one mass point at the centre of mass carries the rigid mass and the
coupling, and pairs of massless rotary points with opposite shapes (whose couplings cancel) carry
the rest of the modal mass. Everything linear about rest (the mass and stiffness matrices of the
body in the scene) is exact. The integrals of second order in the shapes (``d``, ``N``, ``P``,
terms of a spinning body) and the geometric stiffness need the physical mass distribution, which
the reduced matrices do not hold: they are those of the equivalent points (``geometric_stiffness``
is None), and the :attr:`~linflex.ModalData.source` says so.

A scene's ``modal_data = "component.op4"`` reads the component with the defaults of
:func:`nastran_modal_data` (SI units, body origin at the first interface grid, all modes). For a
model in other units or another origin, convert once and name the result in the scene::

    nastran_modal_data("truss.op4", length_unit=1e-3, reference=(600, 150, 150)).save("truss.npz")
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..system._errors import MethodUnavailableError, ModelError
from ..system._signals import check_positive, frozen_array
from ._components import synthesize
from ._modal_data import FILE_READERS, ModalData, _modal_damping, _mode_count

__all__ = ["NastranModel", "read_nastran", "nastran_modal_data", "join_components"]

INSTALL = 'pip install "linflex[nastran]"'


def _pyyeti(path: Path):
    try:
        with np.printoptions():  # pyyeti sets numpy's legacy print style when imported: keep the user's
            from pyyeti.nastran import bulk, n2p, op2, op4
    except ImportError as err:
        raise MethodUnavailableError(f"{path}: reading NASTRAN files needs pyyeti; install it with {INSTALL}") from err
    return bulk, n2p, op2, op4


@dataclass(frozen=True, eq=False)
class NastranModel:
    """A NASTRAN component: a-set mass and stiffness with its freedom map.

    Attributes
    ----------
    K, M : ndarray, shape (n, n)
        Stiffness and mass on the a-set, in the model's units (for example N/mm and kg with
        lengths in mm); grid freedoms in each grid's output coordinate system.
    dof_map : ndarray of int, shape (n, 2)
        ``(id, component)`` of each a-set freedom: component 1..6 for a grid point, 0 for a
        scalar point (the modal coordinates of a CB component).
    uset : pandas.DataFrame
        pyyeti's USET table of the a-set (positions in the basic system [model length] and
        coordinate transforms), as :func:`pyyeti.nastran.n2p.rbgeom_uset` takes it.
    boundary : ndarray of int
        Indices of the grid (b-set) freedoms in ``K`` and ``M``.
    modal : ndarray of int
        Indices of the scalar-point (q-set) freedoms.
    source : str
        The file read (and the superelement), for messages.
    recovery : ndarray, shape (n_out, n), or None
        Displacement recovery of output grid points from the a-set (EXTSEOUT's ``MUG1``), in
        their output coordinate systems [model length, rad].
    recovery_dof_map : ndarray of int, shape (n_out, 2), or None
        ``(grid, component)`` of the rows of ``recovery`` (the ``TUG1`` table of the ``.pch``).
    grid_uset : pandas.DataFrame or None
        USET table of every grid point of the component's bulk data (``.dat``, ``.bdf`` or
        ``.blk`` of the same name), for the positions of the output grid points.
    """

    K: NDArray[np.float64]
    M: NDArray[np.float64]
    dof_map: NDArray[np.int_]
    uset: object
    boundary: NDArray[np.int_]
    modal: NDArray[np.int_]
    source: str
    recovery: NDArray[np.float64] | None = None
    recovery_dof_map: NDArray[np.int_] | None = None
    grid_uset: object = None

    @property
    def grids(self) -> tuple[int, ...]:
        """Ids of the grid points of the a-set, in order."""
        ids = self.dof_map[self.boundary, 0]
        return tuple(int(g) for g in dict.fromkeys(ids.tolist()))

    def grid_position(self, grid: int) -> NDArray[np.float64]:
        """Position of a grid point in the basic system.

        Parameters
        ----------
        grid : int
            A grid id of the a-set.

        Returns
        -------
        ndarray, shape (3,)
            Basic coordinates [model length unit].

        Raises
        ------
        ModelError
            If the model has no such grid point (the message lists those it has).
        """
        if int(grid) not in self.grids:
            raise ModelError(f"{self.source}: no grid point {grid} in the a-set; grid points: "
                             f"{', '.join(map(str, self.grids))}")
        row = self.uset.loc[(int(grid), 1)]
        return np.array([row["x"], row["y"], row["z"]], dtype=float)

    def rigid_body_modes(self, reference=(0.0, 0.0, 0.0)) -> NDArray[np.float64]:
        """Rigid-body motion of the boundary freedoms about a reference point.

        Parameters
        ----------
        reference : array_like, shape (3,)
            Reference point in the basic system [model length unit].

        Returns
        -------
        ndarray, shape (len(boundary), 6)
            Displacement of each b-set freedom (in its output system) for unit translations x, y,
            z [model length] and small rotations about x, y, z [rad] of the basic system at
            ``reference``.
        """
        _, n2p, _, _ = _pyyeti(Path(self.source))
        return np.asarray(n2p.rbgeom_uset(self.uset.iloc[self.boundary], np.asarray(reference, float).reshape(1, 3)))


def _check_matrices(K, M, where: str) -> tuple[NDArray, NDArray]:
    K, M = np.asarray(K, dtype=float), np.asarray(M, dtype=float)
    if K.ndim != 2 or K.shape[0] != K.shape[1] or M.shape != K.shape:
        raise ModelError(f"{where}: mass {M.shape} and stiffness {K.shape} matrices must be square and of the "
                         "same size")
    for name, A in (("stiffness", K), ("mass", M)):
        if not np.all(np.isfinite(A)):
            raise ModelError(f"{where}: the {name} matrix has non-finite entries")
        scale = max(float(np.max(np.abs(A))), 1e-300)
        if np.max(np.abs(A - A.T)) > 1e-6 * scale:  # single-precision .op4 files round each entry
            raise ModelError(f"{where}: the {name} matrix is not symmetric")
    return (K + K.T) / 2, (M + M.T) / 2


def _companion_uset(path: Path, bulk):
    for suffix in (".asm", ".pch"):
        other = path.with_suffix(suffix)
        if other.is_file():
            try:
                if suffix == ".asm":
                    return bulk.asm2uset(str(other), try_rdextrn=path.with_suffix(".pch").exists())[0], other
                return bulk.bulk2uset(str(other))[0], other
            except Exception as err:  # pyyeti raises many kinds on malformed bulk data
                raise ModelError(f"{other}: cannot read the freedom map of {path.name}: {err}") from err
    raise ModelError(f"{path}: missing DOF map: an EXTSEOUT .op4 needs its .asm (ASMBULK) or .pch (EXTBULK) file "
                     f"of the same name ({path.with_suffix('.asm').name} or {path.with_suffix('.pch').name})")


def read_nastran(path, *, superelement: int | None = None) -> NastranModel:
    """Read a NASTRAN Craig-Bampton component or reduced model.

    Parameters
    ----------
    path : str or path-like
        An ``.op4`` file of ``EXTSEOUT`` (with its ``.asm`` or ``.pch`` next to it), or a nas2cam
        ``.op2`` file (with its ``.op4``).
    superelement : int, optional
        For a nas2cam ``.op2`` with several superelements: which one; required then.

    Returns
    -------
    NastranModel
        Mass and stiffness on the a-set (model units) with the freedom map.

    Raises
    ------
    MethodUnavailableError
        Without pyyeti (the message names ``pip install "linflex[nastran]"``).
    ModelError
        For a missing file, a file of another kind, a missing freedom map, matrices of
        inconsistent sizes, or an unknown or ambiguous superelement; the message names the file.

    Examples
    --------
    The inboard truss of pyyeti's test models (an EXTSEOUT component with 4 boundary grids):

    >>> import pathlib, pyyeti
    >>> from linflex.structures import read_nastran
    >>> tests = pathlib.Path(pyyeti.__file__).parent / "tests"
    >>> model = read_nastran(tests / "nas2cam_extseout" / "inboard.op4")
    >>> model.grids, model.K.shape, model.modal.size
    ((3, 11, 19, 27), (32, 32), 8)
    """
    path = Path(path)
    bulk, _, op2, op4 = _pyyeti(path)
    if not path.is_file():  # pyyeti opens a file-selection window for a directory: refuse it here
        raise ModelError(f"{path}: no such NASTRAN file" + (" (a directory)" if path.is_dir() else ""))
    source = str(path)
    if path.suffix.lower() == ".op4":
        try:
            mats = op4.read(str(path))
        except Exception as err:
            raise ModelError(f"{path}: not an .op4 file pyyeti can read: {err}") from err
        names = {k.lower(): k for k in mats}
        pair = next(((k, m) for k, m in (("kxx", "mxx"), ("kaa", "maa")) if k in names and m in names), None)
        if pair is None:
            raise ModelError(f"{path}: unsupported .op4 file: no KXX/MXX (EXTSEOUT) or KAA/MAA matrices "
                             f"(found {', '.join(sorted(mats)) or 'none'})")
        K, M = (np.asarray(mats[names[k]]) for k in pair)
        uset, _ = _companion_uset(path, bulk)
        recovery, recovery_dof_map, grid_uset = _recovery(path, mats, names, bulk)
    elif path.suffix.lower() == ".op2":
        if not path.with_suffix(".op4").is_file():
            raise ModelError(f"{path}: missing DOF map: a nas2cam .op2 needs its .op4 of the same name "
                             f"({path.with_suffix('.op4').name})")
        try:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                nas = op2.rdnas2cam(str(path.with_suffix("")))
        except Exception as err:
            raise ModelError(f"{path}: unsupported .op2 file (not a nas2cam output2 file with USET and "
                             f"MAA/KAA): {err}") from err
        have = sorted(set(nas.get("maa", {})) & set(nas.get("kaa", {})) & set(nas.get("uset", {})))
        if not have:
            raise ModelError(f"{path}: unsupported .op2 file: no superelement has MAA, KAA and a USET table")
        if superelement is None:
            if len(have) > 1:
                raise ModelError(f"{path}: several superelements ({', '.join(map(str, have))}); choose one with "
                                 "read_nastran(path, superelement=...)")
            superelement = have[0]
        if superelement not in have:
            raise ModelError(f"{path}: no superelement {superelement} with MAA and KAA; available: "
                             f"{', '.join(map(str, have))}")
        K, M = np.asarray(nas["kaa"][superelement]), np.asarray(nas["maa"][superelement])
        recovery = recovery_dof_map = grid_uset = None
        uset = nas["uset"][superelement]
        source = f"{path} (superelement {superelement})"
    else:
        raise ModelError(f"{path}: unsupported NASTRAN file kind {path.suffix!r}; use .op4 (EXTSEOUT) or .op2 "
                         "(nas2cam)")
    K, M = _check_matrices(K, M, source)
    dofs = np.array([[int(i), int(c)] for i, c in uset.index], dtype=int).reshape(-1, 2)
    if K.shape[0] != dofs.shape[0]:
        # the nas2cam USET of a superelement holds every freedom of its grids; keep the a-set rows
        aset = _aset_rows(uset)
        if aset is not None and aset.sum() == K.shape[0]:
            uset = uset[aset]
            dofs = dofs[aset]
        else:
            raise ModelError(f"{source}: the matrices have {K.shape[0]} rows but the freedom map has "
                             f"{dofs.shape[0]} a-set freedoms")
    boundary = np.flatnonzero(dofs[:, 1] > 0)
    modal = np.flatnonzero(dofs[:, 1] == 0)
    if recovery is not None and recovery.shape[1] != K.shape[0]:
        raise ModelError(f"{source}: MUG1 has {recovery.shape[1]} columns for {K.shape[0]} a-set freedoms")
    return NastranModel(frozen_array(K), frozen_array(M), frozen_array(dofs, dtype=None), uset, boundary, modal,
                        source, recovery, recovery_dof_map, grid_uset)


def _recovery(path: Path, mats: dict, names: dict, bulk):
    """MUG1 with its TUG1 rows (from the .pch), and the grid points of the bulk data, if present."""
    pch = path.with_suffix(".pch")
    if "mug1" not in names or not pch.is_file():
        return None, None, None
    mug1 = np.asarray(mats[names["mug1"]], dtype=float)
    try:
        rows = np.asarray(bulk.rddtipch(str(pch), "TUG1"), dtype=int).reshape(-1, 2)
    except Exception as err:  # pyyeti raises many kinds on malformed punch files
        raise ModelError(f"{pch}: cannot read the TUG1 table (rows of MUG1): {err}") from err
    if rows.shape[0] != mug1.shape[0]:
        raise ModelError(f"{pch}: TUG1 lists {rows.shape[0]} rows but MUG1 of {path.name} has {mug1.shape[0]}")
    grid_uset = None
    for suffix in (".dat", ".bdf", ".blk"):
        deck = path.with_suffix(suffix)
        if deck.is_file():
            try:
                import warnings

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    grid_uset = bulk.bulk2uset(str(deck))[0]
            except Exception as err:  # pyyeti raises many kinds on malformed bulk data
                raise ModelError(f"{deck}: cannot read the grid points of {path.name}: {err}") from err
            break
    return mug1, rows, grid_uset


def _aset_rows(uset):
    try:
        from pyyeti.nastran import n2p

        return np.asarray(n2p.mksetpv(uset, "g", "a"), dtype=bool)
    except Exception:
        return None


def nastran_modal_data(model, *, n_modes: int | None = None, reference=None, damping=0.0,
                       length_unit: float = 1.0, superelement: int | None = None) -> ModalData:
    """Modal data of a NASTRAN Craig-Bampton component whose interface is fixed to the body frame.

    The boundary grid points move with the body frame (a rigid interface), so the body's modes
    are the component's fixed-interface modes, solved from ``K_qq`` and ``M_qq``. Nodes, named
    ``"grid_<id>"``, are the interface grid points (fixed: zero mode shapes) and, for an EXTSEOUT
    component with ``MUG1`` in its ``.op4``, ``TUG1`` in its ``.pch`` and its bulk data (``.dat``,
    ``.bdf`` or ``.blk`` of the same name, for positions and output coordinate systems), every
    output grid point, with its mode shapes recovered by ``MUG1``. See the module documentation
    for the equivalent mass points.

    Parameters
    ----------
    model : NastranModel or str or path-like
        A model, or a file for :func:`read_nastran`.
    n_modes : int, optional
        Keep the lowest ``n_modes`` fixed-interface modes; all by default.
    reference : array_like, shape (3,), optional
        The body frame's origin in the basic system [model length unit]; default the first
        boundary grid point. Body axes are the basic axes.
    damping : float or array_like
        Modal damping ratio(s) [-].
    length_unit : float
        The model's length unit in metres (1e-3 for a model in mm, kg, s) [m]; positions,
        inertias and rotation shapes are converted to SI.
    superelement : int, optional
        Passed to :func:`read_nastran` for a path.

    Returns
    -------
    ModalData
        Equivalent mass points (exact mass matrix), fixed-interface frequencies [rad/s], damping
        [-] and the grid points as nodes (body frame: basic axes, origin at ``reference``).

    Raises
    ------
    ModelError
        For a model without boundary grid points, a boundary that does not carry the six
        rigid-body motions, a stiffness that resists rigid-body motion or couples boundary and
        modal freedoms (more than round-off), a fixed-interface problem without modes, or a rigid
        inertia that is singular.

    Examples
    --------
    The inboard truss of pyyeti's tests: the lowest fixed-interface frequencies as NASTRAN prints
    them (inboard.out: 38.51181 and 38.51677 rad/s):

    >>> import pathlib, pyyeti
    >>> from linflex.structures import nastran_modal_data
    >>> tests = pathlib.Path(pyyeti.__file__).parent / "tests"
    >>> data = nastran_modal_data(tests / "nas2cam_extseout" / "inboard.op4", length_unit=1e-3)
    >>> [round(float(w), 5) for w in data.frequencies[:2]], data.node_names
    ([38.51181, 38.51677], ('grid_3', 'grid_11', 'grid_19', 'grid_27', 'grid_4', 'grid_16'))
    """
    if not isinstance(model, NastranModel):
        model = read_nastran(model, superelement=superelement)
    try:
        check_positive(length_unit, "length_unit")
    except ModelError:
        raise ModelError(f"length_unit must be a positive length in metres, got {length_unit!r}") from None
    b, q = model.boundary, model.modal
    if b.size == 0:
        raise ModelError(f"{model.source}: no boundary grid points (b-set) to attach the body by")
    if q.size == 0:
        raise ModelError(f"{model.source}: no modal coordinates (q-set scalar points): not a Craig-Bampton "
                         "component with fixed-interface modes")
    try:
        ref = model.grid_position(model.grids[0]) if reference is None else np.asarray(reference, dtype=float)
    except (TypeError, ValueError):
        ref = np.zeros(0)
    if ref.shape != (3,) or not np.all(np.isfinite(ref)):
        raise ModelError(f"reference must be 3 finite coordinates, got {reference!r}")
    R = model.rigid_body_modes(ref)
    K, M = np.asarray(model.K), np.asarray(model.M)
    if np.linalg.matrix_rank(R) < 6:
        raise ModelError(f"{model.source}: the boundary freedoms cannot carry the six rigid-body motions")
    Kbb = K[np.ix_(b, b)]
    rigid_force = np.abs(Kbb @ R).max() / max(np.abs(Kbb).max() * np.abs(R).max(), 1e-300)
    if rigid_force > 1e-6:
        raise ModelError(f"{model.source}: the stiffness resists rigid-body motion (relative force "
                         f"{rigid_force:.2g}): the component is grounded or its freedom map does not match")
    coupling = np.abs(K[np.ix_(b, q)]).max() / max(np.abs(K).max(), 1e-300)
    if coupling > 1e-8:
        raise ModelError(f"{model.source}: not in Craig-Bampton form: the boundary and modal freedoms are coupled "
                         f"by stiffness (relative {coupling:.2g}; K_bq = 0 for fixed-interface modes)")
    lam, V = scipy.linalg.eigh(K[np.ix_(q, q)], M[np.ix_(q, q)])
    if n_modes is not None:
        n_modes = _mode_count(n_modes, "n_modes", q.size)
        lam, V = lam[:n_modes], V[:, :n_modes]
    if lam[0] < -1e-9 * max(abs(lam[-1]), 1.0):
        raise ModelError(f"{model.source}: a negative fixed-interface eigenvalue {lam[0]:.3g}")
    Mrr = R.T @ M[np.ix_(b, b)] @ R
    Mrr = (Mrr + Mrr.T) / 2
    Mrq = R.T @ M[np.ix_(b, q)] @ V
    points = _equivalent_points(Mrr, Mrq, V.T @ M[np.ix_(q, q)] @ V, model.source)
    L = float(length_unit)
    positions, masses, inertias, trans, rots = points
    n_pts = len(masses)
    names = [f"grid_{g}" for g in model.grids]
    node_positions = [model.grid_position(g) - ref for g in model.grids]
    node_trans = [np.zeros((3, lam.size)) for _ in names]
    node_rots = [np.zeros((3, lam.size)) for _ in names]
    recovered, left_out = _recovered_nodes(model, ref, R, V)
    for g, position, trans_g, rot_g in recovered:
        names.append(f"grid_{g}")
        node_positions.append(position - ref)
        node_trans.append(trans_g)
        node_rots.append(rot_g / L)
    node_names = tuple(names)
    node_positions = np.array(node_positions) * L
    return ModalData(
        positions=np.asarray(positions) * L, masses=np.asarray(masses), inertias=np.asarray(inertias) * L**2,
        translations=np.asarray(trans), rotations=np.asarray(rots) / L,
        frequencies=np.sqrt(np.clip(lam, 0.0, None)),
        damping=_modal_damping(damping, lam.size),
        node_names=node_names, node_positions=node_positions, node_translations=np.array(node_trans),
        node_rotations=np.array(node_rots),
        source=f"{model.source}: Craig-Bampton component, interface fixed to the body frame; {n_pts} equivalent "
               "mass points (exact mass matrix; second-order integrals and geometric stiffness not available "
               "from reduced matrices)" + (f"; output grid points left out (not moved rigidly with the interface "
                                            f"by MUG1): {', '.join(map(str, left_out))}" if left_out else ""),
    )


def _recovered_nodes(model: NastranModel, ref: NDArray, R: NDArray, V: NDArray):
    """Output grid points of MUG1 as nodes, and the grid points left out.

    Returns ``[(grid, position, translations (3, M), rotations (3, M))]`` with the shapes turned
    from each grid's output system to the basic system, and the ids of output grid points that
    MUG1 does not move rigidly with the interface (freedoms driven by MPCs or constrained, as a
    test model's grid 60 has): they are not structural points of the body. If no output grid
    point moves rigidly, the freedom map or the grid data do not belong to the matrices: refused.
    """
    found: list = []
    skipped: list = []
    if model.recovery is None or model.grid_uset is None:
        return found, skipped
    _, n2p, _, _ = _pyyeti(Path(model.source))
    known = set(int(g) for g in model.grid_uset.index.get_level_values(0))
    interface = set(model.grids)
    b, q = model.boundary, model.modal
    ids = model.recovery_dof_map
    for g in dict.fromkeys(int(i) for i in ids[:, 0]):
        if g in interface or g not in known:
            continue
        rows = [np.flatnonzero((ids[:, 0] == g) & (ids[:, 1] == c)) for c in range(1, 7)]
        if any(r.size != 1 for r in rows):
            continue  # not all six freedoms recovered (a scalar point or a partial output)
        rows = np.concatenate(rows)
        grid = model.grid_uset.loc[[g]]
        position = np.array([grid.loc[(g, 1), c] for c in ("x", "y", "z")], dtype=float)
        rigid = np.asarray(n2p.rbgeom_uset(grid, ref.reshape(1, 3)))  # (6, 6), output system
        moved = model.recovery[np.ix_(rows, b)] @ R
        deviation = np.abs(moved - rigid).max() / max(np.abs(rigid).max(), 1.0)
        if deviation > 1e-6:
            skipped.append((g, deviation))  # constrained or MPC-driven freedoms: not a structural point
            continue
        to_basic = np.asarray(n2p.rbgeom_uset(grid, position.reshape(1, 3)))[:3, :3].T
        modal = model.recovery[np.ix_(rows, q)] @ V
        found.append((g, position, to_basic @ modal[:3], to_basic @ modal[3:]))
    if skipped and not found:
        g, deviation = skipped[0]
        raise ModelError(f"{model.source}: MUG1 moves none of its output grid points rigidly with the interface "
                         f"(grid {g}: relative deviation {deviation:.3g}): the freedom map or the grid data of the "
                         "bulk file do not belong to these matrices")
    return found, [g for g, _ in skipped]


def _equivalent_points(Mrr: NDArray, Mrq: NDArray, Mqq: NDArray, source: str):
    """Mass points whose rigid mass, rigid-elastic coupling and modal mass are ``Mrr, Mrq, Mqq``.

    One point at the centre of mass with the mass ``m``, the central inertia ``J_c`` minus the
    rotary inertia of the residual points, translation shape ``b / m`` and rotation shape that
    matches the rotational coupling; then pairs of massless points at the centre of mass with
    rotary inertia ``eps U3`` and opposite rotation shapes that add ``D = Mqq - (coupling part)``
    to the modal mass and nothing to the couplings.
    """
    m = Mrr[0, 0]
    if not m > 0:
        raise ModelError(f"{source}: the rigid-body mass is not positive ({m:.3g})")
    s_tilde = Mrr[3:, :3]  # [s x] with s = m c
    s = np.array([s_tilde[2, 1], s_tilde[0, 2], s_tilde[1, 0]])
    c = s / m
    I_O = Mrr[3:, 3:]
    Jc = I_O - m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    lowest = np.linalg.eigvalsh(Jc)[0]
    if lowest <= 1e-12 * np.abs(Jc).max():
        raise ModelError(f"{source}: the rigid inertia about the centre of mass is singular or indefinite "
                         f"(smallest principal value {lowest:.3g}); equivalent mass points need a 3D body")
    n_modes = Mqq.shape[0]
    n_pairs = -(-n_modes // 3)
    eps = 1e-3 * lowest / (2 * n_pairs)
    for _ in range(40):
        J0 = Jc - 2 * n_pairs * eps * np.eye(3)
        Phi0 = Mrq[:3] / m
        Psi0 = np.linalg.solve(J0, Mrq[3:] - m * np.cross(c, Phi0.T).T)
        D = Mqq - m * Phi0.T @ Phi0 - Psi0.T @ J0 @ Psi0
        D = (D + D.T) / 2
        d, W = np.linalg.eigh(D)
        if d[0] >= -1e-10 * max(np.abs(Mqq).max(), 1e-300):
            break
        eps /= 4
    else:
        raise ModelError(f"{source}: the Craig-Bampton mass matrix is not positive semi-definite")
    Lq = W * np.sqrt(np.clip(d, 0.0, None))  # D = Lq Lq^T
    Lq = np.hstack([Lq, np.zeros((n_modes, 3 * n_pairs - n_modes))])
    positions, masses, inertias, trans, rots = [c], [m], [J0], [Phi0], [Psi0]
    for k in range(n_pairs):
        Psi = Lq[:, 3 * k:3 * k + 3].T / np.sqrt(2 * eps)
        for sign in (1.0, -1.0):
            positions.append(c)
            masses.append(0.0)
            inertias.append(eps * np.eye(3))
            trans.append(np.zeros_like(Phi0))
            rots.append(sign * Psi)
    return positions, masses, inertias, trans, rots


def join_components(components) -> NastranModel:
    """Join Craig-Bampton components at the grid freedoms they share.

    Freedoms with the same ``(grid, component)`` are made equal (component mode synthesis with
    :func:`linflex.synthesize`); scalar points (modal coordinates) stay each component's own. The
    result is again a Craig-Bampton model: its boundary is the union of the components' grid
    freedoms, its modal coordinates are all components' fixed-interface modes.

    Parameters
    ----------
    components : sequence of NastranModel or path
        Two or more components (paths are read with :func:`read_nastran`), in the same units.

    Returns
    -------
    NastranModel
        The joined model: ``K``, ``M`` on the independent coordinates (model units) and the
        freedom map; its system modes are the free-free modes of the assembly.

    Raises
    ------
    ModelError
        For fewer than two components, a grid point at different positions in two components, or
        a scalar-point id used by two components.

    Examples
    --------
    The inboard and outboard trusses of pyyeti's tests, joined at their four interface grids;
    NASTRAN's system run (assemble.out) prints 10.67388 rad/s for the first elastic mode:

    >>> import pathlib, pyyeti
    >>> import numpy as np
    >>> from linflex import structural_modes
    >>> from linflex.structures import join_components
    >>> tests = pathlib.Path(pyyeti.__file__).parent / "tests" / "nas2cam_extseout"
    >>> both = join_components([tests / "inboard.op4", tests / "outboard.op4"])
    >>> round(float(structural_modes(both.K, both.M).frequencies[6]), 5)
    10.67388
    """
    import pandas as pd

    if isinstance(components, (str, Path, NastranModel)):  # not a sequence: a string's letters are no files
        raise ModelError(f"join_components needs a sequence of two or more components, got one: {components!s:.200}")
    models = [c if isinstance(c, NastranModel) else read_nastran(c) for c in components]
    if len(models) < 2:
        raise ModelError(f"join_components needs two or more components, got {len(models)}")
    sources = "; ".join(m.source for m in models)
    dofs = np.vstack([m.dof_map for m in models])
    offsets = np.cumsum([0] + [m.K.shape[0] for m in models])
    seen_spoints: dict[int, int] = {}
    first: dict[tuple[int, int], int] = {}
    rows = []
    positions: dict[int, tuple] = {}
    for k, m in enumerate(models):
        for g in m.grids:
            p = m.grid_position(g)
            if g in positions and np.linalg.norm(p - positions[g][0]) > 1e-9 * max(1.0, np.abs(p).max()):
                raise ModelError(f"join_components: grid {g} is at {tuple(positions[g][0])} in {positions[g][1]} "
                                 f"but at {tuple(p)} in {m.source}")
            positions.setdefault(g, (p, m.source))
        for i, (gid, comp) in enumerate(m.dof_map):
            j = offsets[k] + i
            if comp == 0:
                if gid in seen_spoints:
                    raise ModelError(f"join_components: scalar point {gid} appears in two components "
                                     f"({models[seen_spoints[gid]].source} and {m.source})")
                seen_spoints[int(gid)] = k
            elif (int(gid), int(comp)) in first:
                row = np.zeros(offsets[-1])
                row[first[int(gid), int(comp)]] = 1.0
                row[j] = -1.0
                rows.append(row)
            else:
                first[int(gid), int(comp)] = j
    if not rows:
        raise ModelError(f"join_components: the components share no grid freedom ({sources})")
    joined = synthesize([m.M for m in models], [m.K for m in models], np.array(rows))
    keep = np.setdiff1d(np.arange(offsets[-1]), joined.dependent)
    uset = pd.concat([m.uset for m in models]).iloc[keep]
    K, M = _check_matrices(joined.K, joined.M, sources)
    kept = dofs[keep]
    recovery, recovery_dof_map, grid_uset = _joined_recovery(models, kept)
    return NastranModel(frozen_array(K), frozen_array(M), frozen_array(kept, dtype=None), uset,
                        np.flatnonzero(kept[:, 1] > 0), np.flatnonzero(kept[:, 1] == 0), f"joined: {sources}",
                        recovery, recovery_dof_map, grid_uset)


def _joined_recovery(models, kept: NDArray):
    """The components' MUG1 on the joined coordinates (each output freedom once), and their grids."""
    import pandas as pd

    column = {(int(g), int(c)): i for i, (g, c) in enumerate(kept)}
    blocks, rows, usets, seen = [], [], [], set()
    for m in models:
        if m.recovery is None:
            continue
        pick = np.zeros((m.K.shape[0], kept.shape[0]))  # component coordinates from the joined ones
        for i, (g, c) in enumerate(m.dof_map):
            pick[i, column[int(g), int(c)]] = 1.0
        new = [i for i, (g, c) in enumerate(m.recovery_dof_map) if (int(g), int(c)) not in seen]
        seen.update((int(g), int(c)) for g, c in m.recovery_dof_map)
        blocks.append(m.recovery[new] @ pick)
        rows.append(m.recovery_dof_map[new])
        if m.grid_uset is not None:
            usets.append(m.grid_uset)
    if not blocks:
        return None, None, None
    grid_uset = None
    if usets:
        grid_uset = pd.concat(usets)
        grid_uset = grid_uset[~grid_uset.index.duplicated()]
    return frozen_array(np.vstack(blocks)), frozen_array(np.vstack(rows), dtype=None), grid_uset


FILE_READERS.update({".op2": nastran_modal_data, ".op4": nastran_modal_data})
