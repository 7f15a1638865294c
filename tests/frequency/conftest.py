"""Shared models for the frequency-layer tests."""


import numpy as np

from linflex import LinearSystem

from ..mor import load_mor  # noqa: F401  (re-exported for the tests of this folder)


def two_mass(m1=2.0, m2=3.0, c=0.4, k=5.0) -> LinearSystem:
    """Reference notes section 13: two masses, spring and dashpot, force F1 on mass 1,
    state (x1', x2', x1, x2), every state an output."""
    A = np.array([
        [-c / m1, c / m1, -k / m1, k / m1],
        [c / m2, -c / m2, k / m2, -k / m2],
        [1, 0, 0, 0],
        [0, 1, 0, 0],
    ])
    b = np.array([[1 / m1], [0], [0], [0]])
    names = ["v1", "v2", "x1", "x2"]
    return LinearSystem(A, b, np.eye(4), states=names, inputs=["F1"], outputs=names)


def flexible_modal(n_modes: int, zeta: float, *, seed: int = 0, rigid: bool = False, n_in: int = 1,
                   n_out: int = 1, collocated: bool = True) -> LinearSystem:
    """A modal model of a flexible structure: block-diagonal 2x2 modes with frequencies spread
    over 0.5..50 rad/s, damping ``zeta``; optionally a rigid-body double integrator first."""
    rng = np.random.default_rng(seed)
    w = np.sort(np.exp(rng.uniform(np.log(0.5), np.log(50.0), n_modes)))
    blocks = [np.array([[0.0, 1.0], [-wi**2, -2 * zeta * wi]]) for wi in w]
    if rigid:
        blocks = [np.array([[0.0, 1.0], [0.0, 0.0]])] + blocks
    n = 2 * len(blocks)
    A = np.zeros((n, n))
    for i, blk in enumerate(blocks):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = blk
    phi = rng.uniform(0.2, 1.0, (len(blocks), n_in))
    B = np.zeros((n, n_in))
    B[1::2] = phi
    C = np.zeros((n_out, n))
    C[:, 0::2] = phi[:, :n_out].T if collocated and n_out <= n_in else rng.uniform(0.2, 1.0, (n_out, len(blocks)))
    return LinearSystem(A, B, C)
