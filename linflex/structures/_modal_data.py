"""Modal data of a flexible body and its modal integrals (invariants).

:class:`ModalData` describes a flexible body as the finite-element community hands it over:
mass points (nodal rigid bodies with mass and rotary inertia), mass-normalized mode shapes
(translation and small rotation of each point per mode), modal frequencies and damping, named
attachment nodes, and optionally the projected geometric stiffness of the unit inertia loads.
:meth:`ModalData.integrals` turns it into the precomputed sums that the equations of motion
need, so their cost does not grow with the number of finite-element nodes (Banerjee, *Flexible
Multibody Dynamics*, App. 5.A; docs/reference/multibody-formulations-banerjee.md, section 6).

File formats (:meth:`ModalData.save`, :func:`load_modal_data`): ``.npz`` with one array per
field, or ``.json`` with the same field names as nested lists; ``format`` is
``"linflex-modal-data"`` and ``version`` is 1. Shapes, with N mass points, K nodes, M modes:

===================== ============ ===============================================
field                 shape        meaning [unit]
===================== ============ ===============================================
positions             (N, 3)       undeformed mass-point positions, body frame [m]
masses                (N,)         [kg]
inertias              (N, 3, 3)    rotary inertia about the point, body axes [kg m^2]
translations          (N, 3, M)    mode shapes: translation per unit modal coordinate
rotations             (N, 3, M)    mode shapes: small rotation [rad] per unit coordinate
frequencies           (M,)         [rad/s]
damping               (M,)         damping ratios [-]
node_names            (K,)         attachment-node names
node_positions        (K, 3)       [m]
node_translations     (K, 3, M)
node_rotations        (K, 3, M)
geometric_stiffness   (12|21, M, M) optional: S^(i) = Phi^T K_g^(i) Phi [N/m per unit A_i]
===================== ============ ===============================================
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..system._errors import ModelError

__all__ = ["ModalData", "ModalIntegrals", "load_modal_data"]

FORMAT = "linflex-modal-data"
#: Readers of other file kinds by suffix, registered by their modules (``_nastran.py``).
FILE_READERS: dict = {}


def _mode_count(value, name: str, high: int, detail: str = "") -> int:
    """``value`` as an int in 1..``high``, else a :class:`ModelError` naming ``name`` (a bool, a
    fraction or text is refused, not rounded: ``2.5`` modes is a mistake, not 2)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer, float, np.floating))
            or not np.isfinite(value) or int(value) != value or not 0 < value <= high):
        raise ModelError(f"{name} must be between 1 and {high}{detail}, got {value!r}")
    return int(value)


def _modal_damping(damping, n_modes: int) -> NDArray:
    """Damping ratios [-] for ``n_modes`` modes from one ratio or one per mode."""
    try:
        z = np.asarray(damping, dtype=float)
    except (TypeError, ValueError) as err:
        raise ModelError(f"damping must be a ratio [-] or one ratio per mode, got {damping!r}") from err
    if z.ndim > 1 or z.size not in (1, n_modes):
        raise ModelError(f"damping has shape {z.shape}; one ratio [-] for all modes or one per mode ({n_modes}) "
                         "was expected")
    if not np.all(np.isfinite(z)) or np.any(z < 0):
        raise ModelError(f"damping must be finite non-negative ratios of critical damping [-], got {damping!r}")
    return np.broadcast_to(z.reshape(-1), (n_modes,)).copy()


def _skew_cross(a: NDArray, b: NDArray) -> NDArray:
    return np.cross(a, b, axis=-1)


