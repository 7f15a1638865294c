"""linflex: linearization, reduction and frequency-domain analysis of flexible spacecraft.

The core holds the system types, nonlinear models and the exception hierarchy. The layers are
subpackages: :mod:`linflex.linearize`, :mod:`linflex.frequency`, :mod:`linflex.stability`.
"""

from ._errors import (
    AccuracyWarning,
    ConvergenceError,
    LinflexError,
    LinflexWarning,
    MethodUnavailableError,
    ModelError,
    NotAnEquilibriumError,
    ShapeError,
)
from ._linear import LinearSystem, SecondOrderSystem, as_linear_system
from ._model import NonlinearModel, OperatingPoint
from ._version import __version__

# --- scenes ---
_SCENE_API: list[str] = []
# --- end scenes ---

__all__ = _SCENE_API + [
    "AccuracyWarning",
    "ConvergenceError",
    "LinearSystem",
    "LinflexError",
    "LinflexWarning",
    "MethodUnavailableError",
    "ModelError",
    "NonlinearModel",
    "NotAnEquilibriumError",
    "OperatingPoint",
    "SecondOrderSystem",
    "ShapeError",
    "__version__",
    "as_linear_system",
]
