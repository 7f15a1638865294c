"""Exchange of variables: make chosen outputs states by a similarity transformation.

The classic DISCOS/DYNAMO procedure (largest-element pivot search) and a QR-pivoted variant, plus
the plant/controller partition of an exchanged monolithic model.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, as_linear_system
from linflex.system import check_positive, signal_index

__all__ = ["PlantControllerPartition", "VariableExchange", "exchange_variables", "plant_controller_partition"]

METHODS = ("pivot", "qr")


@dataclass(frozen=True)
class VariableExchange:
    """Result of :func:`exchange_variables`.

    Attributes
    ----------
    sys : LinearSystem
        The transformed system ``z' = R^-1 A R z + R^-1 B u``, ``y = C R z + D u``. Its states are
        the retained original states (original order, original names) followed by the exchanged
        outputs (named like the outputs). All outputs are kept; the exchanged ones now read their
        own state.
    R, R_inv : ndarray
        ``x = R z`` and ``z = R_inv x``; ``R_inv`` is the identity rows of the retained states
        stacked on the rows of ``C`` of the exchanged outputs.
    exchanged : tuple of str
        The eliminated states, one per exchanged output, in the order of ``outputs``.
    retained : tuple of str
        The states kept.
    outputs : tuple of str
        The outputs that became states.
    pivots : ndarray
        Magnitude of each pivot (pivot search: the scaled largest element; QR: ``|R_kk|``).
    condition : float
        2-norm condition number of ``C_E``, the block of ``C`` on the eliminated states (the
        exchange inverts it).
    transform_condition : float
        1-norm condition number of ``R``.
    method : str
        ``"pivot"`` or ``"qr"``.
    seconds : float
        Wall time [s].
    """

    sys: LinearSystem
    R: NDArray[np.float64]
    R_inv: NDArray[np.float64]
    exchanged: tuple[str, ...]
    retained: tuple[str, ...]
    outputs: tuple[str, ...]
    pivots: NDArray[np.float64]
    condition: float
    transform_condition: float
    method: str
    seconds: float


def exchange_variables(
    sys, outputs, *, method: str = "pivot", among: Mapping[str, Sequence[str]] | None = None, tol: float = 1e-10,
) -> VariableExchange:
    """Make the chosen outputs states of the system, eliminating as many original states.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system; the chosen outputs must not depend on the inputs (zero rows of ``D``).
    outputs : str or sequence of str
        Names (or indices) of the outputs to exchange: plant sensor signals, controller outputs.
    method : {"pivot", "qr"}
        ``"pivot"``: the classic largest-element pivot search on ``[C | -I]`` with Gauss-Jordan
        elimination, row by row in the order of ``outputs``. ``"qr"``: QR with column pivoting
        of the admissible block of ``C`` (grouped by admissible sets), which picks the states
        giving the best-conditioned ``C_E``.
    among : mapping of str to sequence of str, optional
        For each output name, the states it may replace (e.g. plant states for a sensor signal,
        controller states for a controller output), so that the plant/controller structure of
        :func:`plant_controller_partition` appears. Outputs not listed may replace any state.
    tol : float
        Relative size (to the largest entry of the chosen rows of ``C``) below which a pivot is
        zero: the outputs are then dependent and the exchange is refused.

    Returns
    -------
    VariableExchange

    Raises
    ------
    ModelError
        On an unknown or repeated output, an output with direct feedthrough, an unknown method,
        an output with no admissible state left, dependent outputs (the message names the
        output and the pivot size), or a ``tol`` that is not a finite non-negative number.

    Notes
    -----
    With ``E`` the eliminated and ``S`` the retained states, ``w = C_S x_S + C_E x_E`` and

    ::

        x = R z,   z = [x_S; w],   R = [ I              0      ]  (rows: S, E)
                                       [ -C_E^-1 C_S   C_E^-1  ]

        R^-1 = [ I_S rows ]      A_z = R^-1 A R,  B_z = R^-1 B,  C_z = C R
               [    C     ]

    so the eigenvalues are unchanged. Source: Martin Marietta for NASA MSFC, *Dynamic Analysis of
    a Flexible Spacecraft with Rotating Components* (1975), Ch. III-C (exchange of variables and
    the pivot search); the QR variant follows Golub and Van Loan, Sec. 5.4.2.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[0, 1], [-4, -0.4]], [[0], [1]], [[2, 1]], outputs=["s"])
    >>> res = exchange_variables(sys, "s")
    >>> res.sys.states, res.exchanged
    (('x1', 's'), ('x0',))
    """
    t0 = time.perf_counter()
    sys = as_linear_system(sys, "sys")
    if method not in METHODS:
        raise ModelError(f"method must be one of {METHODS}, got {method!r}")
    tol = check_positive(tol, "tol", allow_zero=True)
    names = [outputs] if isinstance(outputs, (str, int, np.integer)) else list(outputs)
    if not names:
        raise ModelError("outputs: at least one output to exchange is required")
    rows = [signal_index(sys.outputs, k, "outputs") for k in names]
    if len(set(rows)) != len(rows):
        raise ModelError(f"outputs: repeated output in {names!r}")
    out_names = tuple(sys.outputs[r] for r in rows)
    n, nr = sys.n_states, len(rows)
    if nr > n:
        raise ModelError(f"outputs: {nr} outputs cannot replace the {n} states of the system")
    for r in rows:
        if np.any(sys.D[r] != 0):
            raise ModelError(
                f"output {sys.outputs[r]!r} has direct feedthrough (D row {sys.D[r].tolist()}); "
                "it depends on the inputs and cannot become a state"
            )
    for name in set(out_names) & set(sys.states):
        raise ModelError(f"output {name!r} has the name of a state; rename it before exchanging")
    admissible = _admissible(sys, out_names, among)
    C = sys.C[rows]
    scale = np.max(np.abs(C)) if C.size else 0.0
    for i, name in enumerate(out_names):
        if not np.any(C[i]):
            raise ModelError(f"output {name!r} is identically zero (its row of C is zero); it cannot become a state")
    if method == "pivot":
        eliminated, pivots = _pivot_search(C, admissible, out_names, tol * scale)
    else:
        eliminated, pivots = _qr_search(C, admissible, out_names, tol * scale)
    retained = [j for j in range(n) if j not in set(eliminated)]
    CE, CS = C[:, eliminated], C[:, retained]
    lu = scipy.linalg.lu_factor(CE)
    R = np.zeros((n, n))
    R[retained, np.arange(len(retained))] = 1.0
    R[np.ix_(eliminated, range(len(retained)))] = -scipy.linalg.lu_solve(lu, CS)
    R[np.ix_(eliminated, range(len(retained), n))] = scipy.linalg.lu_solve(lu, np.eye(nr))
    R_inv = np.vstack([np.eye(n)[retained], C])
    new = LinearSystem(
        R_inv @ sys.A @ R, R_inv @ sys.B, sys.C @ R, sys.D,
        states=[sys.states[j] for j in retained] + list(out_names), inputs=sys.inputs, outputs=sys.outputs,
    )
    for arr in (R, R_inv, pivots):
        arr.setflags(write=False)
    return VariableExchange(
        sys=new, R=R, R_inv=R_inv, exchanged=tuple(sys.states[j] for j in eliminated),
        retained=tuple(sys.states[j] for j in retained), outputs=out_names, pivots=pivots,
        condition=float(np.linalg.cond(CE)), transform_condition=float(np.linalg.cond(R, 1)), method=method,
        seconds=time.perf_counter() - t0,
    )


def _admissible(sys, out_names, among) -> list[NDArray[np.bool_]]:
    n = sys.n_states
    masks = [np.ones(n, dtype=bool) for _ in out_names]
    if among is None:
        return masks
    if not isinstance(among, Mapping):
        raise ModelError(f"among must map output names to sequences of state names, got {type(among).__name__}")
    for key, states in among.items():
        if key not in out_names:
            raise ModelError(f"among: {key!r} is not one of the exchanged outputs {list(out_names)}")
        states = [states] if isinstance(states, str) else list(states)
        mask = np.zeros(n, dtype=bool)
        for s in states:
            mask[signal_index(sys.states, s, f"among[{key!r}]")] = True
        masks[out_names.index(key)] = mask
    return masks


def _pivot_search(C, admissible, out_names, zero):
    """Largest-element pivot search with Gauss-Jordan elimination on ``[C | -I]`` (row order)."""
    nr, n = C.shape
    W = np.hstack([C, -np.eye(nr)])
    eliminated, pivots = [], []
    for r in range(nr):
        row = np.abs(W[r, :n]) * admissible[r]
        row[eliminated] = 0.0
        j = int(np.argmax(row))
        if row[j] <= zero:
            raise ModelError(
                f"output {out_names[r]!r} is not independent of the outputs before it (largest admissible pivot "
                f"{row[j]:.3g} <= tol * max|C| = {zero:.3g}); remove it or change among="
            )
        pivots.append(row[j])
        W[r] /= W[r, j]
        others = np.arange(nr) != r
        W[others] -= np.outer(W[others, j], W[r])
        eliminated.append(j)
    return eliminated, np.array(pivots)


def _qr_search(C, admissible, out_names, zero):
    """QR with column pivoting, per group of outputs sharing an admissible set of states."""
    nr, n = C.shape
    groups: dict[bytes, list[int]] = {}
    for r in range(nr):
        groups.setdefault(admissible[r].tobytes(), []).append(r)
    eliminated = [-1] * nr
    pivots = np.zeros(nr)
    used = np.zeros(n, dtype=bool)
    for group in groups.values():
        cols = np.nonzero(admissible[group[0]] & ~used)[0]
        if cols.size < len(group):
            raise ModelError(
                f"outputs {[out_names[r] for r in group]} have only {cols.size} admissible states left for "
                f"{len(group)} exchanges"
            )
        Q, Rq, perm = scipy.linalg.qr(C[np.ix_(group, cols)], pivoting=True, mode="economic")
        d = np.abs(np.diag(Rq))
        if np.any(d[: len(group)] <= zero):
            k = int(np.argmax(d[: len(group)] <= zero))
            raise ModelError(
                f"outputs {[out_names[r] for r in group]} are dependent: their admissible block of C has rank {k} "
                f"(QR pivot {d[k]:.3g} <= tol * max|C| = {zero:.3g})"
            )
        chosen = cols[perm[: len(group)]]
        # assign each chosen state to the output whose row dominates it after the triangular
        # factorization: rows of Q^T C_E are upper triangular, so any one-to-one assignment works;
        # keep the order of the rows for readability
        for r, j, p in zip(group, chosen, d[: len(group)]):
            eliminated[r] = int(j)
            pivots[r] = p
        used[chosen] = True
    return eliminated, pivots


@dataclass(frozen=True)
class PlantControllerPartition:
    """Result of :func:`plant_controller_partition`.

    Attributes
    ----------
    sys : LinearSystem
        The system with its states reordered as ``[z1; z2; z3; z4]``.
    groups : tuple of four tuples of str
        State names of ``z1`` (plant), ``z2`` (sensor signals), ``z3`` (controller),
        ``z4`` (controller outputs).
    blocks : tuple of tuples of ndarray
        ``blocks[i][j]`` is ``a_(i+1)(j+1)`` of the reordered ``A``.
    coupling : ndarray
        ``(4, 4)`` array of ``||a_ij||_1 / ||A||_1``.
    structural_zeros : dict of str to float
        Relative size of ``a13, a23, a31, a41``, which vanish when the controller sees the plant
        only through the sensors and the plant sees the controller only through its outputs.
    """

    sys: LinearSystem
    groups: tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...], tuple[str, ...]]
    blocks: tuple[tuple[NDArray[np.float64], ...], ...]
    coupling: NDArray[np.float64]
    structural_zeros: dict[str, float]


def plant_controller_partition(sys, *, sensors, controller, actuators) -> PlantControllerPartition:
    """Partition an exchanged monolithic plant+controller model into its four state groups.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem, control.StateSpace or VariableExchange
        The model after :func:`exchange_variables` (an exchange result is accepted directly).
    sensors : sequence of str
        States that are plant sensor signals (``z2``, the controller's inputs).
    controller : sequence of str
        Remaining controller states (``z3``).
    actuators : sequence of str
        States that are controller outputs (``z4``, the plant's inputs).

    Returns
    -------
    PlantControllerPartition
        The plant states ``z1`` are all the others.

    Raises
    ------
    ModelError
        On unknown or repeated state names.

    Notes
    -----
    ::

        d/dt [z1]   [a11 a12  0  a14] [z1]
             [z2] = [a21 a22  0  a24] [z2]
             [z3]   [ 0  a32 a33 a34] [z3]
             [z4]   [ 0  a42 a43 a44] [z4]

    (DISCOS report, Ch. III-D.1, Eqs. III-29/30.) The structural zeros hold for a strictly
    proper controller whose sensor signals depend on plant states only; their measured sizes are
    reported rather than assumed.

    Examples
    --------
    An oscillator, its position sensor, a first-order controller state and the torque command
    as a state; the controller sees the plant only through the sensor, so the structural zeros
    are exact:

    >>> import numpy as np
    >>> from linflex import LinearSystem
    >>> from linflex.linearize import plant_controller_partition
    >>> A = [[0, 1, 0, 0, 0],
    ...      [-1, 0, 0, 0, 1],
    ...      [0, 1, 0, 0, 0],
    ...      [0, 0, 1, -1, 0],
    ...      [0, 0, 10, 10, -10]]
    >>> sys = LinearSystem(A, np.zeros((5, 1)), states=["pos", "vel", "sensor", "xc", "torque"])
    >>> part = plant_controller_partition(sys, sensors=["sensor"], controller=["xc"], actuators=["torque"])
    >>> part.groups
    (('pos', 'vel'), ('sensor',), ('xc',), ('torque',))
    >>> max(part.structural_zeros.values())
    0.0
    """
    if isinstance(sys, VariableExchange):
        sys = sys.sys
    sys = as_linear_system(sys, "sys")
    picked: dict[int, str] = {}
    idx = []
    for what, names in (("sensors", sensors), ("controller", controller), ("actuators", actuators)):
        names = [names] if isinstance(names, str) else list(names)
        group = []
        for name in names:
            j = signal_index(sys.states, name, what)
            if j in picked:
                raise ModelError(f"{what}: state {sys.states[j]!r} is already listed in {picked[j]}")
            picked[j] = what
            group.append(j)
        idx.append(group)
    plant = [j for j in range(sys.n_states) if j not in picked]
    groups = [plant, *idx]
    order = [j for g in groups for j in g]
    A = sys.A[np.ix_(order, order)]
    new = LinearSystem(
        A, sys.B[order], sys.C[:, order], sys.D, states=[sys.states[j] for j in order],
        inputs=sys.inputs, outputs=sys.outputs,
    )
    edges = np.cumsum([0] + [len(g) for g in groups])
    blocks = tuple(
        tuple(A[edges[i]:edges[i + 1], edges[j]:edges[j + 1]] for j in range(4)) for i in range(4)
    )
    norm = np.linalg.norm(A, 1) or 1.0
    coupling = np.array([[np.linalg.norm(b, 1) / norm if b.size else 0.0 for b in row] for row in blocks])
    coupling.setflags(write=False)
    zeros = {f"a{i + 1}{j + 1}": float(coupling[i, j]) for i, j in ((0, 2), (1, 2), (2, 0), (3, 0))}
    return PlantControllerPartition(
        sys=new, groups=tuple(tuple(sys.states[j] for j in g) for g in groups), blocks=blocks,
        coupling=coupling, structural_zeros=zeros,
    )
