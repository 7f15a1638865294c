"""Scene entries whose mass or load changes along a time profile: deploying booms, propellant
tanks feeding thrusters, and thermal loads on flexible bodies.

Each needs its effect (``deployment``, ``mass_flow``, ``thermal``) in the scene's ``effects``:
validation refuses the entry otherwise, so that a scene never silently drops a mass or a load.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._entries import _Entry
from ._joints import profile_table_problems
from ._problems import Problems, SceneContext

__all__ = ["Boom", "Tank", "ThermalLoad", "profile_bounds"]


def profile_bounds(profile: Any) -> tuple[float, float] | None:
    """The smallest and largest value a time profile (a number or a profile table) takes, or
    None when unbounded or not known in closed form (``ramp``, ``sine``, ``spinup``)."""
    if isinstance(profile, (int, float)) and not isinstance(profile, bool):
        return float(profile), float(profile)
    if not isinstance(profile, dict):
        return None
    kind = profile.get("profile")
    try:
        if kind == "constant":
            return (float(profile.get("value", 0.0)),) * 2
        if kind in ("step", "transition"):
            a, b = float(profile["before"]), float(profile["after"])
            return min(a, b), max(a, b)
        if kind == "table":
            # The cubic spline may overshoot its points; the samples bound it only approximately,
            # so the table is sampled densely (the bound is what the validation can promise).
            import casadi as ca

            times = np.asarray(profile["times"], dtype=float)
            values = np.asarray(profile["values"], dtype=float)
            spline = ca.interpolant("bounds", "bspline", [times], values)
            grid = np.linspace(times[0], times[-1], 64 * times.size)
            sampled = np.asarray(spline(grid), dtype=float).ravel()
            return float(min(sampled.min(), values.min())), float(max(sampled.max(), values.max()))
    except (KeyError, TypeError, ValueError, RuntimeError):
        return None
    return None


def _profile_problems(out: Problems, path: str, value: Any, unit: str) -> None:
    """A number or a profile table."""
    if isinstance(value, dict):
        profile_table_problems(out, path, value)
    elif not callable(value):
        out.number(value, path, unit)


def _needs(out: Problems, path: str, context: SceneContext, effect: str, what: str) -> None:
    if context.lacks(effect):
        out.add(path, f"{what} needs the {effect!r} effect (add it to effects)")


@dataclass(frozen=True)
class Boom(_Entry):
    """A boom deploying from (or retracting into) ``body`` along a time profile of its length.

    The boom's material is stowed at ``point`` of ``body`` (a point mass there,
    ``mass_per_length (total_length - length(t))``) and streams out along ``direction``: the
    deployed part, of length ``length(t)``, is a thin beam clamped at ``point`` whose material
    moves outward at the deployment rate. With ``EI`` and ``modes``, the deployed part bends in
    the two directions normal to ``direction`` with ``modes`` assumed shapes ``(s/l)^(k+2)``
    each (the shapes stretch with the length, Banerjee's variable-length idea), axial
    foreshortening included so that spin stiffens it. Needs the ``deployment`` effect; the
    boom's material feels no gravity effect yet (validation refuses the combination).

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; the bending coordinates are ``<name>.eta<k>``.
    body : str
        The rigid body the boom deploys from.
    mass_per_length : float
        Mass per unit length of the boom [kg/m].
    length : float or mapping
        The deployed length [m]: a number, or a time profile (``profile`` and its keys as in a
        joint's ``prescribed``; a deployment to 10 m in 60 s is ``{profile = "transition",
        start = 0, duration = 60, before = 0, after = 10}``).
    total_length : float, optional
        The boom's full length [m] (stowed plus deployed); default the largest ``length`` of
        a bounded profile (``constant``, ``step``, ``table``, ``transition``).
    point : array_like of 3 floats
        The root (where the boom leaves the body, and where its stowed material sits), body
        axes [m].
    direction : array_like of 3 floats
        The direction the boom deploys along, body axes [-] (normalized).
    EI : float, optional
        Bending stiffness [N m^2] of a boom that bends (in ``modes`` shapes); without it (the
        default) the boom is rigid.
    modes : int
        Assumed bending shapes per transverse direction (0: a rigid boom; default 3 with ``EI``).
    damping : float
        Stiffness-proportional damping coefficient [s] of the bending (force ``-damping K eta'``).

    Examples
    --------
    A 10 m boom of 0.5 kg/m deploying from the hub in 100 s:

    >>> from linflex import Boom
    >>> boom = Boom("boom", "hub", mass_per_length=0.5, point=(0.5, 0.0, 0.0),
    ...             length={"profile": "transition", "start": 0.0, "duration": 100.0,
    ...                     "before": 0.0, "after": 10.0})
    >>> boom.deployed_range()
    (0.0, 10.0)
    """

    name: str
    body: str
    mass_per_length: float
    length: Any
    total_length: Any = None
    point: Any = (0.0, 0.0, 0.0)
    direction: Any = (1.0, 0.0, 0.0)
    EI: Any = None
    modes: Any = None
    damping: float = 0.0

    def deployed_range(self) -> tuple[float, float] | None:
        """The smallest and largest deployed length of the profile [m], None when not bounded.

        Returns
        -------
        tuple of float or None
            ``(smallest, largest)`` deployed length [m].
        """
        return profile_bounds(self.length)

    def full_length(self) -> float:
        """The boom's full length [m]: ``total_length``, else the profile's largest length.

        Returns
        -------
        float
            Stowed plus deployed length [m].
        """
        if self.total_length is not None:
            return float(self.total_length)
        bounds = self.deployed_range()
        if bounds is None:
            raise ValueError(f"boom {self.name!r}: give total_length for an unbounded length profile")
        return bounds[1]

    def n_modes(self) -> int:
        """Assumed bending shapes per transverse direction (0 for a rigid boom).

        Returns
        -------
        int
            ``modes``, else 3 with ``EI`` and 0 without.
        """
        if self.EI is None:
            return 0
        return 3 if self.modes is None else int(self.modes)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        if out.name_ref(self.body, f"{path}.body", context.body_names, "body"):
            if context.bodies[self.body].type != "rigid":
                out.add(f"{path}.body", f"a boom deploys from a rigid body ({self.body!r} is "
                                        f"{context.bodies[self.body].type!r})")
        out.number(self.mass_per_length, f"{path}.mass_per_length", "kg/m", positive=True)
        _profile_problems(out, f"{path}.length", self.length, "m")
        out.number(self.total_length, f"{path}.total_length", "m", positive=True, optional=True, kind="length")
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.vector(self.direction, f"{path}.direction", "-", nonzero=True)
        out.number(self.EI, f"{path}.EI", "N m^2", positive=True, optional=True)
        out.number(self.damping, f"{path}.damping", "s", nonnegative=True)
        if self.modes is not None and out.integer(self.modes, f"{path}.modes", low=0, high=8):
            out.inapplicable(self, "modes", path, self.EI is not None or not self.modes,
                             "a rigid boom (no EI) has no bending shapes")
        if not any(p.startswith((f"{path}.length", f"{path}.total_length")) for p in out):
            bounds = self.deployed_range()
            if bounds is None and self.total_length is None:
                out.add(f"{path}.total_length", "needed: the length profile has no bounded range "
                                                "(give the boom's full length)")
            elif bounds is not None:
                full = self.total_length if self.total_length is not None else bounds[1]
                if isinstance(full, (int, float)) and (bounds[0] < 0 or bounds[1] > full * (1 + 1e-12)):
                    out.add(f"{path}.length", f"the deployed length ranges over [{bounds[0]:g}, {bounds[1]:g}] m, "
                                              f"outside [0, total_length = {full:g}] m")
        _needs(out, path, context, "deployment", "a boom")


@dataclass(frozen=True)
class Tank(_Entry):
    """A propellant tank at ``point`` of ``body`` that feeds the body's thrusters.

    The propellant is a point mass whose mass, the output ``<name>.propellant`` [kg] (the state
    ``<name>.propellant_used`` is the mass spent), falls at the rate ``|F| / exhaust_velocity`` of each fed thruster's thrust ``F``; the mass leaves at
    the thruster's point with the thruster's velocity minus ``exhaust_velocity`` along its axis,
    so that the vehicle and its exhaust together keep their momentum (the force of moving the
    propellant from the tank to the thruster, jet damping included, acts on the vehicle).
    Needs the ``mass_flow`` effect (and ``thrusters`` for the thrust).

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; its state is ``<name>.propellant_used``.
    body : str
        The body the tank is fixed in.
    mass : float
        Initial propellant mass [kg].
    exhaust_velocity : float
        Effective exhaust velocity of the thrusters it feeds [m/s] (specific impulse times g0).
    point : array_like of 3 floats
        The tank's (the propellant's) mass centre, body axes [m].
    thrusters : sequence of str, optional
        The thruster actuators it feeds (default: every thruster on ``body``).

    Examples
    --------
    >>> from linflex import Tank
    >>> Tank("tank", "sat", mass=40.0, exhaust_velocity=2200.0).exhaust_velocity
    2200.0
    """

    name: str
    body: str
    mass: float
    exhaust_velocity: float
    point: Any = (0.0, 0.0, 0.0)
    thrusters: Any = None

    def fed_thrusters(self, scene: Any) -> list[Any]:
        """The thruster actuators this tank feeds.

        Parameters
        ----------
        scene : Scene
            The tank's scene.

        Returns
        -------
        list of Actuator
            The thrusters named in ``thrusters``, else every thruster on ``body``.
        """
        names = None if self.thrusters is None else ([self.thrusters] if isinstance(self.thrusters, str)
                                                     else list(self.thrusters))
        return [a for a in scene.actuators if a.type == "thruster"
                and (a.name in names if names is not None else a.body == self.body)]

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.mass, f"{path}.mass", "kg", positive=True, kind="mass")
        out.number(self.exhaust_velocity, f"{path}.exhaust_velocity", "m/s", positive=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        if self.thrusters is not None:
            names = [self.thrusters] if isinstance(self.thrusters, str) else self.thrusters
            thrusters = [a for a, v in context.actuators.items() if v.type == "thruster"]
            for k, name in enumerate(names if isinstance(names, (tuple, list)) else [names]):
                if out.name_ref(name, f"{path}.thrusters[{k}]", thrusters, "thruster") and \
                        context.actuators[name].body != self.body:
                    out.add(f"{path}.thrusters[{k}]", f"thruster {name!r} is on body "
                                                      f"{context.actuators[name].body!r}, not on {self.body!r}")
        _needs(out, path, context, "mass_flow", "a propellant tank")


@dataclass(frozen=True)
class ThermalLoad(_Entry):
    """A thermal load on a flexible body: a bending moment or modal loads along a time profile.

    A temperature difference across a beam bends it as a uniform moment ``moment`` would (the
    thermal curvature ``alpha dT / h`` times ``EI``); on a modal model that is the pair of
    moments ``+moment`` at ``node`` and ``-moment`` at ``opposite_node`` (its generalized forces
    ``(Psi_to - Psi_from)^T moment``), which leaves the rigid motion alone. Alternatively
    ``modal_load`` gives the generalized force of each kept mode directly. Either is scaled by
    the profile ``scale`` (a number or a time profile: a ``step`` or a ``transition`` at a
    terminator crossing for thermal snap, a slow ``sine`` or ``table`` for slow thermal bending).
    Needs the ``thermal`` effect.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene.
    body : str
        The flexible body it loads.
    moment : array_like of 3 floats, optional
        The thermal bending moment, body axes [N m] (with ``node``).
    node : str, optional
        The node where ``+moment`` acts (the beam's far end; for a ``beam`` body ``"0.end"``).
    opposite_node : str, optional
        The node where ``-moment`` acts; default none (the clamped body origin, which does
        not move with the modes).
    modal_load : sequence of floats, optional
        Instead of ``moment``: the generalized force on each kept mode [N m or N, as the
        modes' normalization].
    scale : float or mapping
        The time profile the load is multiplied by [-] (a number, or ``profile`` and its keys
        as in a joint's ``prescribed``).

    Examples
    --------
    Thermal snap at a terminator crossing: 0.2 N m reached in 5 s from t = 100 s.

    >>> from linflex import ThermalLoad
    >>> snap = ThermalLoad("snap", "array", moment=(0.0, 0.2, 0.0), node="0.end",
    ...                    scale={"profile": "transition", "start": 100.0, "duration": 5.0,
    ...                           "before": 0.0, "after": 1.0})
    >>> snap.node
    '0.end'
    """

    name: str
    body: str
    moment: Any = None
    node: Any = None
    modal_load: Any = None
    scale: Any = 1.0
    opposite_node: Any = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        flexible = out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        if flexible and context.bodies[self.body].type != "flexible":
            out.add(f"{path}.body", f"thermal loads act on flexible bodies ({self.body!r} is rigid)")
            flexible = False
        if (self.moment is None) == (self.modal_load is None):
            out.add(path, "give either moment (with to) or modal_load")
        elif self.moment is not None:
            out.vector(self.moment, f"{path}.moment", "N m")
            if self.node is None:
                out.add(f"{path}.node", "a thermal moment needs the node it acts at")
            elif flexible:
                context.check_node(out, f"{path}.node", self.body, self.node)
            if self.opposite_node is not None and flexible:
                context.check_node(out, f"{path}.opposite_node", self.body, self.opposite_node)
        else:
            for key in ("node", "opposite_node"):
                if getattr(self, key) is not None:
                    out.add(f"{path}.{key}", "does not apply to a modal_load (remove it)")
            if flexible:
                try:
                    n = context.modal_data(self.body).n_modes
                    modes = context.bodies[self.body].modes
                    n = n if modes is None else min(n, int(modes))
                except Exception:  # noqa: BLE001 - the body's own problems report it
                    n = None
                if n is not None:
                    out.array(self.modal_load, f"{path}.modal_load", (n,), "N m or N", f"{n} values (one per mode)")
        _profile_problems(out, f"{path}.scale", self.scale, "-")
        _needs(out, path, context, "thermal", "a thermal load")
