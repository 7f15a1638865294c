"""The effects registry and the built-in effects.

An effect is a plug-in that contributes terms to the Kane builder (:class:`~linflex._kane.KaneBuilder`)
when a scene names it in ``effects``; an effect a scene does not name adds nothing to the compiled
graph. An effect is an object with a ``name`` and up to four methods, each optional:

``check(scene) -> list[str]``
    Extra validation problems (``"path: message"``), reported by :meth:`Scene.validate`.
``structure(builder, scene)``
    Before the kinematics are closed: add coordinates and speeds (``add_coordinates``,
    ``set_kinematics``), mass elements (``add_element``), inputs (``add_input``), or ``detach`` a
    part that is otherwise rigidly attached to its body so that the effect can make it move.
``signals(builder, scene)``
    With the kinematics known: add states (``add_state``/``set_rate``), outputs, and terms to
    the actuator commands in ``builder.commands`` (sensor signals are in ``builder.sensor_signals``).
``loads(builder, scene)``
    Forces and torques (``add_force``, ``add_force_at``, ``add_torque``,
    ``add_element_torque``, ``add_generalized_force``) and potential energy (``add_potential``).

Register a new one with :func:`register_effect`; see ``Effect`` for a base class.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import casadi as ca
import numpy as np

from ._controllers import controller_reference, controller_system
from ._errors import ModelError
from ._kane import KaneBuilder, MassElement, cross, rot_axis
from ._scene import R_EARTH, vector3, wheel_inertia

__all__ = ["Effect", "register_effect", "registered_effects"]


class Effect:
    """Base class of effects: override the stages the effect needs.

    Attributes
    ----------
    name : str
        The name scenes use in ``effects``.
    needs_orbit : bool
        Whether the scene must have an ``[orbit]`` table.
    order : int
        Effects run in increasing ``order`` within each stage (ties: scene order).

    Examples
    --------
    A constant body torque, registered under a new name:

    >>> import numpy as np
    >>> from linflex import Effect, register_effect
    >>> class Bias(Effect):
    ...     name = "bias_torque"
    ...     def loads(self, b, scene):
    ...         b.add_torque(scene.bodies[0].name, np.array([0.0, 0.0, 1e-3]))
    >>> register_effect(Bias(), replace=True)
    """

    name: str = ""
    needs_orbit: bool = False
    order: int = 50

    def check(self, scene) -> list[str]:
        """Problems of ``scene`` that this effect cannot accept (run by scene validation).

        Parameters
        ----------
        scene : Scene
            The scene being validated (SI units throughout).

        Returns
        -------
        list of str
            One message per problem, each starting with the path of the entry
            (``"bodies[2].inertia: ..."``); empty when the scene is fine. The base class
            returns ``[]``.
        """
        return []

    def structure(self, b: KaneBuilder, scene) -> None:
        """Stage 1: add coordinates, states, inputs or mass elements, before the kinematics close.

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_coordinates``, ``b.add_state``,
            ``b.add_input``, ``b.add_element``).
        scene : Scene
            The scene being compiled.
        """

    def signals(self, b: KaneBuilder, scene) -> None:
        """Stage 2: add outputs or replace sensor signals, once the kinematics are known.

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_output``, ``b.sensor_signals``); outputs
            in SI units ([m], [rad], [rad/s], [N], [N m], ...).
        scene : Scene
            The scene being compiled.
        """

    def loads(self, b: KaneBuilder, scene) -> None:
        """Stage 3: add forces [N], torques [N m], generalized forces or a potential [J].

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_force``, ``b.add_torque``,
            ``b.add_generalized_force``, ``b.add_potential``); ``b.origin`` is this effect's
            name, so that the linearization's stiffness split credits it.
        scene : Scene
            The scene being compiled.
        """

    def __repr__(self) -> str:
        return f"<effect {self.name!r}>"


_REGISTRY: dict[str, Effect] = {}


def register_effect(effect: Effect, *, replace: bool = False) -> None:
    """Register ``effect`` under ``effect.name``.

    Parameters
    ----------
    effect : Effect
        The effect; its ``name`` is the key scenes list in ``effects``.
    replace : bool, optional
        Allow replacing an effect already registered under that name.

    Returns
    -------
    None

    Raises
    ------
    ModelError
        When the name is empty or already registered (and ``replace`` is false), or the object
        has none of the stage methods.

    Examples
    --------
    >>> from linflex import Effect, register_effect, registered_effects
    >>> class NoLoad(Effect):
    ...     name = "no_load"
    ...     def loads(self, b, scene):
    ...         pass
    >>> register_effect(NoLoad(), replace=True)
    >>> "no_load" in registered_effects()
    True
    """
    name = getattr(effect, "name", "")
    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError(f"effect.name must be an identifier string, got {name!r}")
    if name in _REGISTRY and not replace:
        raise ModelError(f"effect {name!r} is already registered; pass replace=True to override it")
    if not any(callable(getattr(effect, m, None)) for m in ("structure", "signals", "loads")):
        raise ModelError(f"effect {name!r} has none of the methods structure, signals, loads")
    _REGISTRY[name] = effect


def registered_effects() -> Mapping[str, Effect]:
    """A read-only view of the registered effects by name.

    Returns
    -------
    Mapping of str to Effect
        The registry, read-only (register with :func:`register_effect`).

    Examples
    --------
    >>> from linflex import registered_effects
    >>> "gravity" in registered_effects(), "joint_springs" in registered_effects()
    (True, True)
    """
    return MappingProxyType(_REGISTRY)


def _unit(v) -> np.ndarray:
    v = vector3(v)
    return v / np.linalg.norm(v)


def _orbit_gravity(b: KaneBuilder, r):
    """Point-mass gravity at the origin + r minus the origin's (the frame is in free fall)."""
    R = b.R_O + r
    return -b.mu * R / ca.norm_2(R) ** 3 + b.mu * b.R_O / ca.norm_2(b.R_O) ** 3


