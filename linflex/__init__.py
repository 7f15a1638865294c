"""linflex: linearization, reduction and frequency-domain analysis of flexible spacecraft.

The core holds the system types, nonlinear models and the exception hierarchy. The layers are
subpackages: :mod:`linflex.linearize`, :mod:`linflex.frequency`, :mod:`linflex.stability`.
"""

from ._beam import Beam, BeamStructure, PointMassAt, assemble_beams, beam_modal_data
from ._components import (
    ComponentReduction,
    EffectiveMass,
    StructuralModes,
    Synthesis,
    component_damping,
    constraint_modes,
    craig_bampton,
    frequency_filter,
    guyan,
    modal_effective_mass,
    modal_truncation_vectors,
    structural_modes,
    svd_component_reduction,
    synthesize,
)
from ._controllers import controller_reference, controller_system
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
from ._modal_data import ModalData, ModalIntegrals, load_modal_data
from ._model import NonlinearModel, OperatingPoint
from ._segments import rigid_segment_beam, segment_spring_constants
from ._version import __version__

# --- scenes ---
# isort: split
from ._compile import Model, compile_model
from ._effects import Effect, register_effect, registered_effects
from ._scene import (
    Actuator,
    Body,
    Controller,
    Disturbance,
    Environment,
    Frame,
    Joint,
    LoopJoint,
    Orbit,
    Pendulum,
    PointMass,
    Scene,
    Sensor,
    Spring,
    Surface,
    Wheel,
    load_scene,
)
from ._simulate import TimeResponse, simulate, time_response_plot

_SCENE_API: list[str] = [
    "Actuator", "Body", "Controller", "Disturbance", "Effect", "Environment", "Frame", "Joint", "LoopJoint", "Model",
    "Orbit", "Pendulum", "PointMass", "Scene", "Sensor", "Spring", "Surface", "TimeResponse", "Wheel",
    "compile_model", "load_scene", "register_effect", "registered_effects", "simulate",
    "time_response_plot",
]
# --- end scenes ---

# --- sweeps ---
# isort: split
from ._sweep import SweepResult, parameter_grid, parameter_sample, sweep, sweep_scatter_plot, vary_scene

_SWEEP_API: list[str] = ["SweepResult", "parameter_grid", "parameter_sample", "sweep", "sweep_scatter_plot", "vary_scene"]
# --- end sweeps ---

__all__ = _SCENE_API + _SWEEP_API + [
    "AccuracyWarning",
    "Beam",
    "BeamStructure",
    "ComponentReduction",
    "EffectiveMass",
    "StructuralModes",
    "Synthesis",
    "ConvergenceError",
    "LinearSystem",
    "LinflexError",
    "LinflexWarning",
    "MethodUnavailableError",
    "ModalData",
    "ModalIntegrals",
    "ModelError",
    "NonlinearModel",
    "NotAnEquilibriumError",
    "OperatingPoint",
    "PointMassAt",
    "SecondOrderSystem",
    "ShapeError",
    "__version__",
    "as_linear_system",
    "assemble_beams",
    "component_damping",
    "constraint_modes",
    "craig_bampton",
    "frequency_filter",
    "guyan",
    "modal_effective_mass",
    "modal_truncation_vectors",
    "rigid_segment_beam",
    "segment_spring_constants",
    "structural_modes",
    "svd_component_reduction",
    "synthesize",
    "beam_modal_data",
    "controller_reference",
    "controller_system",
    "load_modal_data",
]
