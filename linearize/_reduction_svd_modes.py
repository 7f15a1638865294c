"""SVD reduction of projected system modes (component-wise reduction of a flexible multibody model)."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import ModelError, SecondOrderSystem, svd_component_reduction
from linflex.frequency import HinfNorm
from linflex.system import GalerkinBases, signal_index

from ._projection import project_second_order
from ._reduction_norm import checked_against_full, stable_parts_error

__all__ = ["ProjectedModesReduction", "projected_modes_reduction"]


@dataclass(frozen=True)
class ProjectedModesReduction(GalerkinBases):
    """Result of :func:`projected_modes_reduction`.

    Attributes
    ----------
    sys : SecondOrderSystem
        The reduced system; dofs ``<component>_0, <component>_1, ...`` per component.
    components : tuple of str
        Component names, in the order of the reduced dofs.
    bases : dict of str to ndarray
        The kept left singular vectors ``U_i`` (``m_i x r_i``) of each component: its dofs are
        ``q_i ~ U_i eta_i``.
    singular_values : dict of str to ndarray
        All singular values of each component's block of the system modes, descending.
    orders : dict of str to int
        Kept directions ``r_i`` per component.
    frequencies : ndarray
        The ``n_modes`` system frequencies [rad/s] the reduction is built from.
    T : ndarray
        The block basis ``(n_dofs, sum r_i)``: ``q ~ T eta``.
    tol : float
        Relative threshold on the singular values (to each component's largest).
    measured_error : HinfNorm or None
        H-infinity norm of the difference of the stable parts of the full and reduced systems
        (rigid-body parts split off), when requested, checked against direct evaluations of
        both systems by the frequency engine.
    seconds : float
        Wall time [s].
    V, W : ndarray
        Both ``T`` (properties, for the common result shape).
    order : int
        ``T.shape[1]``, the number of reduced dofs (a property).
    error_bound : None
        No a-priori bound exists (a property).
    """

    sys: SecondOrderSystem
    components: tuple[str, ...]
    bases: dict[str, NDArray[np.float64]]
    singular_values: dict[str, NDArray[np.float64]]
    orders: dict[str, int]
    frequencies: NDArray[np.float64]
    T: NDArray[np.float64]
    tol: float
    measured_error: HinfNorm | None
    seconds: float



def projected_modes_reduction(
    sys: SecondOrderSystem, components: Mapping[str, Sequence[str | int]], *, n_modes: int, tol: float = 1e-8,
    measure_error: bool = False,
) -> ProjectedModesReduction:
    """Reduce each component to the combinations of its dofs that the lowest system modes use.

    Parameters
    ----------
    sys : SecondOrderSystem
        The assembled model (hinges locked at the reference configuration), symmetric ``M``
        positive definite and symmetric ``K``, whose dofs are the stacked component coordinates
        (e.g. component modal coordinates).
    components : mapping of str to sequence of str or int
        For each component, the names (or indices) of its dofs; every dof belongs to exactly one
        component.
    n_modes : int
        Number of lowest system modes to preserve.
    tol : float
        Keep the left singular vectors whose singular value exceeds ``tol`` times the
        component's largest.
    measure_error : bool
        Also measure the H-infinity norm of the error (stable parts).

    Returns
    -------
    ProjectedModesReduction

    Raises
    ------
    ModelError
        If the components do not partition the dofs, ``n_modes`` is out of range, ``tol`` is not
        in [0, 1), or ``M``/``K`` are not symmetric (``M`` positive definite).

    Notes
    -----
    Banerjee, *Flexible Multibody Dynamics* (2016), Sec. 7.8, Eqs. 7.55-7.58 (with the printed
    7.58 corrected): with ``Phi`` the ``n_modes`` lowest mass-normalised system modes and ``A_i``
    its rows of component ``i``, ``A_i = U_i S_i V_i^T``; the reduced component basis keeps the
    left singular vectors above the threshold and ``T = blockdiag(U_i)``. The reduced system is
    the Ritz projection ``T^T M T``, ``T^T D T``, ``T^T K T``, ``T^T B``, ``Cq T``, ``Cv T``. When
    every non-zero direction is kept, each retained mode lies in the span of ``T`` and its
    frequency is reproduced exactly; otherwise the frequencies converge from above.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import SecondOrderSystem
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 2.0]])
    >>> so = SecondOrderSystem(np.eye(3), 0.01 * K, K, [[1.0], [0.0], [0.0]])
    >>> res = projected_modes_reduction(so, {"a": [0], "b": [1, 2]}, n_modes=1)
    >>> res.orders
    {'a': 1, 'b': 1}
    """
    t0 = time.perf_counter()
    if not isinstance(sys, SecondOrderSystem):
        raise ModelError(f"sys must be a SecondOrderSystem (mass and stiffness matrices), got {type(sys).__name__}")
    n = sys.n_dofs
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes <= n:
        raise ModelError(f"n_modes must be an integer between 1 and the {n} dofs, got {n_modes!r}")
    try:
        tol = float(tol)
    except (TypeError, ValueError) as err:
        raise ModelError(f"tol must be a real number in [0, 1), got {tol!r}") from err
    if not 0 <= tol < 1:
        raise ModelError(f"tol must be a real number in [0, 1), got {tol!r}")
    if not isinstance(components, Mapping) or not components:
        raise ModelError("components must be a non-empty mapping of component name to its dofs")
    owner: dict[int, str] = {}
    groups: dict[str, list[int]] = {}
    for name, dofs in components.items():
        dofs = [dofs] if isinstance(dofs, (str, int, np.integer)) else list(dofs)
        if not dofs:
            raise ModelError(f"components[{name!r}] has no dofs")
        idx = []
        for d in dofs:
            j = signal_index(sys.dofs, d, f"components[{name!r}]")
            if j in owner and owner[j] == name:
                raise ModelError(f"components[{name!r}] lists dof {sys.dofs[j]!r} twice")
            if j in owner:
                raise ModelError(f"dof {sys.dofs[j]!r} is in both components {owner[j]!r} and {name!r}")
            owner[j] = name
            idx.append(j)
        groups[str(name)] = idx
    missing = [sys.dofs[j] for j in range(n) if j not in owner]
    if missing:
        raise ModelError(f"dofs {missing[:8]} belong to no component; every dof must be in exactly one")
    M, K = sys.M, sys.K
    if np.max(np.abs(M - M.T)) > 1e-10 * np.max(np.abs(M)) or np.max(np.abs(K - K.T)) > 1e-10 * max(np.max(np.abs(K)), 1e-300):
        raise ModelError("projected_modes_reduction needs symmetric M and K")
    try:
        w2, Phi = scipy.linalg.eigh((K + K.T) / 2, (M + M.T) / 2, subset_by_index=[0, n_modes - 1])
    except np.linalg.LinAlgError as err:
        raise ModelError(f"M must be symmetric positive definite ({err})") from err
    bases, svals, orders = {}, {}, {}
    blocks = []
    names = []
    for name, idx in groups.items():
        U, s = svd_component_reduction(Phi[idx], tol=tol)  # core: Banerjee Eqs. 7.56-7.58
        r = U.shape[1]
        bases[name] = U
        svals[name] = s
        orders[name] = r
        blocks.append((idx, U))
        names += [f"{name}_{k}" for k in range(r)]
    total = sum(orders.values())
    T = np.zeros((n, total))
    col = 0
    for idx, U in blocks:
        T[idx, col:col + U.shape[1]] = U
        col += U.shape[1]
    red = project_second_order(sys, T, dofs=names)
    freq = np.sqrt(np.clip(w2, 0.0, None))
    for arr in (freq, T):
        arr.setflags(write=False)
    measured = None
    if measure_error:
        full, reduced = sys.to_state_space(), red.to_state_space()
        measured = checked_against_full(full, reduced, stable_parts_error(full, reduced))
    return ProjectedModesReduction(
        sys=red, components=tuple(groups), bases=bases, singular_values=svals, orders=orders, frequencies=freq,
        T=T, tol=tol, measured_error=measured, seconds=time.perf_counter() - t0,
    )
