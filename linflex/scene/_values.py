"""Values every scene user reads: Earth's constants, vectors, inertias and time profiles of scene entries.

The ground floor of the scene room: it imports nothing from linflex, so effects, dynamics and the
scene's own validation can share these without a circle.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: Earth's gravitational parameter [m^3/s^2] (WGS-84) and equatorial radius [m].
MU_EARTH = 3.986004418e14
R_EARTH = 6378137.0


def vector3(value: Any) -> np.ndarray:
    """A validated scene 3-vector as a float array (used after validation)."""
    return np.asarray(value, dtype=float).reshape(3)


def unit_vector(value: Any) -> np.ndarray:
    """A validated scene direction normalized to unit length (used after validation)."""
    v = vector3(value)
    return v / np.linalg.norm(v)


def inertia_matrix(value: Any) -> np.ndarray:
    """Three principal values or a 3x3 matrix as a 3x3 float array (used after validation)."""
    arr = np.asarray(value, dtype=float)
    return np.diag(arr) if arr.shape == (3,) else arr.reshape(3, 3)


def wheel_inertia(wheel: Any) -> np.ndarray:
    """A wheel's central inertia in its body's axes (the node axes for a wheel at a node) [kg m^2]."""
    a = vector3(wheel.axis) / np.linalg.norm(vector3(wheel.axis))
    return float(wheel.transverse_inertia) * (np.eye(3) - np.outer(a, a)) + float(wheel.spin_inertia) * np.outer(a, a)


def profile_function(prescribed: Any) -> Callable[[Any], Any]:
    """A function of time (CasADi-compatible) for a ``prescribed`` entry (validated)."""
    if callable(prescribed):
        return prescribed
    kind = prescribed.get("profile")
    if kind == "constant":
        value = float(prescribed.get("value", 0.0))
        return lambda t: value + 0 * t
    if kind == "ramp":
        off, rate = float(prescribed.get("offset", 0.0)), float(prescribed.get("rate", 0.0))
        return lambda t: off + rate * t
    import casadi as ca

    if kind == "spinup":
        return _spinup_angle(float(prescribed.get("offset", 0.0)), float(prescribed["rate"]),
                             float(prescribed["ramp_time"]))
    if kind == "step":
        time, before, after = (float(prescribed[k]) for k in ("time", "before", "after"))
        return lambda t: ca.if_else(t >= time, after, before)
    if kind == "table":
        times = np.asarray(prescribed["times"], dtype=float)
        values = np.asarray(prescribed["values"], dtype=float)
        spline = ca.interpolant("table", "bspline", [times], values)
        return lambda t: ca.if_else(t <= times[0], values[0],
                                    ca.if_else(t >= times[-1], values[-1], spline(t)))
    if kind == "transition":
        return _transition(*(float(prescribed[k]) for k in ("start", "duration", "before", "after")))
    off, amp = float(prescribed.get("offset", 0.0)), float(prescribed.get("amplitude", 0.0))
    freq, phase = float(prescribed.get("frequency", 0.0)), float(prescribed.get("phase", 0.0))
    return lambda t: off + amp * ca.sin(freq * t + phase)


def _spinup_angle(offset: float, rate: float, ramp_time: float) -> Callable[[Any], Any]:
    """The angle of the classic spin-up (Banerjee ch. 5: Kane, Ryan and Banerjee 1987).

    The rate ``(W/T)(t - T/(2 pi) sin(2 pi t/T))`` for ``t <= T``, then ``W``, integrated from
    ``offset``: ``offset + (W/T)(t^2/2 + (T/(2 pi))^2 (cos(2 pi t/T) - 1))``, then
    ``offset + W T/2 + W (t - T)``. Rate and acceleration are continuous.
    """
    import casadi as ca

    T, W = ramp_time, rate
    c = T / (2 * np.pi)

    def angle(t):
        ramp = offset + (W / T) * (t**2 / 2 + c**2 * (ca.cos(t / c) - 1))
        steady = offset + W * T / 2 + W * (t - T)
        return ca.if_else(t <= T, ramp, steady)

    return angle


def _transition(start: float, duration: float, before: float, after: float) -> Callable[[Any], Any]:
    """``before`` until ``start``, then the cycloidal blend ``s - sin(2 pi s)/(2 pi)`` of
    ``s = (t - start)/duration`` to ``after`` (rate and acceleration zero at both ends), then ``after``."""
    import casadi as ca

    def value(t):
        s = ca.fmin(ca.fmax((t - start) / duration, 0.0), 1.0)
        return before + (after - before) * (s - ca.sin(2 * np.pi * s) / (2 * np.pi))

    return value
