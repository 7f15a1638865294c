"""Structures: beams, modal data of flexible bodies, and component-mode synthesis and reduction."""

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
from ._inertia_loads import InertiaLoadStiffness, inertia_load_stiffness
from ._modal_data import ModalData, ModalIntegrals, load_modal_data
from ._nastran import NastranModel, join_components, nastran_modal_data, read_nastran

__all__ = [
    "Beam", "BeamStructure", "PointMassAt", "assemble_beams", "beam_modal_data", "ComponentReduction", "EffectiveMass",
    "StructuralModes", "Synthesis", "component_damping", "constraint_modes", "craig_bampton", "frequency_filter",
    "guyan", "modal_effective_mass", "modal_truncation_vectors", "structural_modes", "svd_component_reduction",
    "synthesize", "ModalData", "ModalIntegrals", "load_modal_data", "InertiaLoadStiffness", "inertia_load_stiffness",
    "NastranModel", "join_components", "nastran_modal_data", "read_nastran",
]
