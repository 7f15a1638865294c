"""Exact Jacobians of CasADi graphs by coloured directional sweeps (the layers' internal API:
:func:`colored_jacobian`, used by the simulator and by :mod:`linflex.linearize`)."""

from __future__ import annotations

import numpy as np

__all__ = ["colored_jacobian", "DIRECTIONS_PER_CALL", "REVERSE_SWEEP_COST"]

# A reverse sweep costs about this many forward sweeps (measured on the compiled chains and
# spacecraft of benchmarks/linearization.py: 1.3 to 1.6).
REVERSE_SWEEP_COST = 1.5

# Directions per call of the sweep function mapped over the colours. The directions of one call
# share the primal values (and an MX graph's linear-solve factorizations): each added direction
# costs about the same to build but saves less and less evaluation. Measured at the 500-state
# chain (an SX graph of 81k instructions, 251 reverse sweeps) with 1 / 2 / 4 / 8 directions per
# call: later calls 98 / 83 / 72 / 68 ms, first calls 0.35 / 0.40 / 0.51 / 0.82 s (6 was no
# faster than 4 within the noise); on the 90-state MX arrays scene 4 were 1.7x faster than 1.
DIRECTIONS_PER_CALL = 4


def colored_jacobian(expr, z, others, Z, Others):
    """``d expr / d z`` at ``z = Z, others = Others``, an MX expression with the Jacobian's sparsity.

    ``expr`` (SX or MX, a column) depends on the symbols ``z`` and ``others``; the Jacobian is made
    of forward (``J V``) or reverse (``J^T V``) sweeps, ``ca.jtimes`` with
    ``DIRECTIONS_PER_CALL`` seed columns ``V`` per call, mapped over the colours of its sparsity
    (columns, or rows, with disjoint structure share one sweep), whichever needs fewer sweeps
    (a reverse sweep counted ``REVERSE_SWEEP_COST`` forward ones); the compressed result is
    scattered back to the sparsity. Only the sweep of one call is a symbolic graph (a few times
    the size of ``expr``), not the whole Jacobian (that costs about a microsecond per
    instruction and direction, 10 s for a 500-state chain), and large linear solves of MX
    graphs stay numeric nodes. Exact to round-off, like the symbolic Jacobian.

    Parameters
    ----------
    expr : casadi.SX or casadi.MX
        The function's value, a column [its units].
    z : casadi.SX or casadi.MX
        The symbols to differentiate by (a column; same kind as ``expr``).
    others : list
        The other symbols ``expr`` depends on (same kind).
    Z : casadi.MX
        Where: the value of ``z`` (MX symbols or expressions).
    Others : list of casadi.MX
        The values of ``others``.

    Returns
    -------
    casadi.MX
        The Jacobian [units of expr per unit of z], shape ``(expr.numel(), z.numel())``.
    """
    import casadi as ca

    g = ca.Function("g", [z, *others], [expr])
    sparsity = g.jac_sparsity(0, 0)
    columns, rows = sparsity.uni_coloring(), sparsity.T.uni_coloring()
    reverse = REVERSE_SWEEP_COST * rows.size2() < columns.size2()
    coloring = rows if reverse else columns
    n_sweeps = coloring.size2()
    if n_sweeps == 0 or sparsity.nnz() == 0:
        return ca.MX(sparsity.size1(), sparsity.size2())
    K = min(DIRECTIONS_PER_CALL, n_sweeps)
    nb = -(-n_sweeps // K)
    seeds = np.zeros((coloring.size1(), nb * K))
    seeds[:, :n_sweeps] = np.asarray(ca.DM(coloring))  # a one where an index has the colour
    seed = type(z).sym("seed", coloring.size1(), K)
    sweeps = ca.Function("sweeps", [z, *others, seed], [ca.jtimes(expr, z, seed, reverse)])
    # z and the others are the same for every call: passed once, not repeated nb times
    shared = list(range(1 + len(others)))
    compressed = sweeps.map("sweeps", "serial", nb, shared, [])(Z, *Others, ca.DM(seeds))[:, :n_sweeps]
    colour = np.zeros(coloring.size1(), dtype=int)
    index, which = coloring.get_triplet()
    colour[np.asarray(index, dtype=int)] = np.asarray(which, dtype=int)
    i, j = (np.asarray(v, dtype=int) for v in sparsity.get_triplet())
    # column-major positions in the compressed matrix of every structural nonzero (i, j)
    position = j + sparsity.size2() * colour[i] if reverse else i + sparsity.size1() * colour[j]
    return ca.MX(sparsity, ca.vec(compressed)[position.tolist()])