# -- gravity -----------------------------------------------------------------------------------


class UniformGravity(Effect):
    """``gravity``: uniform field ``environment.gravity`` (inertial axes) on every mass."""

    name = "gravity"

    def loads(self, b, scene):
        g_F = b.C_NF.T @ ca.DM(vector3(scene.environment.gravity))
        for el in b.elements:
            if el.has_mass:
                b.add_force_at(el.r, el.mass * g_F)
                b.add_potential(-el.mass * ca.dot(g_F, el.r))


class CentralGravity(Effect):
    """``central_gravity``: point-mass Earth on every mass (exact, relative to the free-falling
    frame origin on the reference orbit)."""

    name = "central_gravity"
    needs_orbit = True

    def loads(self, b, scene):
        for el in b.elements:
            if el.has_mass:
                b.add_force_at(el.r, el.mass * _orbit_gravity(b, el.r))


class GravityGradient(Effect):
    """``gravity_gradient``: first-order gradient torque ``3 mu / R^5 R x (I R)`` on every element
    with inertia (instantaneous inertia, body axes), and, without ``central_gravity``, the
    first-order tidal force ``m mu / r0^3 (3 (e.r) e - r)`` on every mass (Hill's equations)."""

    name = "gravity_gradient"
    needs_orbit = True

    def loads(self, b, scene):
        tidal = "central_gravity" not in scene.effects
        r0 = ca.norm_2(b.R_O)
        e = b.R_O / r0
        for el in b.elements:
            if el.has_inertia:
                R_B = el.C.T @ (b.R_O + el.r)
                I = el.I
                b.add_element_torque(el, 3 * b.mu / ca.norm_2(R_B) ** 5 * cross(R_B, I @ R_B))
            if tidal and el.has_mass:
                F = el.mass * b.mu / r0**3 * (3 * ca.dot(e, el.r) * e - el.r)
                b.add_force_at(el.r, F)


# -- surfaces ----------------------------------------------------------------------------------


