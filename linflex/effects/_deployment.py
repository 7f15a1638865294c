"""Deploying booms: material that streams out of (or back into) a body along a length profile.

A boom of mass per length ``rho`` and full length ``L`` deploys from the root ``point`` of its
body along ``e``; its deployed length ``l(t)`` is prescribed. The stowed part, ``rho (L - l)``,
is a point mass at the root. The deployed material moves outward at ``l'``: the particle that
left the root ``sigma`` metres of material ago sits at ``s = l(t) - sigma`` from the root, at
(body axes)::

    p(sigma, t) = root + (s - f(s)) e + w1(s) n1 + w2(s) n2,      s = l(t) - sigma

with the bending ``w_d(s) = sum_k (s/l)^(k+2) eta_dk`` (assumed shapes that stretch with the
length: Banerjee's variable-length beam, the modes follow the deployment) and the axial
foreshortening ``f(s) = 1/2 int_0^s (w1'^2 + w2'^2)`` that makes spin stiffen the boom.

Kane's generalized inertia forces of the material follow each particle at fixed ``sigma`` (the
material derivative): the velocities and accelerations are the rates of ``p`` with ``sigma``
held, evaluated afterwards at Gauss-Legendre points ``sigma_k = l (1 - xi_k)`` of the deployed
length with weights ``rho l w_k``. The points are enough for the integrands (polynomials in
``xi``) to be integrated exactly, so the discrete equations are the continuum's. Mass crosses
the root at the rate ``rho l'`` and changes velocity there by ``l' e`` (from the root's velocity
to the deployed material's, or back when retracting): the momentum flux ``rho l'^2 e`` acts at
the root (Reynolds' transport theorem). The mechanism that drives ``l(t)`` and the bending are
internal: the total angular momentum of an isolated spacecraft stays constant.

Bending stiffness ``K = EI / l^3 [(i+2)(i+1)(j+2)(j+1) / (i+j+1)]`` for each transverse direction
(the strain energy ``1/2 int EI w''^2``), generalized forces ``-K eta - damping K eta'``.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..dynamics._kane import MaterialElement, skew
from ..scene._registry import Effect, register_effect
from ..scene._values import profile_function, unit_vector, vector3

__all__ = ["boom_axes", "boom_stiffness", "quadrature_points"]


def boom_axes(direction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(e, n1, n2)``: the deployment direction and the two bending directions (body axes).

    ``n1`` is the first body axis (x, y, z) not within 25 degrees of ``e``, made normal to it;
    ``n2 = e x n1``. For a boom along x: ``(x, y, z)``.
    """
    e = unit_vector(direction)
    axis = next(a for a in np.eye(3) if abs(a @ e) < 0.9)
    n1 = axis - (axis @ e) * e
    n1 /= np.linalg.norm(n1)
    return e, n1, np.cross(e, n1)


def boom_stiffness(n_modes: int) -> np.ndarray:
    """The bending stiffness of the shapes ``xi^(k+2)`` per ``EI / l^3``: ``int phi_i'' phi_j'' dxi``."""
    k = np.arange(n_modes)
    c = (k + 2.0) * (k + 1.0)
    return np.outer(c, c) / (k[:, None] + k[None, :] + 1.0)