@dataclass(frozen=True)
class ModalIntegrals:
    """Precomputed modal integrals of a flexible body about its reference point O.

    Names follow the reference notes, section 6.1 (M modes):
    ``mass`` m [kg]; ``s0`` (3,) first moment [kg m]; ``b`` (3, M); ``c`` (3, M);
    ``d`` (M, M, 3) with d[l, k] = sum m Phi_l x Phi_k; ``e`` (M, M) modal mass of translation;
    ``N`` (M, 3, 3); ``P`` (M, M, 3, 3); ``I0`` (3, 3) inertia about O [kg m^2];
    rotary-inertia sums ``W1`` (3, 3) [kg m^2], ``W4`` (3, M), ``W9`` (M, M). With mass-normalized
    modes (modal coordinate ``q`` in [kg^1/2 m]), ``b``, ``c``, ``d``, ``N``, ``P``, ``W4`` and
    ``W9`` carry [kg m^2] per unit of ``q`` to the power of the modes involved, so that every term
    of :meth:`inertia` is in [kg m^2] and ``e`` is dimensionless [-] (the identity for
    translation-only mass-normalized modes).
    """

    mass: float
    s0: NDArray
    b: NDArray
    c: NDArray
    d: NDArray
    e: NDArray
    N: NDArray
    P: NDArray
    I0: NDArray
    W1: NDArray
    W4: NDArray
    W9: NDArray

    def inertia(self, q: NDArray) -> NDArray:
        """Deformed inertia about O, Eq. 5.40 with the second-order term.

        Parameters
        ----------
        q : array_like, shape (M,)
            Modal coordinates [kg^1/2 m for mass-normalized modes].

        Returns
        -------
        ndarray, shape (3, 3)
            ``I0 + sum_l q_l (N_l + N_l^T) + sum_kl q_k q_l P_kl`` [kg m^2], body axes.
        """
        q = np.asarray(q)
        first = np.einsum("l,lij->ij", q, self.N + np.transpose(self.N, (0, 2, 1)))
        return self.I0 + first + np.einsum("k,l,klij->ij", q, q, self.P)


