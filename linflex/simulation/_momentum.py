"""The momentum form of a compiled flexible model: the state in which the exponential integrator
steps, ``z = (q, p, a)`` with the generalized momenta ``p = M(q) u`` in place of the speeds ``u``.

Kane's equations ``M(q) u' = r(q, u, t)`` put the structure's stiffness through ``M(q)^-1``: a
mode's elastic force ``-w_j^2 q_j`` reaches every speed with a coefficient that changes as the
structure deflects (the rigid-flexible coupling of the mass matrix depends on the modal
coordinates), so the Jacobian of ``u'`` changes by about ``w_j^2`` times that coupling along the
run. On the hub with two 24-mode arrays of ``benchmarks/simulation.py`` the arrays' first axial
mode (``w^2 = 7.7e4 1/s^2``) changes the first bending mode's acceleration by 2760 1/s^2 per unit
of its coordinate; an exponential integrator with a frozen Jacobian carries that change in its
explicit remainder, where it is stiff (``h * 2760 * 0.3 = 83`` at the largest deflection and
``h = 0.1 s``), and its steps must resolve the axial mode. In the momentum form::

    q' = qdot(q, u),      p' = M'(q, q', t) u + r(q, u, t),      u = M(q)^-1 p

the stiffness enters ``p'`` with its constant coefficient and the deflection-dependent coupling
multiplies the momenta instead (``q' = M(q)^-1 p``): one power of the frequency less. Measured
on those arrays (tip deflection to 1e-8 of its peak against DOP853 at rtol 1e-11, one frozen
Jacobian, steps of the sample interval over 1, 2, 4, 8): the speeds' form stalls at 3e-7 to 2.5e-7
from 300 to 1200 steps and reaches 8.5e-10 only at 2400, where the steps resolve the axial
mode; the momentum form converges in the step, 3.2e-7, 9.2e-8, 9.9e-9, 6.1e-10 (the same at 48
modes per array).

The form is built for compiled scenes whose speeds include a block with a constant mass matrix
(the modal speeds of flexible bodies: :func:`~linflex.compiler._block_solve.constant_block`), so
that ``u = M^-1 p`` is the block solve of the compiled state derivative; for other models (a
constant mass matrix, where the momenta are a fixed linear map of the speeds and change
nothing; loop joints; rigid chains) :func:`momentum_form` returns None and the integrator steps
in the model's own state.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

__all__ = ["MomentumForm", "momentum_form"]

_FORMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
# The speeds outside the constant mass block whose Schur complement the form's graph solves
# symbolically (its LU expanded: O(k^3) instructions; a hub, its wheels and a few joints).
MAX_OTHER_SPEEDS = 12


@dataclass(frozen=True, eq=False)
class MomentumForm:
    """A compiled model's state derivative in ``z = (q, p, a)`` and the maps between ``x`` and ``z``.

    Attributes
    ----------
    f : casadi.Function
        ``(z, u, p, t) -> z'``: coordinates' rates, the momenta's rates
        ``M'(q, q', t) u + r(q, u, t)`` [N, N m, or kg^1/2 m / s^2 for modal speeds] and the
        auxiliary states' rates.
    jacobian : casadi.Function
        ``(z, u, p, t) -> dz'/dz``, dense.
    speeds : slice
        Where the speeds (in ``x``) and the momenta (in ``z``) sit.
    """

    f: object
    jacobian: object
    speeds: slice
    _z_of_x: object
    _x_of_z: object
    _mass: object

    def to_z(self, x: np.ndarray, params: np.ndarray, t: float) -> np.ndarray:
        """``z`` of the state ``x`` at time ``t`` [s]: the speeds replaced by ``M(q) u``."""
        return np.asarray(self._z_of_x(x, params, t), float).reshape(-1)

    def to_x(self, Z: np.ndarray, params: np.ndarray, times: np.ndarray) -> np.ndarray:
        """The states of the rows of ``Z`` at ``times`` [s]: the momenta replaced by
        ``u = M(q)^-1 p`` (one block solve per row)."""
        k = Z.shape[0]
        X = self._x_of_z.map(k)(Z.T, np.tile(np.reshape(params, (-1, 1)), (1, k)), np.reshape(times, (1, -1)))
        return np.asarray(X, float).T

    def inverse_mass(self, z: np.ndarray, params: np.ndarray, t: float) -> np.ndarray:
        """``M(q)^-1`` at ``z`` [inverse mass units]: maps errors of the momenta to the speeds'."""
        return np.linalg.inv(np.asarray(self._mass(z, params, t), float))


def momentum_form(model) -> MomentumForm | None:
    """The :class:`MomentumForm` of a compiled model, built once per model; None where the model
    has no Kane equations, loop joints or contacts, a mass matrix that depends on the inputs or
    on nothing (constant), or no speeds with a constant mass block (see the module's notes)."""
    if model not in _FORMS:
        _FORMS[model] = _build(model)
    return _FORMS[model]


def _build(model) -> MomentumForm | None:
    import casadi as ca

    from ..compiler._block_solve import block_solve, constant_block
    from ..system._jacobians import colored_jacobian

    eq = getattr(model, "equations", None)
    if eq is None or eq.loop is not None or getattr(eq.builder, "u", None) is None:
        return None
    b = eq.builder
    q, u, t = b.q, b.u, b.t
    nq, nu = q.numel(), u.numel()
    x, uin, psym = eq.x, eq.inputs, eq.params
    n, n_aux = x.numel(), x.numel() - q.numel() - u.numel()
    if nu == 0 or n != model.n_states:
        return None
    J, Mb, c, g = b.assemble_parts()
    M = J.T @ (Mb @ J)
    if ca.depends_on(M, ca.vertcat(u, uin)) or not ca.depends_on(M, ca.vertcat(q, t)):
        return None
    block = constant_block(J, Mb, ca.vertcat(x, uin, psym, t))
    if block is None or nu - len(block[0]) > MAX_OTHER_SPEEDS:
        return None
    # One flat graph of z: the speeds from the momenta by the block solve (the few other speeds'
    # Schur complement expanded), then the rates with those speeds substituted.
    p = ca.SX.sym("p", nu)
    aux = x[nq + nu:]
    speeds = block_solve(M, p, *block)
    Mu = J.T @ (Mb @ (J @ u))
    auxdot = eq.auxdot if n_aux else ca.SX(0, 1)
    rates = ca.substitute(ca.vertcat(b.qdot, b.rate(Mu) + g - J.T @ c, auxdot), u, speeds)
    z = ca.vertcat(q, p, aux)
    f = ca.Function("f_momentum", [z, uin, psym, t], [rates], ["z", "u", "p", "t"], ["zdot"], {"cse": True})
    Z, U, P, T = ca.MX.sym("z", n), ca.MX.sym("u", uin.numel()), ca.MX.sym("p", psym.numel()), ca.MX.sym("t")
    jacobian = ca.Function("jacobian_momentum", [Z, U, P, T],
                           [ca.densify(colored_jacobian(rates, z, [uin, psym, t], Z, [U, P, T]))])
    z_of_x = ca.Function("z_of_x", [x, psym, t], [ca.vertcat(q, Mu, aux)], {"cse": True})
    x_of_z = ca.Function("x_of_z", [z, psym, t], [ca.vertcat(q, speeds, aux)], {"cse": True})
    mass = ca.Function("mass_of_z", [z, psym, t], [M], {"cse": True})
    return MomentumForm(f=f, jacobian=jacobian, speeds=slice(nq, nq + nu), _z_of_x=z_of_x, _x_of_z=x_of_z,
                        _mass=mass)