def quadrature_points(n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points ``xi`` on ``[0, 1]`` and weights, exact for the boom's integrands.

    The momentum ``p x v`` of the bent, foreshortened boom is a polynomial in ``xi`` of degree at
    most ``2 (2 n + 3) + 2`` (the foreshortening has degree ``2 n + 3``, the stretching of the
    shapes adds ``(1 - xi)`` factors); ``N`` points integrate degree ``2 N - 1`` exactly.
    """
    degree = 2 if n_modes == 0 else 2 * (2 * n_modes + 3) + 2
    N = degree // 2 + 1
    x, w = np.polynomial.legendre.leggauss(N)
    return (x + 1) / 2, w / 2


#: Effects that act on the bodies' mass elements and would miss the booms' material.
_UNFELT = ("gravity", "central_gravity", "gravity_gradient")


def _length(boom):
    value = boom.length
    return profile_function(value) if isinstance(value, dict) or callable(value) else (lambda t: float(value) + 0 * t)


class Deployment(Effect):
    """``deployment``: booms deploying from their body along a length profile (``booms``); the
    stowed material at the root, the deployed material streaming out with its momentum flux,
    flexible booms bending in assumed shapes that stretch with the length (coordinates
    ``<boom>.eta<k>``); outputs ``<boom>.length`` [m]. The total angular momentum of an isolated
    spacecraft is conserved while its inertia changes."""

    name = "deployment"
    order = 20

    def check(self, scene):
        out = [f"effects: booms feel no {name!r} yet (the deployed material is not a body's mass element); "
               "leave it out or model the boom as a flexible body" for name in _UNFELT if scene.booms and name in scene.effects]
        for i, boom in enumerate(scene.booms):
            if boom.n_modes():
                bounds = boom.deployed_range()
                if bounds is not None and not bounds[0] > 0:
                    out.append(f"booms[{i}].length: a flexible boom needs a positive length at all times (its "
                               f"bending stiffness grows as 1/length^3), got a smallest length of {bounds[0]:g} m")
        return out

    def structure(self, b, scene):
        for boom in scene.booms:
            n = boom.n_modes()
            if n:
                names = [f"{boom.name}.eta{k}" for k in range(2 * n)]
                q, u = b.add_coordinates(names, [f"{name}_rate" for name in names])
                b.set_kinematics(q, u)

    def signals(self, b, scene):
        wF = skew(ca.DM(b.w_F))
        for boom in scene.booms:
            n = boom.n_modes()
            frame = b.frames[boom.body]
            e, n1, n2 = boom_axes(boom.direction)
            root = vector3(boom.point)
            rho = float(boom.mass_per_length)
            length = _length(boom)(b.t)
            rate = ca.jacobian(length, b.t)
            xi, weights = quadrature_points(n)
            N = xi.size
            sigma = ca.SX.sym(f"sigma_{boom.name}", N)
            s = length - sigma
            local = ca.repmat(ca.DM(root), 1, N) + ca.DM(e) @ s.T  # 3 x N
            if n:
                eta = b.q[[b.q_names.index(f"{boom.name}.eta{k}") for k in range(2 * n)]]
                x = s / length  # xi of each material point, with sigma held
                k = np.arange(n)
                bend = [ca.SX.zeros(N, 1), ca.SX.zeros(N, 1)]
                slope2 = ca.SX.zeros(N, 1)  # int_0^xi (dw/dxi)^2 over both directions
                for d in range(2):
                    ed = eta[d * n:(d + 1) * n]
                    for i in k:
                        bend[d] += x ** (i + 2) * ed[i]
                        for j in k:
                            slope2 += (ed[i] * ed[j] * (i + 2) * (j + 2) / (i + j + 3)) * x ** (i + j + 3)
                local = (local - ca.DM(e) @ (slope2 / (2 * length)).T + ca.DM(n1) @ bend[0].T
                         + ca.DM(n2) @ bend[1].T)
            R = ca.vec(ca.repmat(frame.r, 1, N) + frame.C @ local)
            V = b.rate(R)
            A = b.rate(V) + ca.vec(2 * wF @ ca.reshape(V, 3, N) + wF @ (wF @ ca.reshape(R, 3, N)))
            at = length * ca.DM(1 - xi)
            R, V, A = (ca.substitute(expr, sigma, at) for expr in (R, V, A))
            r0, v0, _, a0 = b.kinematics_of(frame.r + frame.C @ ca.DM(root))
            stowed = rho * (boom.full_length() - length)
            flux = rho * rate**2 * (frame.C @ ca.DM(e))
            b.materials.append(MaterialElement(
                boom.name, ca.vertcat(stowed, rho * length * ca.DM(weights)), ca.vertcat(r0, R), ca.vertcat(v0, V),
                ca.vertcat(a0, A), ca.vertcat(flux, ca.SX.zeros(3 * N, 1)), body=boom.body))
            b.add_output([f"{boom.name}.length"], length)

    def loads(self, b, scene):
        for boom in scene.booms:
            n = boom.n_modes()
            if not n:
                continue
            length = _length(boom)(b.t)
            K = float(boom.EI) / length**3 * ca.DM(boom_stiffness(n))
            for d in range(2):
                names = [f"{boom.name}.eta{d * n + k}" for k in range(n)]
                eta = b.q[[b.q_names.index(name) for name in names]]
                rates = [b.speed_index(f"{name}_rate") for name in names]
                eta_rate = b.u[rates]
                force = -K @ (eta + float(boom.damping) * eta_rate)
                for k, index in enumerate(rates):
                    b.add_generalized_force(index, force[k])
                b.add_potential(0.5 * ca.dot(eta, K @ eta))


for _effect in (Deployment(),):
    register_effect(_effect)