@dataclass(frozen=True, eq=False)
class ModalData:
    """A flexible body's mass points, mode shapes, frequencies and attachment nodes.

    See the module documentation for the file formats. Arrays are read-only. With N mass
    points, K nodes and M mass-normalized modes (modal coordinates in [kg^1/2 m]):

    Attributes
    ----------
    positions : ndarray, shape (N, 3)
        Undeformed mass-point positions in the body frame [m].
    masses : ndarray, shape (N,)
        Point masses [kg].
    inertias : ndarray, shape (N, 3, 3)
        Rotary inertia about each point in body axes [kg m^2].
    translations : ndarray, shape (N, 3, M)
        Mode shapes: translation per unit modal coordinate [m / (kg^1/2 m)] = [kg^-1/2].
    rotations : ndarray, shape (N, 3, M)
        Mode shapes: small rotation per unit modal coordinate [rad / (kg^1/2 m)].
    frequencies : ndarray, shape (M,)
        Natural frequencies [rad/s].
    damping : ndarray, shape (M,)
        Modal damping ratios [-].
    node_names : tuple of str
        Attachment-node names (K).
    node_positions : ndarray, shape (K, 3)
        Node positions in the body frame [m].
    node_translations, node_rotations : ndarray, shape (K, 3, M)
        Mode shapes at the nodes, as ``translations`` [kg^-1/2] and ``rotations``.
    geometric_stiffness : ndarray, shape (12 or 21, M, M), or None
        Projected geometric stiffness of the unit inertia loads, ``S^(i) = Phi^T K_g^(i) Phi``
        with ``K_g^(i)`` in [N/m per unit A_i] (module table), in modal coordinates.
    source : str
        Where the data came from (file name), for messages.

    Raises
    ------
    ModelError
        On inconsistent shapes, non-finite values, negative masses or frequencies.
    """

    positions: NDArray
    masses: NDArray
    inertias: NDArray
    translations: NDArray
    rotations: NDArray
    frequencies: NDArray
    damping: NDArray
    node_names: tuple[str, ...] = ()
    node_positions: NDArray | None = None
    node_translations: NDArray | None = None
    node_rotations: NDArray | None = None
    geometric_stiffness: NDArray | None = None
    source: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.node_names, str):  # one node: a name, not its letters
            object.__setattr__(self, "node_names", (self.node_names,))
        N = np.asarray(self.positions).shape[0] if np.ndim(self.positions) == 2 else -1
        M = np.asarray(self.frequencies).size
        K = len(self.node_names)
        expected = {
            "positions": (N, 3), "masses": (N,), "inertias": (N, 3, 3), "translations": (N, 3, M),
            "rotations": (N, 3, M), "frequencies": (M,), "damping": (M,),
            "node_positions": (K, 3), "node_translations": (K, 3, M), "node_rotations": (K, 3, M),
        }
        if N < 1:
            raise ModelError(f"ModalData.positions must have shape (N, 3), got {np.shape(self.positions)}")
        for name, shape in expected.items():
            value = getattr(self, name)
            if value is None:
                value = np.zeros(shape)
            try:
                arr = np.array(value, dtype=float)
            except (TypeError, ValueError) as err:
                raise ModelError(f"ModalData.{name} must be an array of numbers: {err}") from err
            if arr.shape != shape:
                raise ModelError(f"ModalData.{name} has shape {arr.shape} but {shape} was expected "
                                 f"({N} mass points, {K} nodes, {M} modes)")
            if not np.all(np.isfinite(arr)):
                raise ModelError(f"ModalData.{name} has non-finite entries")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if self.geometric_stiffness is not None:
            S = np.array(self.geometric_stiffness, dtype=float)
            if S.ndim != 3 or S.shape[0] not in (12, 21) or S.shape[1:] != (M, M):
                raise ModelError(f"ModalData.geometric_stiffness has shape {S.shape}; (12 or 21, {M}, {M}) expected")
            if not np.all(np.isfinite(S)):
                raise ModelError("ModalData.geometric_stiffness has non-finite entries")
            S.setflags(write=False)
            object.__setattr__(self, "geometric_stiffness", S)
        if np.any(self.masses < 0):
            raise ModelError("ModalData.masses must be non-negative")
        if np.any(self.frequencies < 0):
            raise ModelError("ModalData.frequencies must be non-negative [rad/s]")
        if np.any(self.damping < 0):
            raise ModelError("ModalData.damping must be non-negative (ratios of critical damping)")
        J = self.inertias
        scale = max(float(np.max(np.abs(J))) if J.size else 0.0, 1e-300)
        asym = np.max(np.abs(J - np.swapaxes(J, 1, 2)), axis=(1, 2)) if J.size else np.zeros(0)
        bad = np.flatnonzero(asym > 1e-12 * scale)
        if bad.size:
            raise ModelError(f"ModalData.inertias[{bad[0]}] is not symmetric (rotary inertia of mass point "
                             f"{bad[0]}; {bad.size} point(s) affected)")
        lowest = np.linalg.eigvalsh(J)[:, 0] if J.size else np.zeros(0)
        bad = np.flatnonzero(lowest < -1e-12 * scale)
        if bad.size:
            raise ModelError(f"ModalData.inertias[{bad[0]}] is not positive semi-definite (smallest eigenvalue "
                             f"{lowest[bad[0]]:.3g} kg m^2; {bad.size} point(s) affected)")
        object.__setattr__(self, "node_names", tuple(str(n) for n in self.node_names))
        repeated = sorted({n for n in self.node_names if self.node_names.count(n) > 1})
        if repeated:
            raise ModelError(f"ModalData.node_names repeat {', '.join(map(repr, repeated))}: each node needs its "
                             "own name")

    @property
    def n_modes(self) -> int:
        """Number of modes M."""
        return self.frequencies.size

    def node(self, name: str):
        """``(position, translations (3, M), rotations (3, M))`` of a named node.

        Parameters
        ----------
        name : str
            One of ``node_names``.

        Returns
        -------
        position : ndarray, shape (3,)
            Body frame [m].
        translations, rotations : ndarray, shape (3, M)
            Mode shapes at the node [kg^-1/2] and [rad / (kg^1/2 m)].

        Raises
        ------
        ModelError
            For an unknown node (with the closest name).
        """
        if name not in self.node_names:
            from difflib import get_close_matches

            hint = get_close_matches(name, self.node_names, n=1)
            raise ModelError(f"unknown node {name!r}" + (f" (did you mean {hint[0]!r}?)" if hint else
                                                        f"; nodes: {', '.join(self.node_names)}"))
        i = self.node_names.index(name)
        return self.node_positions[i], self.node_translations[i], self.node_rotations[i]

    def truncated(self, n_modes: int) -> ModalData:
        """The same body with its lowest ``n_modes`` modes.

        Parameters
        ----------
        n_modes : int
            Number of modes to keep, 1 to :attr:`n_modes`.

        Returns
        -------
        ModalData
            Same mass points and nodes, the first ``n_modes`` shapes, frequencies [rad/s] and
            damping ratios [-].

        Raises
        ------
        ModelError
            If ``n_modes`` is out of range.
        """
        return self.selected(range(_mode_count(n_modes, "n_modes", self.n_modes)))

    def selected(self, modes) -> ModalData:
        """The same body with the modes ``modes`` only, in that order: an axial or a torsion
        mode left out of a beam's model, say.

        Parameters
        ----------
        modes : sequence of int
            Indices of the modes to keep (0-based, distinct, at least one).

        Returns
        -------
        ModalData
            Same mass points and nodes; those modes' shapes, frequencies [rad/s], damping ratios
            [-] and geometric stiffness.

        Raises
        ------
        ModelError
            If an index is out of range or repeated, or none is given.

        Examples
        --------
        >>> from linflex import Beam, beam_modal_data
        >>> arm = Beam((0, 0, 0), (2, 0, 0), EA=1e7, EIy=1e4, EIz=1e4, GJ=1e4, mass_per_length=1.5)
        >>> data = beam_modal_data(arm, 4)
        >>> data.selected([0, 2]).frequencies.tolist() == data.frequencies[[0, 2]].tolist()
        True
        """
        given = list(modes)
        keep = [int(k) for k in given if isinstance(k, (int, np.integer)) and not isinstance(k, bool)]
        if (not keep or len(keep) != len(given) or len(set(keep)) != len(keep)
                or not all(0 <= k < self.n_modes for k in keep)):
            raise ModelError(f"modes must be distinct indices from 0 to {self.n_modes - 1}, got {given}")
        S = None if self.geometric_stiffness is None else self.geometric_stiffness[:, keep][:, :, keep]
        return ModalData(self.positions, self.masses, self.inertias, self.translations[..., keep],
                         self.rotations[..., keep], self.frequencies[keep], self.damping[keep], self.node_names,
                         self.node_positions, self.node_translations[..., keep], self.node_rotations[..., keep],
                         S, self.source)

    def integrals(self) -> ModalIntegrals:
        """The modal integrals of section 6.1 and the rotary sums of section 6.2, as node sums.

        Returns
        -------
        ModalIntegrals
            ``mass`` [kg], ``s0`` [kg m], ``I0`` [kg m^2] and the modal sums (see the class).
        """
        m, r, Phi, Psi, J = self.masses, self.positions, self.translations, self.rotations, self.inertias
        eye = np.eye(3)
        Phi_k = np.transpose(Phi, (0, 2, 1))  # (N, M, 3)
        rr = np.einsum("g,gi,gj->ij", m, r, r)
        # N_l = sum m [(r . Phi_l) U3 - r Phi_l^T], indexed [l, row, column].
        N_l = np.einsum("g,gi,gil,jk->ljk", m, r, Phi, eye) - np.einsum("g,gj,gkl->ljk", m, r, Phi)
        return ModalIntegrals(
            mass=float(m.sum()),
            s0=m @ r,
            b=np.einsum("g,gil->il", m, Phi),
            c=np.einsum("g,gli->il", m, _skew_cross(r[:, None, :], Phi_k)),
            d=np.einsum("g,glki->lki", m, _skew_cross(Phi_k[:, :, None, :], Phi_k[:, None, :, :])),
            e=np.einsum("g,gil,gik->lk", m, Phi, Phi),
            N=N_l,
            P=(np.einsum("g,gil,gik,ab->lkab", m, Phi, Phi, eye) - np.einsum("g,gal,gbk->lkab", m, Phi, Phi)),
            I0=np.trace(rr) * eye - rr,
            W1=J.sum(axis=0),
            W4=np.einsum("gij,gjl->il", J, Psi),
            W9=np.einsum("gil,gij,gjk->lk", Psi, J, Psi),
        )

    # -- files ---------------------------------------------------------------------------------

    def save(self, path: str | Path) -> Path:
        """Write to ``.npz`` or ``.json`` (by suffix); returns the path.

        Parameters
        ----------
        path : str or path-like
            Destination; the suffix picks the format. Values in the units of the attributes.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ModelError
            For a suffix other than ``.npz`` or ``.json``.
        """
        path = Path(path)
        data = {"format": FORMAT, "version": 1}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None:
                data[f.name] = value
        if path.suffix == ".npz":
            np.savez_compressed(path, **{k: np.asarray(v) for k, v in data.items()})
        elif path.suffix == ".json":
            path.write_text(json.dumps({k: (v.tolist() if isinstance(v, np.ndarray) else
                                            list(v) if isinstance(v, tuple) else v) for k, v in data.items()}))
        else:
            raise ModelError(f"ModalData.save: unknown suffix {path.suffix!r}; use .npz or .json")
        return path


