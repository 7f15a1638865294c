"""Systems in series: the one series connection of linflex (controller chains, design filters)."""

from __future__ import annotations

import numpy as np

from ._errors import ModelError
from ._linear import LinearSystem, as_linear_system

__all__ = ["series"]


def series(*systems) -> LinearSystem:
    """Systems in series, the first one applied first.

    ::

        [x1]+ = [A1     0 ] [x1] + [B1   ] u        y = [D2 C1  C2] [x1] + D2 D1 u
        [x2]    [B2 C1  A2] [x2]   [B2 D1]                          [x2]

    Parameters
    ----------
    *systems : LinearSystem or any system :func:`linflex.as_linear_system` takes
        Each with as many inputs as the one before has outputs, and the same sampling period
        ``dt`` [s] (all continuous, or all sampled alike); without delays.

    Returns
    -------
    LinearSystem
        ``systems[-1] ... systems[1] systems[0]``: the first one's inputs, the last one's
        outputs, the states of all in order (each prefixed ``f<k>.`` when names repeat).

    Raises
    ------
    ModelError
        If no system is given, channel counts do not chain, or sampling periods differ.

    Examples
    --------
    >>> from linflex import low_pass, notch
    >>> chain = series(notch(5.0, 20.0, 2.0), low_pass(30.0))
    >>> chain.n_states, chain.inputs, chain.outputs
    (4, ('in',), ('out',))
    """
    if not systems:
        raise ModelError("series: give at least one system")
    parts = [as_linear_system(s, f"systems[{i}]", discrete=True) for i, s in enumerate(systems)]
    for k in range(1, len(parts)):
        if parts[k].n_inputs != parts[k - 1].n_outputs:
            raise ModelError(f"series: systems[{k}] has {parts[k].n_inputs} inputs but systems[{k - 1}] has "
                             f"{parts[k - 1].n_outputs} outputs")
        if parts[k].dt != parts[0].dt:
            raise ModelError(f"series: systems[{k}] has dt = {parts[k].dt} s but systems[0] has dt = {parts[0].dt} s")
    names = [s for p in parts for s in p.states]
    if len(set(names)) != len(names):
        names = [f"f{k}.{s}" for k, p in enumerate(parts) for s in p.states]
    A, B, C, D = parts[0].A, parts[0].B, parts[0].C, parts[0].D
    for p in parts[1:]:
        n1, n2 = A.shape[0], p.n_states
        A = np.block([[A, np.zeros((n1, n2))], [p.B @ C, p.A]])
        B = np.vstack([B, p.B @ D])
        C = np.hstack([p.D @ C, p.C])
        D = p.D @ D
    return LinearSystem(A, B, C, D, states=names, inputs=parts[0].inputs, outputs=parts[-1].outputs, dt=parts[0].dt)