class SolarPressure(Effect):
    """``solar_pressure``: flat plates, ``F = -P A max(c, 0) [(1 - rho) s + 2 rho c n]`` with
    ``c = n . s``, ``s`` the Sun direction (fixed in inertial axes), ``P`` the pressure, ``rho``
    the specular reflectivity (Wertz, Spacecraft Attitude Determination and Control, 17.2)."""

    name = "solar_pressure"

    def loads(self, b, scene):
        env = scene.environment
        s_F = b.C_NF.T @ ca.DM(_unit(env.sun_direction))
        for surf in scene.surfaces:
            frame = b.frames[surf.body]
            n_F = frame.C @ ca.DM(_unit(surf.normal))
            c = ca.dot(n_F, s_F)
            lit = ca.fmax(c, 0)
            rho = float(surf.reflectivity)
            F = -float(env.solar_pressure) * float(surf.area) * lit * ((1 - rho) * s_F + 2 * rho * c * n_F)
            b.add_force(surf.body, vector3(surf.point), F)


class AerodynamicDrag(Effect):
    """``aerodynamic_drag``: flat plates in an exponential atmosphere,
    ``F = -1/2 rho Cd A |v| max(n . v/|v|, 0) v`` with ``v`` the inertial velocity of the plate's
    centre (orbital plus local; the atmosphere does not rotate)."""

    name = "aerodynamic_drag"
    needs_orbit = True

    def loads(self, b, scene):
        env = scene.environment
        for surf in scene.surfaces:
            frame = b.frames[surf.body]
            r, rdot, _, _ = b.point_kinematics(surf.body, vector3(surf.point))
            v = b.inertial_velocity(r, rdot)
            speed = ca.norm_2(v)
            altitude = ca.norm_2(b.R_O + r) - R_EARTH
            rho = float(env.density) * ca.exp(-(altitude - float(env.reference_altitude)) / float(env.scale_height))
            n_F = frame.C @ ca.DM(_unit(surf.normal))
            proj = ca.fmax(ca.dot(n_F, v) / speed, 0)
            F = -0.5 * rho * float(surf.drag_coefficient) * float(surf.area) * speed * proj * v
            b.add_force(surf.body, vector3(surf.point), F)


# -- internal degrees of freedom -----------------------------------------------------------------


class WheelGyroscopics(Effect):
    """``wheel_gyroscopics``: rotors spinning relative to their body (to the node axes for a wheel
    at a node of a flexible body); constant-speed wheels add their angular momentum, torque-mode
    wheels a speed state ``<wheel>.speed`` (relative rate [rad/s]). Without it a wheel is a
    locked rigid part of its body (of its node)."""

    name = "wheel_gyroscopics"
    order = 10

    def structure(self, b, scene):
        for w in scene.wheels:
            a = _unit(w.axis)
            if w.mode == "torque":
                _, speed = b.add_coordinates([], [f"{w.name}.speed"])
                omega = speed[0]
            else:
                omega = ca.SX(float(w.speed))
            b.wheel_speeds[w.name] = omega
            if w.node is not None:
                # At a node of a flexible body: the rotor spins relative to the node axes, which
                # turn with the structure (the gyroscopic torque then couples into the modes).
                element = b.node_wheels[w.name]
                element.w_axes = element.w
                element.w = element.w + ca.DM(a) * omega
                continue
            b.detach(w.body, ("wheel_rotor", w.name))
            frame = b.frames[w.body]
            b.add_element(MassElement(f"{w.name}.rotor", 0.0, wheel_inertia(w), frame.r, frame.C,
                                      frame.w + ca.DM(a) * omega, body=w.body, w_axes=frame.w))


