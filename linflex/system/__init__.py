"""System types and the ground floor every layer stands on: linear and nonlinear systems, operating points, errors, signals and shared numerics.

The names below the public ones (``signal_index``, ``frozen_array``, ``real_matrix``,
``real_vector``, ``schur_eigenvalues``, ``complex_schur`` (with ``complex_schur_from_real`` and
``apply_rotations``), ``colored_jacobian``, ``diagonal_balance``, ``Progress``, ``plot_axes``, and the
exact maps of sampled and delayed systems ``w_plane``, ``to_w_frequency``, ``from_w_frequency``,
``delay_factors``) are the layers'
internal API: :mod:`linflex.linearize`, :mod:`linflex.frequency` and :mod:`linflex.stability`
import them from here, never from the private modules.
Every output file is written through ``atomic_write`` / ``replaced_folder`` (``_files.py``).
"""

from ._display import display_value, html_summary, short_repr
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
from ._files import OutputError, atomic_write, check_output_file, check_output_folder, file_lock, replaced_folder
from ._filters import lead_lag, low_pass, notch
from ._galerkin import GalerkinBases
from ._jacobians import colored_jacobian
from ._linear import DENSE_STATES_MAX, LinearSystem, SecondOrderSystem, as_linear_system
from ._model import NonlinearModel, OperatingPoint
from ._numerics import apply_rotations, complex_schur, complex_schur_from_real, diagonal_balance, schur_eigenvalues
from ._plotting import PlotHandle, plot_axes
from ._progress import Progress, stderr_is_terminal
from ._sampling import PadeApproximation, delay_factors, discretize, from_w_frequency, pade, to_w_frequency, w_plane
from ._series import series
from ._signals import check_positive, frozen_array, real_array, real_matrix, real_vector, signal_index, signal_names

__all__ = [
    "AccuracyWarning", "ConvergenceError", "LinflexError", "LinflexWarning", "MethodUnavailableError", "ModelError",
    "NotAnEquilibriumError", "ShapeError", "LinearSystem", "SecondOrderSystem", "as_linear_system",
    "lead_lag", "low_pass", "notch", "series",
    "NonlinearModel", "OperatingPoint", "PlotHandle",
    "NonlinearModel", "OperatingPoint", "PlotHandle", "PadeApproximation", "discretize", "pade",
    "delay_factors", "from_w_frequency", "to_w_frequency", "w_plane",
    # the layers' internal API
    "DENSE_STATES_MAX", "GalerkinBases", "diagonal_balance", "plot_axes", "schur_eigenvalues", "complex_schur", "complex_schur_from_real",
    "apply_rotations", "colored_jacobian", "Progress", "stderr_is_terminal", "check_positive", "frozen_array", "real_array",
    "real_matrix", "real_vector", "signal_index", "signal_names", "display_value", "html_summary", "short_repr",
    "OutputError", "atomic_write", "check_output_file", "check_output_folder", "file_lock", "replaced_folder",
]
