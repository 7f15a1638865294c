"""From a scene to the numbers of a stability-margin report.

This is one of the two places allowed to join every layer (ARCHITECTURE.md): it compiles the
scene's plant (every effect but ``control``), finds its operating point, linearizes it, closes
the loop with the scene's controllers as a :class:`linflex.frequency.Loop`, and computes modes
and margins, recording what each step cost.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import scipy.linalg

import linflex
from linflex import LinearSystem, ModelError, OperatingPoint
from linflex.frequency import Loop, transfer_function
from linflex.linearize import (
    Linearization,
    StiffnessShares,
    find_operating_point,
    linearize,
    scaled_residual,
    stiffness_shares,
)

from .._margins import StabilityMargins, stability_margins
from .._modes import ModeTable, modes

__all__ = ["SceneAnalysis", "analyse_scene", "margin_summary"]


@dataclass(frozen=True)
class SceneAnalysis:
    """Everything a stability-margin report says about one scene.

    Attributes
    ----------
    scene : Scene
        The scene analysed.
    plant : Linearization
        The plant (the scene without its controllers) linearized about ``plant.op``, with
        its error estimate and cost.
    trimmed : bool
        Whether the operating point had to be trimmed (the scene's initial state was not an
        equilibrium of the plant).
    loop : Loop
        Plant and controllers joined by named channels, negative feedback.
    open_loop : LinearSystem
        The loop broken at the plant inputs, ``L = K P``.
    margins : StabilityMargins
        Loop-at-a-time and multi-loop margins of ``open_loop``.
    plant_modes, closed_loop_modes : ModeTable
        Modal tables of the plant and of the closed loop.
    closed_loop_stable : bool
        Whether no closed-loop mode is unstable (structural zero eigenvalues, such as a
        quaternion's scalar part, are rigid-body modes, not instabilities).
    costs : Mapping[str, float]
        Wall time of each step [s].
    stiffness : StiffnessShares or None
        What makes each undamped plant mode stiff (structure, springs, centrifugal field,
        geometric stiffness, gravity gradient), from Kane's direct linearization at the same
        point (:func:`linflex.linearize.stiffness_shares`): each origin's share of each mode's
        squared frequency [rad^2/s^2], the frequencies [rad/s]; None when not asked for.
    """

    scene: object
    plant: Linearization
    trimmed: bool
    loop: Loop
    open_loop: LinearSystem
    margins: StabilityMargins
    plant_modes: ModeTable
    closed_loop_modes: ModeTable
    closed_loop_stable: bool
    costs: Mapping[str, float]
    stiffness: StiffnessShares | None


def _feedback_controller(scene) -> LinearSystem:
    """All controllers in one block-diagonal system, in the Loop's negative-feedback sign."""
    if not scene.controllers:
        raise ModelError(f"scene {scene.name!r} has no controllers: there is no loop to analyse")
    parts = [linflex.controller_system(c) for c in scene.controllers]
    inputs = [name for K in parts for name in K.inputs]
    outputs = [name for K in parts for name in K.outputs]
    for what, names in (("sensor", inputs), ("actuator", outputs)):
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ModelError(f"controllers: the {what}s {repeated} are used by more than one controller; "
                             "merge those controllers to analyse their loop")
    A = scipy.linalg.block_diag(*[K.A for K in parts]) if any(K.n_states for K in parts) else np.zeros((0, 0))
    B = scipy.linalg.block_diag(*[K.B for K in parts]).reshape(A.shape[0], len(inputs))
    C = scipy.linalg.block_diag(*[K.C for K in parts]).reshape(len(outputs), A.shape[0])
    D = scipy.linalg.block_diag(*[K.D for K in parts])
    # Loop convention: plant input = -beta, so beta = -u (see linflex.frequency.Loop).
    return LinearSystem(A, B, -C, -D, states=[s for K in parts for s in K.states], inputs=inputs, outputs=outputs)


def analyse_scene(scene, *, method: str = "autodiff", equilibrium_tol: float = 1e-8,
                  stiffness_by_origin: bool = True) -> SceneAnalysis:
    """Compile, trim, linearize and close the loops of a scene; margins and modes.

    Parameters
    ----------
    scene : Scene or path
        A scene (or a TOML file) with at least one controller.
    method : str
        Linearization method (see :func:`linflex.linearize.linearize`); exact by default.
    equilibrium_tol : float
        Largest scaled residual [1/s] accepted without trimming.
    stiffness_by_origin : bool
        Also split the plant's stiffness by origin (a Kane linearization at the same point
        when ``method`` is not ``"kane"``; sweeps that only want margins leave it out).

    Returns
    -------
    SceneAnalysis

    Raises
    ------
    ModelError
        For a scene without controllers or with a sensor or actuator shared between
        controllers; trim failures raise :class:`linflex.ConvergenceError`.

    Examples
    --------
    The rigid spacecraft of ``examples/attitude_control.toml`` under a PD on three axes:

    >>> from linflex.stability.report import analyse_scene
    >>> a = analyse_scene("examples/attitude_control.toml")
    >>> a.closed_loop_stable, a.trimmed, a.margins.channels
    (True, False, ('tx', 'ty', 'tz'))
    >>> [round(float(loop.min_phase_margin), 2) for loop in a.margins.loops]   # [deg]
    [65.16, 65.16, 65.16]
    """
    costs: dict[str, float] = {}
    start = time.perf_counter()
    if isinstance(scene, (str, Path)):
        scene = linflex.load_scene(scene)
    costs["load scene"] = time.perf_counter() - start
    controller = _feedback_controller(scene)

    start = time.perf_counter()
    plant_scene = dataclasses.replace(scene, effects=tuple(e for e in scene.effects if e != "control"))
    model = linflex.compile_model(plant_scene)
    costs["compile plant"] = time.perf_counter() - start

    start = time.perf_counter()
    op = OperatingPoint(model.x0, np.zeros(model.n_inputs))
    residual = model.evaluate(op.x, op.u)[0]
    trimmed = bool(np.max(scaled_residual(residual, op.x), initial=0.0) > equilibrium_tol)
    if trimmed:
        op = find_operating_point(model, op.x, op.u, fix_inputs=()).op
    costs["operating point"] = time.perf_counter() - start

    plant = linearize(model, op, method=method, equilibrium_tol=equilibrium_tol)
    costs[f"linearize ({plant.method})"] = plant.seconds

    start = time.perf_counter()
    # Structurally disconnected states (a quaternion's scalar part, unmeasured wheel speeds)
    # are in no transfer function but would count as closed-loop poles at 0.
    loop = Loop(plant.sys.connected_part(), controller, sensors=controller.inputs,
                actuators=controller.outputs)
    open_loop = loop.open_loop()
    closed = transfer_function(loop, "closed_loop")
    costs["loop assembly"] = time.perf_counter() - start

    start = time.perf_counter()
    margins = stability_margins(open_loop)
    costs["margins"] = time.perf_counter() - start

    start = time.perf_counter()
    plant_modes = modes(loop.plant)
    closed_modes = modes(closed)
    costs["modes"] = time.perf_counter() - start
    stable = not any(m.unstable for m in closed_modes)

    shares = None
    if stiffness_by_origin:
        start = time.perf_counter()
        direct = plant if plant.method == "kane" else linearize(model, op, method="kane", equilibrium_tol=equilibrium_tol)
        shares = stiffness_shares(direct)
        costs["stiffness by origin (kane)"] = time.perf_counter() - start
    return SceneAnalysis(scene, plant, trimmed, loop, open_loop, margins, plant_modes, closed_modes, stable,
                         MappingProxyType(costs), shares)


def margin_summary(scene, *, method: str = "autodiff") -> dict[str, float]:
    """The headline numbers of :func:`analyse_scene`, as a flat mapping for sweeps.

    Parameters
    ----------
    scene : Scene or path
        A scene with at least one controller.
    method : str
        Linearization method (see :func:`analyse_scene`).

    Returns
    -------
    dict
        ``gain_margin_db``: the smallest ``|20 log10 GM|`` over the loops (loop-at-a-time) [dB],
        ``inf`` without phase crossovers; ``phase_margin_deg``: the smallest ``|PM|`` [deg];
        ``delay_margin_s``: the smallest delay margin [s]; ``disk_margin``: the multi-loop
        balanced disk margin ``alpha``; ``closed_loop_stable``: 1 or 0;
        ``min_closed_loop_damping``: the smallest damping ratio of the closed-loop oscillatory
        modes; ``first_flexible_frequency``: the lowest oscillatory plant mode [rad/s] (``nan``
        without one).

    Examples
    --------
    >>> from linflex import load_scene
    >>> summary = margin_summary(load_scene("examples/attitude_control.toml"))  # doctest: +SKIP
    >>> sorted(summary)[:2]  # doctest: +SKIP
    ['closed_loop_stable', 'delay_margin_s']
    """
    result = analyse_scene(scene, method=method, stiffness_by_origin=False)
    loops = result.margins.loops
    gain_db = [abs(20.0 * np.log10(lp.min_gain_margin)) if 0 < lp.min_gain_margin < np.inf else np.inf for lp in loops]
    oscillatory_cl = [m.damping_ratio for m in result.closed_loop_modes.modes if m.kind == "oscillatory"]
    flexible = [m.natural_frequency for m in result.plant_modes.modes if m.kind == "oscillatory"]
    return {
        "gain_margin_db": float(min(gain_db, default=np.inf)),
        "phase_margin_deg": float(min((abs(lp.min_phase_margin) for lp in loops), default=np.inf)),
        "delay_margin_s": float(min((lp.delay_margin for lp in loops), default=np.inf)),
        "disk_margin": float(result.margins.disk_margin.alpha),
        "closed_loop_stable": float(result.closed_loop_stable),
        "min_closed_loop_damping": float(min(oscillatory_cl, default=np.nan)),
        "first_flexible_frequency": float(min(flexible, default=np.nan)),
    }
