"""Tolerances shared by the stability modules: the spectrum policy of ``linflex.frequency``.

The definitions (system scale, rigid-body and imaginary-axis eigenvalues, ``rigid_tol``) live in
``frequency/_spectrum.py``, one place for the whole package; this module only re-exports them for
the stability modules.
"""

from __future__ import annotations

from linflex.frequency._spectrum import check_positive, classify, rigid_mask, system_scale

__all__ = ["rigid_mask", "system_scale", "check_positive", "classify"]