def load_modal_data(path: str | Path) -> ModalData:
    """Read modal data written by :meth:`ModalData.save` or by another tool in that format.


    Parameters
    ----------
    path : str or Path
        A ``.npz`` or ``.json`` file, or a NASTRAN ``.op4``/``.op2`` Craig-Bampton component in SI
        units (:func:`linflex.structures.nastran_modal_data`, with pyyeti).

    Returns
    -------
    ModalData
        The validated modal data (SI units, frequencies in rad/s).

    Raises
    ------
    ModelError
        For a missing file, an unknown format or version, missing fields or wrong shapes; the
        message names the file.

    Examples
    --------
    A round trip through a temporary file:

    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from linflex import Beam, beam_modal_data, load_modal_data
    >>> beam = Beam((0, 0, 0), (1, 0, 0), EA=1e6, EIy=1.0, EIz=1.0, GJ=1.0, mass_per_length=1.0, elements=4)
    >>> data = beam_modal_data(beam, 2)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     back = load_modal_data(data.save(pathlib.Path(tmp) / "beam.npz"))
    >>> bool(np.array_equal(back.frequencies, data.frequencies))
    True
    """
    path = Path(path)
    if not path.exists():
        raise ModelError(f"{path}: no such modal-data file")
    reader = FILE_READERS.get(path.suffix.lower())  # NASTRAN .op2/.op4 (registered by _nastran.py)
    if reader is not None:
        return reader(path)
    try:
        if path.suffix == ".npz":
            if not zipfile.is_zipfile(path):
                raise ModelError(f"{path}: not an .npz archive (a zip file of arrays, as ModalData.save writes); "
                                 f"it starts with {path.read_bytes()[:8]!r}")
            with np.load(path, allow_pickle=False) as archive:
                raw = {k: archive[k] for k in archive.files}
            raw = {k: (v.item() if v.ndim == 0 else v) for k, v in raw.items()}
        elif path.suffix == ".json":
            raw = json.loads(path.read_text(encoding="utf-8"))
        else:
            raise ModelError(f"{path}: unknown suffix {path.suffix!r}; use .npz or .json")
    except ModelError:
        raise
    except json.JSONDecodeError as err:
        raise ModelError(f"{path}: malformed JSON: {err}") from err
    except (OSError, ValueError, zipfile.BadZipFile) as err:
        raise ModelError(f"{path}: cannot read modal data: {err}") from err
    if not isinstance(raw, dict):
        raise ModelError(f"{path}: expected a JSON object with the fields format, version, positions, ... at the "
                         f"top level, got a {type(raw).__name__}")
    raw = dict(raw)
    fmt, version = raw.pop("format", None), raw.pop("version", None)
    if fmt != FORMAT:
        raise ModelError(f"{path}: not a {FORMAT} file (its format is {fmt!r}; expected {FORMAT!r})")
    if isinstance(version, bool) or not isinstance(version, (int, float, np.integer, np.floating)) or version != 1:
        raise ModelError(f"{path}: not a {FORMAT} file of version 1 (its version is {version!r}; expected the "
                         "integer 1)")
    known = {f.name for f in fields(ModalData)}
    unknown = set(raw) - known
    if unknown:
        raise ModelError(f"{path}: unknown fields {sorted(unknown)}")
    required = {"positions", "masses", "inertias", "translations", "rotations", "frequencies", "damping"}
    missing = required - set(raw)
    if missing:
        raise ModelError(f"{path}: missing fields {sorted(missing)}")
    if "node_names" in raw:
        raw["node_names"] = tuple(str(n) for n in np.atleast_1d(raw["node_names"]))
    try:
        return ModalData(**raw)
    except ModelError as err:
        raise ModelError(f"{path}: {err}") from err
    except (TypeError, ValueError) as err:  # a field that is no array of numbers
        raise ModelError(f"{path}: a field is not an array of numbers ({err})") from err
