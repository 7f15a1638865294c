"""The scene compiler: a validated scene and its named effects become one compiled :class:`Model` (CasADi functions)."""

from ._compile import Model, compile_model

__all__ = ["Model", "compile_model"]
