"""The hard-case corpus: every hard model the project knows, in one place.

Each case is an open loop ``L`` (square, negative feedback) of a flexible-spacecraft kind, built to
break a numerical path: damping 1e-4, orders up to 401, rigid-body double integrators, repeated
frequencies, near pole-zero cancellation, states scaled 1e9 apart, a stiff chain compiled from a
scene, and the ISS 1R structure. ``tests/hard/test_corpus.py`` runs every analysis on each and
checks it against an independent computation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

import linflex
from linflex import LinearSystem, OperatingPoint

from ..mor import load_mor
from ..stability.stab_models import hub_loop


@dataclass(frozen=True)
class HardCase:
    """A named hard model: ``build()`` returns its open loop ``L`` (square, negative feedback)."""

    name: str
    build: Callable[[], LinearSystem]
    what: str
    rigid: bool  # has rigid-body (double integrator) poles at the origin


def flexible_pd_loop(order: int) -> LinearSystem:
    """The root-locus benchmark's loop (benchmarks/frequency.py): a rigid body and
    ``(order - 3) / 2`` modes at zeta 1e-3 between 0.5 and 50 rad/s (log-uniform, seed 1),
    collocated, under a PD law ``kp + kd s / (0.02 s + 1)`` (one filter state): ``order`` states."""
    import control

    rng = np.random.default_rng(1)
    n_modes = (order - 3) // 2
    w = np.sort(np.exp(rng.uniform(np.log(0.5), np.log(50.0), n_modes)))
    n = 2 + 2 * n_modes
    A = np.zeros((n, n))
    A[0, 1] = 1.0
    for i, wi in enumerate(w):
        A[2 + 2 * i:4 + 2 * i, 2 + 2 * i:4 + 2 * i] = [[0.0, 1.0], [-wi**2, -2e-3 * wi]]
    phi = np.r_[1.0, rng.uniform(0.2, 1.0, n_modes)]
    B = np.zeros((n, 1))
    B[1::2, 0] = phi
    C = np.zeros((1, n))
    C[0, 0::2] = phi
    K = LinearSystem([[-50.0]], [[1.0]], [[-0.5 * 2500.0]], [[0.2 + 0.5 * 50.0]])
    return LinearSystem.from_control(control.ss(K.to_control() * LinearSystem(A, B, C).to_control()))


def modal_plant(freqs, zetas, b, c, *, rigid: bool) -> LinearSystem:
    """Block-diagonal modal plant: optional rigid double integrator, then one 2x2 block per mode.

    ``b`` (n_modes, m) and ``c`` (p, n_modes) are the modal input and output gains; the rigid
    block gets ``b_rigid = 1`` and ``c_rigid = 1`` in every channel.
    """
    blocks, B_rows, C_cols = [], [], []
    m, p = b.shape[1], c.shape[0]
    if rigid:
        blocks.append(np.array([[0.0, 1.0], [0.0, 0.0]]))
        B_rows.append(np.vstack([np.zeros((1, m)), np.ones((1, m))]))
        C_cols.append(np.hstack([np.ones((p, 1)), np.zeros((p, 1))]))
    for k, (w, z) in enumerate(zip(freqs, zetas)):
        blocks.append(np.array([[0.0, 1.0], [-w * w, -2.0 * z * w]]))
        B_rows.append(np.vstack([np.zeros((1, m)), b[k][None, :]]))
        C_cols.append(np.hstack([c[:, k][:, None], np.zeros((p, 1))]))
    return LinearSystem(scipy.linalg.block_diag(*blocks), np.vstack(B_rows), np.hstack(C_cols), np.zeros((p, m)))


def pd_loop(plant: LinearSystem, kp: float, kd: float, tau: float) -> LinearSystem:
    """``L = C P`` with ``C(s) = kp + kd s / (tau s + 1)`` per channel (diagonal), plant first."""
    m = plant.n_inputs
    # controller per channel: state f' = (y - f) / tau, u = (kp + kd/tau) y - (kd/tau) f
    Ak = -np.eye(m) / tau
    Bk = np.eye(m) / tau
    Ck = -(kd / tau) * np.eye(m)
    Dk = (kp + kd / tau) * np.eye(m)
    n = plant.n_states
    A = np.block([[plant.A, np.zeros((n, m))], [Bk @ plant.C, Ak]])
    B = np.vstack([plant.B, np.zeros((m, m))])
    C = np.hstack([Dk @ plant.C, Ck])
    return LinearSystem(A, B, C, np.zeros((m, m)))


def repeated_axes() -> LinearSystem:
    """Two identical axes (repeated frequencies, every pole double), 2x2, damping 1e-3, order 66."""
    w = np.geomspace(0.8, 80.0, 15)
    z = np.full(15, 1e-3)
    g = 0.3 / (1.0 + np.arange(15)) ** 0.4
    one = modal_plant(w, z, g[:, None], g[None, :], rigid=True)
    plant = LinearSystem(scipy.linalg.block_diag(one.A, one.A), scipy.linalg.block_diag(one.B, one.B),
                         scipy.linalg.block_diag(one.C, one.C), np.zeros((2, 2)))
    return pd_loop(plant, 1.0, 1.4, 0.02)


def near_cancellation() -> LinearSystem:
    """Modes whose residues are 1e-8 of the others: poles and zeros within 1e-8 of each other."""
    w = np.geomspace(0.9, 60.0, 20)
    z = np.full(20, 5e-4)
    g = np.where(np.arange(20) % 4 == 1, 1e-4, 0.3)  # gain^2 = 1e-8 on every fourth mode
    return pd_loop(modal_plant(w, z, g[:, None], g[None, :], rigid=True), 1.0, 1.4, 0.02)


def badly_scaled() -> LinearSystem:
    """The repeated-axes loop in coordinates scaled from 1e-4 to 1e5 (states 1e9 apart)."""
    L = hub_loop(61, 1e-3)
    s = np.logspace(-4, 5, L.n_states)
    return LinearSystem(L.A * (s[:, None] / s[None, :]), L.B * s[:, None], L.C / s[None, :], L.D)


def stiff_chain_scene() -> linflex.Scene:
    """A hub on a revolute joint carrying a 10-segment spring chain, an attitude sensor and a torquer."""
    hub = linflex.Body(name="hub", mass=50.0, inertia=(20.0, 20.0, 20.0))
    bodies, joints = linflex.rigid_segment_beam("beam", length=5.0, EI=2.0e3, mass_per_length=1.0, segments=10,
                                                parent="hub", damping=0.05)
    spin = linflex.Joint(name="spin", type="revolute", child="hub", axis=(0.0, 0.0, 1.0))
    return linflex.Scene(
        name="chain", effects=("joint_springs",), bodies=(hub, *bodies), joints=(spin, *joints),
        sensors=(linflex.Sensor(name="angle", type="attitude", body="hub", axis=(0.0, 0.0, 1.0)),),
        actuators=(linflex.Actuator(name="torque", type="torque", body="hub", axis=(0.0, 0.0, 1.0)),),
    )


def stiff_chain_model():
    """The compiled :func:`stiff_chain_scene` and its equilibrium (every joint at rest)."""
    model = linflex.compile_model(stiff_chain_scene())
    return model, OperatingPoint(np.zeros(model.n_states), np.zeros(model.n_inputs))


def stiff_chain() -> LinearSystem:
    """A 10-segment rigid-segment beam (stiff rotational springs) on a hub, under PD at the hub.

    Built from the scene vocabulary and linearized exactly (autodiff): the segment springs put
    modal frequencies from about 1 to 1600 rad/s in one model; joint damping 0.05 N m s/rad.
    """
    from linflex.linearize import linearize

    model, op = stiff_chain_model()
    full = linearize(model, op, method="autodiff").sys
    k = full.outputs.index("angle")  # the compiled model also reports the actuator command
    plant = LinearSystem(full.A, full.B, full.C[k:k + 1], full.D[k:k + 1])
    return pd_loop(plant, 200.0, 300.0, 0.01)


CASES = (
    HardCase("hub_401_zeta1e-4", lambda: hub_loop(401, 1e-4), "order 401, damping 1e-4, rigid hub", True),
    HardCase("hub_rolloff_101_zeta1e-3", lambda: hub_loop(101, 1e-3, rolloff=True),
             "roll-off filter: many phase crossovers", True),
    HardCase("repeated_axes_2x2", repeated_axes, "every pole double, MIMO", True),
    HardCase("near_cancellation", near_cancellation, "residues 1e-8: poles near zeros", True),
    HardCase("badly_scaled", badly_scaled, "states scaled 1e-4 .. 1e5", True),
    HardCase("stiff_chain", stiff_chain, "10 rigid segments with springs, from a scene", True),
    HardCase("iss1R_x20", lambda: _iss1r_loop(20.0), "ISS 1R (270 states, 3x3), gain 20: crossings at resonances",
             False),
)


def _iss1r_loop(gain: float) -> LinearSystem:
    """``L = gain * G`` of the ISS 1R structure (stable, lightly damped; |L| peaks above 1)."""
    G = load_mor("iss1R")
    return LinearSystem(G.A, G.B, gain * G.C, gain * G.D)
