"""Equations of motion: Kane's method as a CasADi graph, flexible-body terms, the order-n recursion and loop constraints.

``pivoted_columns`` is part of the layers' internal API (:mod:`linflex.linearize` uses it for
constrained linearization).
"""

from ._constraints import LoopClosure, pivoted_columns
from ._kane import KaneBuilder
from ._order_n import FORMULATIONS

__all__ = ["FORMULATIONS", "KaneBuilder", "LoopClosure", "pivoted_columns"]
