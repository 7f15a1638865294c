"""Thrusters and the closed-loop controllers of a scene."""

from __future__ import annotations

import casadi as ca

from ..scene._chains import is_sampled
from ..scene._registry import Effect, register_effect
from ..scene._values import unit_vector, vector3
from ._controllers import controller_chain, controller_reference, sampled_controller


class Thrusters(Effect):
    """``thrusters``: thruster actuators (force along ``axis`` at ``point``, command in N);
    without it thruster actuators have no input and apply nothing."""

    name = "thrusters"
    order = 10

    def structure(self, b, scene):
        for a in scene.actuators:
            if a.type == "thruster":
                b.commands[a.name] = b.add_input([a.name])

    def loads(self, b, scene):
        for a in scene.actuators:
            if a.type == "thruster":
                C = b.frames[a.body].C
                b.add_force(a.body, vector3(a.point), C @ ca.DM(unit_vector(a.axis)) * b.commands[a.name])


class Control(Effect):
    """``control``: the controllers' dynamics, from sensor signals to actuator commands; states
    ``<controller>.x<k>``. Without it the actuator commands are the model's inputs only.

    A sampled controller (``sample_time``) is not part of the continuous equations: its
    actuators' commands stay inputs of the model, which the simulator drives at the sample
    instants (``model.compiled.sampled_controllers``)."""

    name = "control"

    def signals(self, b, scene):
        # One implementation of the controller laws: controller_chain gives (the law, then its
        # filters) u = C xc + D [y - reference; r], xc' = A xc + B [y - reference; r].
        b.sampled_controllers = tuple(sampled_controller(c) for c in scene.controllers if is_sampled(c))
        for c in scene.controllers:
            if is_sampled(c):
                continue
            K = controller_chain(c)
            reference = controller_reference(c)  # on the inputs; the rate inputs have none
            measured = ca.vertcat(*[b.sensor_signals[s] for s in K.inputs])
            offset = ca.vertcat(ca.DM(reference), ca.DM.zeros(K.n_inputs - reference.size, 1))
            deviation = measured - offset
            out = ca.DM(K.D) @ deviation
            if K.n_states:
                xc = b.add_state(list(K.states))
                b.set_rate(xc, ca.DM(K.A) @ xc + ca.DM(K.B) @ deviation)
                out += ca.DM(K.C) @ xc
            for k, act in enumerate(K.outputs):
                b.commands[act] = b.commands[act] + out[k]


for _effect in (Thrusters(), Control(),):
    register_effect(_effect)
