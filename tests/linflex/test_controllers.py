"""controller_system: the scene's controller laws as linear systems.

The ``control`` effect compiles the same laws into the closed-loop model through the Kane
builder's sensor signals and actuator commands; closing the linearized plant by hand must give
the same closed loop (a check of the wiring and signs). The law itself is checked against the
closed-form PD design in tests/stability/test_report_analysis.py."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import linflex
from linflex import ModelError, controller_reference, controller_system
from linflex.linearize import linearize

SCENE = Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml"


def closed_loop_matrix(plant, K):
    """A of the plant closed by u = K(y) (command sign), plant D assumed zero::

        [ A + B Dk C    B Ck ]
        [   Bk C         Ak  ]
    """
    C = plant.C[[plant.outputs.index(s) for s in K.inputs]]
    B = plant.B[:, [plant.inputs.index(a) for a in K.outputs]]
    return np.block([[plant.A + B @ K.D @ C, B @ K.C], [K.B @ C, K.A]])


@pytest.mark.parametrize("variant", ["pd", "pid", "transfer_function"])
def test_closed_loop_equals_the_control_effect(variant):
    scene = linflex.load_scene(SCENE)
    pd = dataclasses.replace(scene.controllers[0], reference=None)
    if variant == "pid":
        controller = dataclasses.replace(pd, ki=[2.0, 3.0, 1.0])
    elif variant == "transfer_function":
        # A lead filter per channel on the attitude error only (no rate path).
        controller = dataclasses.replace(pd, type="transfer_function", num=[60.0, 25.0], den=[0.2, 1.0],
                                         rate_inputs=None, kp=0.0, kd=0.0)
    else:
        controller = pd
    closed = dataclasses.replace(scene, controllers=(controller,))
    plant_scene = dataclasses.replace(closed, effects=tuple(e for e in closed.effects if e != "control"))
    model = linflex.compile_model(closed)
    reference = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs)))
    plant = linearize(linflex.compile_model(plant_scene), linflex.OperatingPoint(model.x0[:7], np.zeros(3))).sys
    ours = closed_loop_matrix(plant, controller_system(controller))
    # Independent implementations of the same law: eigenvalues agree to round-off.
    expected = np.sort_complex(np.linalg.eigvals(reference.sys.A))
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(ours)), expected, atol=1e-9)


def test_names_and_reference():
    controller = linflex.load_scene(SCENE).controllers[0]
    K = controller_system(controller)
    assert K.inputs == ("roll", "pitch", "yaw", "p", "q", "r") and K.outputs == ("tx", "ty", "tz")
    np.testing.assert_array_equal(controller_reference(controller), [0.05, -0.03, 0.02])
    # u = -kp theta - kd omega: command sign.
    assert K.D[0, 0] == -25.0 and K.D[0, 3] == -70.0


def test_bad_controllers():
    controller = linflex.load_scene(SCENE).controllers[0]
    with pytest.raises(ModelError, match="one rate sensor per channel"):
        controller_system(dataclasses.replace(controller, rate_inputs=["p"]))
    with pytest.raises(ModelError, match="unknown controller type 'lqr'"):
        controller_system(dataclasses.replace(controller, type="lqr"))
    with pytest.raises(ModelError, match="gains must be scalars or one per channel"):
        controller_system(dataclasses.replace(controller, kp=[1.0, 2.0]))
