"""linflex: linearization, reduction and frequency-domain analysis of flexible spacecraft.

The core is in rooms, one subpackage per concern (``docs/architecture.md`` draws them):
:mod:`linflex.system` (system types, errors, the layers' shared numerics),
:mod:`linflex.structures` (beams, modal data, component modes), :mod:`linflex.scene` (entries,
validation, the effect vocabulary, TOML), :mod:`linflex.dynamics` (Kane's equations, order-n,
constraints), :mod:`linflex.effects` (the built-in effects), :mod:`linflex.compiler` (scene to
model), :mod:`linflex.simulation`, :mod:`linflex.sweeps` and :mod:`linflex.cli`. The public names
are re-exported here. The layers are subpackages: :mod:`linflex.linearize`,
:mod:`linflex.frequency`, :mod:`linflex.stability`.
"""

from ._version import __version__
from .structures import (
    Beam,
    BeamStructure,
    ComponentReduction,
    EffectiveMass,
    InertiaLoadStiffness,
    ModalData,
    ModalIntegrals,
    NastranModel,
    PointMassAt,
    StructuralModes,
    Synthesis,
    assemble_beams,
    beam_modal_data,
    component_damping,
    constraint_modes,
    craig_bampton,
    frequency_filter,
    guyan,
    inertia_load_stiffness,
    join_components,
    load_modal_data,
    modal_effective_mass,
    modal_truncation_vectors,
    nastran_modal_data,
    read_nastran,
    structural_modes,
    svd_component_reduction,
    synthesize,
)
from .system import (
    AccuracyWarning,
    ConvergenceError,
    LinearSystem,
    LinflexError,
    LinflexWarning,
    MethodUnavailableError,
    ModelError,
    NonlinearModel,
    NotAnEquilibriumError,
    OperatingPoint,
    PadeApproximation,
    PlotHandle,
    SecondOrderSystem,
    ShapeError,
    as_linear_system,
    discretize,
    lead_lag,
    low_pass,
    notch,
    pade,
)

# --- scenes ---
# isort: split
from .compiler import Model, compile_model
from .effects import controller_chain, controller_reference, controller_system
from .scene import (
    Actuator,
    Body,
    Boom,
    Constraint,
    Controller,
    Disturbance,
    Effect,
    Environment,
    Frame,
    InputProfile,
    Joint,
    Limits,
    LoopJoint,
    Orbit,
    Pendulum,
    PointMass,
    Requirements,
    Scene,
    Sensor,
    Spring,
    Surface,
    Tank,
    ThermalLoad,
    Wheel,
    load_scene,
    register_effect,
    registered_effects,
    rigid_segment_beam,
    segment_spring_constants,
)
from .simulation import (
    TimeResponse,
    forced_response,
    impulse_response,
    initial_response,
    simulate,
    step_response,
    time_response_plot,
)

_SCENE_API: list[str] = [
    "Actuator", "Body", "Constraint", "Controller", "Disturbance", "Effect", "Environment", "Frame", "InputProfile", "Joint", "Limits", "LoopJoint", "Model",
    "Orbit", "Pendulum", "PointMass", "Requirements", "Scene", "Sensor", "Spring", "Surface", "TimeResponse", "Wheel",
    "compile_model", "load_scene", "register_effect", "registered_effects", "simulate",
    "time_response_plot", "forced_response", "impulse_response", "initial_response", "step_response",
    "Boom", "Tank", "ThermalLoad",
]
# --- end scenes ---

# --- sweeps ---
# isort: split
from .sweeps import SweepResult, parameter_grid, parameter_sample, sweep, sweep_scatter_plot, vary_scene

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
    "PlotHandle",
    "PointMassAt",
    "SecondOrderSystem",
    "ShapeError",
    "__version__",
    "as_linear_system",
    "lead_lag",
    "low_pass",
    "notch",
    "PadeApproximation",
    "discretize",
    "pade",
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
    "controller_chain",
    "controller_reference",
    "controller_system",
    "load_modal_data",
    "InertiaLoadStiffness",
    "NastranModel",
    "inertia_load_stiffness",
    "join_components",
    "nastran_modal_data",
    "read_nastran",
]
