"""Stability requirements of a scene's loops (a ``[requirements]`` table), checked by the report.

Each requirement is a bound in the unit its name says, as reviewers write them: margins are
lower bounds, sensitivity peaks upper bounds. Global values apply to every loop; a loop's own
values (``[requirements.loops.<actuator>]``) replace them for that loop.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from ._entries import _Entry
from ._problems import Problems, SceneContext, hint

__all__ = ["REQUIREMENTS", "Requirements"]

#: The requirement names: unit, whether the value is a lower (``">="``) or upper (``"<="``) bound,
#: and what it bounds.
REQUIREMENTS: Mapping[str, tuple[str, str, str]] = MappingProxyType({
    "gain_margin_db": ("dB", ">=", "gain margin |20 log10 GM| at every phase crossover"),
    "phase_margin_deg": ("deg", ">=", "phase margin |PM| at every gain crossover"),
    "delay_margin_s": ("s", ">=", "delay margin at every gain crossover"),
    "disk_margin": ("-", ">=", "balanced disk margin alpha (loop-at-a-time and multi-loop)"),
    "sensitivity_peak_db": ("dB", "<=", "sensitivity peak Ms = max |S(j omega)| (input side)"),
    "complementary_sensitivity_peak_db": ("dB", "<=",
                                          "complementary sensitivity peak Mt = max |T(j omega)| (input side)"),
})


@dataclass(frozen=True)
class Requirements(_Entry):
    """Requirements on the loops' margins and sensitivity peaks (a ``[requirements]`` table).

    Every value is optional (None: not required). ``loops`` maps an actuator name (the channel
    where its loop is broken) to a table of the same keys, which replace the global ones for that
    loop.

    Parameters
    ----------
    gain_margin_db : float, optional
        Least gain margin [dB], both directions (``|20 log10 GM|``).
    phase_margin_deg : float, optional
        Least phase margin [deg], as ``|PM|`` (a phase-stabilized crossing has a negative PM).
    delay_margin_s : float, optional
        Least delay margin [s].
    disk_margin : float, optional
        Least balanced disk margin ``alpha`` [-].
    sensitivity_peak_db : float, optional
        Largest sensitivity peak Ms [dB].
    complementary_sensitivity_peak_db : float, optional
        Largest complementary sensitivity peak Mt [dB].
    loops : mapping of str to mapping, optional
        Per-loop requirements by actuator name, with the keys above.

    Examples
    --------
    >>> from linflex.scene import Requirements
    >>> r = Requirements(phase_margin_deg=30.0, loops={"motor_x": {"phase_margin_deg": 40.0}})
    >>> r.for_loop("motor_x"), r.for_loop("motor_y")
    ({'phase_margin_deg': 40.0}, {'phase_margin_deg': 30.0})
    """

    gain_margin_db: Any = None
    phase_margin_deg: Any = None
    delay_margin_s: Any = None
    disk_margin: Any = None
    sensitivity_peak_db: Any = None
    complementary_sensitivity_peak_db: Any = None
    loops: Any = None

    def global_values(self) -> dict[str, float]:
        """The global requirements that are set, by name.

        Returns
        -------
        dict of str to float
            Values in the units the names say (dB, deg, s, -); unset ones left out.
        """
        return {key: float(getattr(self, key)) for key in REQUIREMENTS if getattr(self, key) is not None}

    def for_loop(self, channel: str) -> dict[str, float]:
        """The requirements of the loop broken at ``channel``: its own values over the global ones.

        Parameters
        ----------
        channel : str
            The actuator where the loop is broken.

        Returns
        -------
        dict of str to float
            Values in the units the names say (dB, deg, s, -); unset ones left out.
        """
        out = self.global_values()
        own = (self.loops or {}).get(channel, {}) if isinstance(self.loops, Mapping) else {}
        out.update({key: float(value) for key, value in own.items() if key in REQUIREMENTS and value is not None})
        return out

    def is_empty(self) -> bool:
        """Whether nothing is required.

        Returns
        -------
        bool
            True when no global and no per-loop value is set.
        """
        return not self.global_values() and not any(
            value is not None for own in (self.loops or {}).values() if isinstance(own, Mapping)
            for value in own.values())

    def updated(self, other: Requirements) -> Requirements:
        """These requirements with those set in ``other`` replacing them (a command line over a scene).

        Parameters
        ----------
        other : Requirements
            The values that win (global and per loop); unset ones keep these.

        Returns
        -------
        Requirements
            The merged requirements (not validated).
        """
        changes: dict[str, Any] = other.global_values()
        loops = {k: dict(v) for k, v in (self.loops or {}).items()} if isinstance(self.loops, Mapping) else {}
        for channel, own in (other.loops or {}).items():
            loops.setdefault(channel, {}).update(own)
        return Requirements(**{**{k: getattr(self, k) for k in REQUIREMENTS}, **changes}, loops=loops or None)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        for key, (unit, _, _) in REQUIREMENTS.items():
            out.number(getattr(self, key), f"{path}.{key}", unit, positive=REQUIREMENTS[key][1] == ">=",
                       optional=True)
        if self.loops is None:
            return
        if not isinstance(self.loops, Mapping):
            out.add(f"{path}.loops", f"expected a table of loops by actuator name, got {self.loops!r}")
            return
        for channel, own in self.loops.items():
            where = f"{path}.loops.{channel}"
            if context.actuators and channel not in context.actuators:
                out.add(where, f"unknown actuator {channel!r} (a loop is named by the actuator where it is "
                               f"broken){hint(channel, list(context.actuators))}")
            if not isinstance(own, Mapping):
                out.add(where, f"expected a table of requirements, got {own!r}")
                continue
            for key, value in own.items():
                if key not in REQUIREMENTS:
                    out.add(f"{where}.{key}", f"unknown requirement{hint(key, list(REQUIREMENTS))}")
                else:
                    out.number(value, f"{where}.{key}", REQUIREMENTS[key][0],
                               positive=REQUIREMENTS[key][1] == ">=")
