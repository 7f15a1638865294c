"""The common bases of a Galerkin (Rayleigh-Ritz) reduction ``x ~ T q``: one definition for the
core's component-mode reductions and ``linearize``'s projected-modes reduction."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["GalerkinBases"]


class GalerkinBases:
    """Mixin of a reduction result with a basis ``T``: the common result fields ``V``, ``W``,
    ``order`` and ``error_bound`` of every linflex reduction (``docs/architecture.md``).

    Examples
    --------
    >>> import numpy as np
    >>> from linflex.system import GalerkinBases
    >>> class Ritz(GalerkinBases):
    ...     T = np.eye(3)[:, :2]
    >>> Ritz().order, Ritz().error_bound
    (2, None)
    """

    T: NDArray[np.float64]

    @property
    def V(self) -> NDArray[np.float64]:
        """The right basis ``T`` (the full coordinates are ``V`` times the reduced ones)."""
        return self.T

    @property
    def W(self) -> NDArray[np.float64]:
        """The left basis: ``T`` as well (a Galerkin projection, ``T^T M T``, ``T^T K T``)."""
        return self.T

    @property
    def order(self) -> int:
        """Number of reduced coordinates (columns of ``T``)."""
        return int(self.T.shape[1])

    @property
    def error_bound(self) -> None:
        """None: a Galerkin projection of modes has no a-priori error bound (see ``measured_error``)."""
        return None
