"""A rolling disk: upright rolling is stable above a critical speed, as Routh's closed form says.

The scene ``rolling_disk.toml`` is a thin uniform disk on a small hub rolling without slip (a
``rolling`` constraint: one holonomic and two non-holonomic rows). Linearized about upright
straight rolling at speed ``v`` (the same state for every speed, the speeds scaled), the lean
has the eigenvalues ``+-sqrt(lambda^2)`` with (Routh, *Advanced Rigid Dynamics*, art. 244)::

    lambda^2 = (m g R - C (C + m R^2) Omega^2 / A) / (A + m R^2),    Omega = v / R

``m`` the total mass, ``A`` the transverse and ``C`` the spinning disk's axial moment of inertia:
unstable (a real pair) below ``v_c^2 = m g R^3 A / (C (C + m R^2))``, neutrally stable (an
imaginary pair) above; for a thin uniform disk alone ``v_c^2 = g R / 3``. The script prints the
lean eigenvalues against speed beside the closed form, and finds the critical speed where the
product of the lean pair (``-lambda^2``) changes sign.

``main()`` returns ``(critical speed of the model, of the closed form)`` [m/s].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.optimize

import linflex
from linflex.linearize import constrained_linearization

SCENE = Path(__file__).with_name("rolling_disk.toml")
G = 9.81


def lean_pair(model: linflex.Model, v: float) -> np.ndarray:
    """The two eigenvalues [1/s] of largest magnitude of the constrained linearization at ``v``
    [m/s] (the others are zero: position, heading, spin angle, the hub's turning)."""
    x = np.array(model.x0, float)
    nq = model.constraints.n_coordinates
    x[nq:] *= v / x[model.states.index("float.vx")]
    lin = constrained_linearization(model, linflex.OperatingPoint(x), method="kane", allow_non_equilibrium=True)
    ev = np.linalg.eigvals(lin.sys.A)
    return ev[np.argsort(-np.abs(ev))][:2]


def closed_form(scene: linflex.Scene, v: float) -> complex:
    """Routh's lean eigenvalue ``sqrt(lambda^2)`` [1/s] at ``v`` [m/s] for the scene's wheel."""
    hub, disk = scene.bodies
    R = scene.constraints[0].radius
    m, A, C = hub.mass + disk.mass, hub.inertia[0] + disk.inertia[0], disk.inertia[1]
    return np.sqrt(complex((m * G * R - C * (C + m * R**2) * (v / R) ** 2 / A) / (A + m * R**2)))


def main() -> tuple[float, float]:
    scene = linflex.load_scene(SCENE)
    model = linflex.compile_model(scene)
    for v in np.arange(0.0, 3.01, 0.5):
        pair = lean_pair(model, v)
        print(f"v = {v:3.1f} m/s: lean {np.max(pair.real) + 0.0:+.6f} {np.max(np.abs(pair.imag)):+.6f}i,"
              f" closed form {closed_form(scene, v):+.6f}")
    critical = scipy.optimize.brentq(lambda v: -np.prod(lean_pair(model, v)).real, 0.5, 3.0, xtol=1e-14)
    hub, disk = scene.bodies
    R = scene.constraints[0].radius
    m, A, C = hub.mass + disk.mass, hub.inertia[0] + disk.inertia[0], disk.inertia[1]
    exact = float(np.sqrt(m * G * R**3 * A / (C * (C + m * R**2))))
    print(f"critical speed {critical:.12f} m/s (closed form {exact:.12f} m/s; sqrt(g R / 3) = "
          f"{np.sqrt(G * R / 3):.6f} m/s for the disk alone)")
    return critical, exact


if __name__ == "__main__":
    main()