def _perpendicular(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


class Slosh(Effect):
    """``slosh``: spherical pendulums (fuel slosh); coordinates ``<p>.theta1``, ``<p>.theta2``
    (rotations of the rod about two axes normal to its rest direction) with their rates, viscous
    hinge damping on the rates. Without it the bob is fixed at its rest position."""

    name = "slosh"
    order = 20

    def structure(self, b, scene):
        for p in scene.pendulums:
            b.detach(p.body, ("pendulum", p.name))
            q, u = b.add_coordinates([f"{p.name}.theta1", f"{p.name}.theta2"],
                                     [f"{p.name}.rate1", f"{p.name}.rate2"])
            b.set_kinematics(q, u)
            d = _unit(p.direction)
            e1, e2 = _perpendicular(d)
            rod = rot_axis(e1, q[0]) @ rot_axis(e2, q[1]) @ ca.DM(d * float(p.length))
            frame = b.frames[p.body]
            r = frame.r + frame.C @ (ca.DM(vector3(p.point)) + rod)
            b.add_element(MassElement(p.name, float(p.mass), None, r, frame.C, frame.w, body=p.body))
            b.pendulum_speeds[p.name] = u

    def loads(self, b, scene):
        for p in scene.pendulums:
            if p.damping:
                for k in range(2):
                    b.add_generalized_force(b.speed_index(f"{p.name}.rate{k + 1}"),
                                            -float(p.damping) * b.pendulum_speeds[p.name][k])


class Dampers(Effect):
    """``dampers``: the scene's ``springs``, point masses sliding along a body axis on a
    spring-damper (nutation dampers), coordinate
    ``<d>.position`` [m] and rate ``<d>.speed``; force ``-k s - c s'``."""

    name = "dampers"
    order = 20

    def structure(self, b, scene):
        for d in scene.springs:
            b.detach(d.body, ("spring", d.name))
            q, u = b.add_coordinates([f"{d.name}.position"], [f"{d.name}.speed"])
            b.set_kinematics(q, u)
            frame = b.frames[d.body]
            r = frame.r + frame.C @ (ca.DM(vector3(d.point)) + ca.DM(_unit(d.axis)) * q[0])
            b.add_element(MassElement(d.name, float(d.mass), None, r, frame.C, frame.w, body=d.body))
            b.damper_coordinates[d.name] = (q[0], u[0])

    def loads(self, b, scene):
        for d in scene.springs:
            s, v = b.damper_coordinates[d.name]
            b.add_generalized_force(b.speed_index(f"{d.name}.speed"), -float(d.stiffness) * s - float(d.damping) * v)
            b.add_potential(0.5 * float(d.stiffness) * s**2)


class JointSprings(Effect):
    """``joint_springs``: ``-k (q - rest) - c q'`` on free revolute and prismatic coordinates."""

    name = "joint_springs"

    def check(self, scene):
        return [f"joints[{i}].stiffness: joint springs act on revolute and prismatic joints only (this one is {j.type!r})"
                for i, j in enumerate(scene.joints)
                if j.type not in ("revolute", "prismatic") and (j.stiffness or j.damping)]

    def loads(self, b, scene):
        for j in scene.joints:
            if j.type not in ("revolute", "prismatic") or not (j.stiffness or j.damping):
                continue
            q, u = b.joint_speeds.get(j.name, (None, None))
            if u is None:
                continue
            index = b.u_names.index(b.joint_speed_names[j.name])
            k, c = b.param(f"{j.name}.stiffness", j.stiffness), b.param(f"{j.name}.damping", j.damping)
            b.add_generalized_force(index, -k * (q - float(j.rest)) - c * u)
            b.add_potential(0.5 * k * (q - float(j.rest)) ** 2)


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
                b.add_force(a.body, vector3(a.point), C @ ca.DM(_unit(a.axis)) * b.commands[a.name])


class Control(Effect):
    """``control``: the controllers' dynamics, from sensor signals to actuator commands; states
    ``<controller>.x<k>``. Without it the actuator commands are the model's inputs only."""

    name = "control"

    def signals(self, b, scene):
        # One implementation of the controller laws: controller_system gives
        # u = C xc + D [y - reference; r], xc' = A xc + B [y - reference; r].
        for c in scene.controllers:
            K = controller_system(c)
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


class GeometricStiffness(Effect):
    """``geometric_stiffness``: the motion-induced stiffness of flexible bodies, from the projected
    geometric stiffness of the unit inertia loads combined with the current accelerations and
    rates (Banerjee Eqs. 5.13-5.25 as corrected in the reference notes). Without it, modal
    models are linearized prematurely: spin softens a beam instead of stiffening it."""

    name = "geometric_stiffness"

    def structure(self, b, scene):
        for fe in b.flexible:
            if fe.data.geometric_stiffness is None:
                raise ModelError(f"geometric_stiffness: flexible body {fe.name!r} has no geometric-stiffness "
                                 "matrices in its modal data (beam_modal_data computes them)")
            fe.geometric = True


for _effect in (UniformGravity(), CentralGravity(), GravityGradient(), SolarPressure(), AerodynamicDrag(),
                WheelGyroscopics(), Slosh(), Dampers(), JointSprings(), Thrusters(), Control(),
                GeometricStiffness()):
    register_effect(_effect)
