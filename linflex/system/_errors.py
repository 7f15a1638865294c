"""The linflex exception and warning hierarchy.

Every exception linflex raises for bad input or a failed computation derives from
:class:`LinflexError` and also from the matching builtin, so callers may catch either
(``except ValueError`` keeps working).
"""

from __future__ import annotations

__all__ = [
    "LinflexError",
    "ModelError",
    "ShapeError",
    "NotAnEquilibriumError",
    "ConvergenceError",
    "MethodUnavailableError",
    "LinflexWarning",
    "AccuracyWarning",
]


class LinflexError(Exception):
    """Base class of every error linflex raises on purpose."""


class ModelError(LinflexError, ValueError):
    """A model, scene or system is malformed, or a model failed when evaluated."""


class ShapeError(LinflexError, ValueError):
    """An array argument has the wrong shape; the message names the argument."""


class NotAnEquilibriumError(LinflexError, ValueError):
    """Linearization was asked about a point where the state derivative is not zero.

    Attributes
    ----------
    residual : numpy.ndarray
        The state derivative at the operating point [state units/s].
    """

    def __init__(self, message: str, residual=None):
        super().__init__(message)
        self.residual = residual


class ConvergenceError(LinflexError, RuntimeError):
    """An iterative method did not reach the requested accuracy."""


class MethodUnavailableError(LinflexError, TypeError):
    """The requested method cannot be applied to this kind of model."""


class LinflexWarning(UserWarning):
    """Base class of linflex warnings."""


class AccuracyWarning(LinflexWarning):
    """A result is less accurate than requested; its error estimate says by how much."""
