"""Scene entries, part four: the frame attitude is measured in, the orbit, the environment, the limits."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ._entries import FRAME_KINDS, _Entry
from ._problems import LIMITS, Problems, SceneContext
from ._values import MU_EARTH, R_EARTH


@dataclass(frozen=True)
class Frame(_Entry):
    """The frame attitude is measured in: ``inertial``, ``lvlh`` (x along the orbital velocity, y
    opposite the orbit normal, z to the Earth's centre) or ``spin`` (``rate`` [rad/s] about
    ``axis``).

    Parameters
    ----------
    kind : str
        ``"inertial"``, ``"lvlh"`` (the orbit frame) or ``"spin"``.
    rate : float
        For ``spin``: the frame's rate [rad/s].
    axis : array_like of 3 floats
        For ``spin``: the spin axis [-] (normalized).

    Examples
    --------
    >>> from linflex import Frame
    >>> Frame("spin", rate=0.5, axis=(0, 0, 1)).rate
    0.5
    """

    kind: str = "inertial"
    rate: float = 0.0
    axis: Any = (0.0, 0.0, 1.0)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.kind, f"{path}.kind", FRAME_KINDS, "frame kind")
        if self.kind == "spin":
            out.number(self.rate, f"{path}.rate", "rad/s", kind="rate")
            out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        else:
            for key in ("rate", "axis"):
                out.inapplicable(self, key, path, self.kind not in FRAME_KINDS,
                                 f"only a spin frame has a rate and an axis (this one is {self.kind!r})")


@dataclass(frozen=True)
class Orbit(_Entry):
    """A circular reference orbit of ``radius`` [m] (or ``altitude`` [m] above ``R_EARTH``) with
    gravitational parameter ``mu`` [m^3/s^2].

    Parameters
    ----------
    kind : str
        The orbit's kind: ``"circular"`` (the only one).
    radius : float, optional
        Orbit radius [m].
    altitude : float, optional
        Altitude above ``R_EARTH`` [m], instead of ``radius``.
    mu : float
        Gravitational parameter [m^3/s^2].

    Examples
    --------
    >>> from linflex import Orbit
    >>> round(Orbit(altitude=500e3).r0)   # [m]
    6878137
    """

    kind: str = "circular"
    radius: float | None = None
    altitude: float | None = None
    mu: float = MU_EARTH

    @property
    def r0(self) -> float:
        """Orbit radius [m]."""
        return float(self.radius) if self.radius is not None else R_EARTH + float(self.altitude)

    @property
    def mean_motion(self) -> float:
        """Orbital rate ``n = sqrt(mu / r^3)`` [rad/s]."""
        return math.sqrt(self.mu / self.r0**3)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.kind, f"{path}.kind", ("circular",), "orbit kind")
        ok_mu = out.number(self.mu, f"{path}.mu", "m^3/s^2", positive=True)
        if (self.radius is None) == (self.altitude is None):
            out.add(path, "give exactly one of radius [m] or altitude [m]")
            return
        if self.radius is not None:
            ok = out.number(self.radius, f"{path}.radius", "m", positive=True, kind="length")
        else:
            ok = out.number(self.altitude, f"{path}.altitude", "m", nonnegative=True, kind="length")
        high = out.limits["rate"][1]
        if ok and ok_mu and not self.mean_motion <= high:
            # The orbital rate follows from both: a tiny radius is a rate no scene can have.
            key = "radius" if self.radius is not None else "altitude"
            out.add(f"{path}.{key}", f"{getattr(self, key)!r} [m] gives the orbital rate sqrt(mu / r^3) = "
                                     f"{self.mean_motion:.3g} rad/s (mu = {self.mu!r} m^3/s^2), above the physically "
                                     f"meaningful {high:g} rad/s (change it with [limits] rate = [lo, hi])")


@dataclass(frozen=True)
class Environment(_Entry):
    """Uniform ``gravity`` [m/s^2] (inertial axes), ``sun_direction`` (unit vector toward the
    Sun, inertial axes), ``solar_pressure`` [N/m^2], and an exponential atmosphere
    ``density`` [kg/m^3] at ``reference_altitude`` [m] with ``scale_height`` [m].

    Parameters
    ----------
    gravity : array_like of 3 floats
        Uniform gravity in inertial axes [m/s^2].
    sun_direction : array_like of 3 floats
        Unit vector toward the Sun in inertial axes [-].
    solar_pressure : float
        Solar radiation pressure [N/m^2].
    density : float
        Atmospheric density at ``reference_altitude`` [kg/m^3].
    reference_altitude : float
        Altitude of the reference density [m].
    scale_height : float
        Scale height of the exponential atmosphere [m].

    Examples
    --------
    >>> from linflex import Environment
    >>> Environment(density=1e-11).scale_height   # [m]
    60000.0
    """

    gravity: Any = (0.0, 0.0, -9.81)
    sun_direction: Any = (1.0, 0.0, 0.0)
    solar_pressure: float = 4.56e-6
    density: float = 3.0e-12
    reference_altitude: float = 500e3
    scale_height: float = 60e3

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.vector(self.gravity, f"{path}.gravity", "m/s^2")
        out.vector(self.sun_direction, f"{path}.sun_direction", "-", nonzero=True)
        out.number(self.solar_pressure, f"{path}.solar_pressure", "N/m^2", nonnegative=True)
        out.number(self.density, f"{path}.density", "kg/m^3", nonnegative=True)
        out.number(self.reference_altitude, f"{path}.reference_altitude", "m", kind="length")
        out.number(self.scale_height, f"{path}.scale_height", "m", positive=True, kind="length")


@dataclass(frozen=True)
class Limits(_Entry):
    """The physically meaningful ranges of scene numbers (a ``[limits]`` table), each ``(low, high)``.

    A nonzero magnitude outside its range is refused with the entry's path before anything is
    compiled (a mass of 1e300 kg, an inertia of 1e-300 kg m^2, an orbit of 1 mm radius).
    Defaults are :data:`linflex.scene._problems.LIMITS`.

    Parameters
    ----------
    mass : (float, float)
        Masses [kg]; default (1e-9, 1e12).
    inertia : (float, float)
        Moments of inertia [kg m^2] (a body's largest principal moment, wheel inertias);
        default (1e-21, 1e28).
    length : (float, float)
        Lengths [m] (pendulum and beam lengths, orbit radii; points and offsets only their upper
        bound); default (1e-6, 1e10).
    rate : (float, float)
        Angular rates [rad/s] (wheel speeds, frame and joint rates, the orbital rate; only the
        upper bound); default (0, 1e5).

    Examples
    --------
    A scene of micro-satellites allowed to go down to a milligram:

    >>> from linflex import Limits
    >>> Limits(mass=(1e-6, 1e3)).as_dict()["mass"]
    (1e-06, 1000.0)
    """

    mass: Any = LIMITS["mass"]
    inertia: Any = LIMITS["inertia"]
    length: Any = LIMITS["length"]
    rate: Any = LIMITS["rate"]

    def as_dict(self) -> dict[str, tuple[float, float]]:
        """The ranges by kind, as ``LIMITS`` (linflex/scene/_problems.py) has them (valid limits only; others keep the default).

        Returns
        -------
        dict of str to (float, float)
            ``{"mass": (low, high) [kg], "inertia": [kg m^2], "length": [m], "rate": [rad/s]}``.
        """
        out = dict(LIMITS)
        for key in LIMITS:
            value = getattr(self, key)
            if _valid_range(value):
                out[key] = (float(value[0]), float(value[1]))
        return out

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        for key in LIMITS:
            value = getattr(self, key)
            if not _valid_range(value):
                out.add(f"{path}.{key}", f"expected [low, high] with 0 <= low < high (finite), got {value!r}")


def _valid_range(value: Any) -> bool:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        return False
    return 0 <= lo < hi < math.inf and not any(isinstance(v, bool) for v in value)
