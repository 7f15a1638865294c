"""linflex.linearize: linearization about operating points, trim, and model reduction."""

if __name__ != "linflex.linearize":
    raise ImportError(
        "this folder is the linflex.linearize package: install linflex (pip install -e .) and "
        "write 'import linflex.linearize', not 'import linearize'"
    )

# --- linearization ---
from ._autodiff import jacobian_function
from ._compare import LinearComparison, compare_linear_nonlinear
from ._constrained import ConstrainedLinearization, constrained_linearization
from ._direct import StiffnessShares, stiffness_shares
from ._linearization import METHODS, linearize, scaled_residual
from ._result import JacobianBlocks, Linearization
from ._trajectory import FrozenTimeModes, TrajectoryLinearization, linearize_along
from ._trim import TrimResult, find_operating_point

_LINEARIZATION_API = [
    "ConstrainedLinearization",
    "FrozenTimeModes",
    "METHODS",
    "StiffnessShares",
    "TrajectoryLinearization",
    "JacobianBlocks",
    "LinearComparison",
    "Linearization",
    "TrimResult",
    "compare_linear_nonlinear",
    "constrained_linearization",
    "find_operating_point",
    "jacobian_function",
    "linearize",
    "linearize_along",
    "scaled_residual",
    "stiffness_shares",
]
# --- end linearization ---

# --- reduction ---
# Every reduction chooses bases and projects through ._projection (one Petrov-Galerkin base, the
# reassembly with the kept unstable/rigid part, the Ritz projection of second-order systems); every
# result has the shape of ._projection.ReductionResult (sys, V, W, error_bound, measured_error,
# order, seconds; measured_error is a linflex.frequency.HinfNorm); the one threshold of the spectrum policy is called rigid_tol everywhere.
from ._balanced import BalancedTruncation, balanced_truncation
from ._exchange import PlantControllerPartition, VariableExchange, exchange_variables, plant_controller_partition
from ._modal import ModalTruncation, modal_truncation
from ._reduction_minimal import MinimalRealization, minimal_realization
from ._reduction_split import StableSplit, split_stable
from ._reduction_svd_modes import ProjectedModesReduction, projected_modes_reduction

_REDUCTION_API = [
    "BalancedTruncation",
    "MinimalRealization",
    "ModalTruncation",
    "PlantControllerPartition",
    "ProjectedModesReduction",
    "StableSplit",
    "VariableExchange",
    "balanced_truncation",
    "exchange_variables",
    "minimal_realization",
    "modal_truncation",
    "plant_controller_partition",
    "projected_modes_reduction",
    "split_stable",
]
# --- end reduction ---

__all__ = _LINEARIZATION_API + _REDUCTION_API
