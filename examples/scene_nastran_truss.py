"""A spacecraft whose truss comes from NASTRAN: two Craig-Bampton components on a rigid bus.

The story: the inboard and outboard truss sections of pyyeti's test models (NASTRAN EXTSEOUT
runs, lengths in mm, mass in kg) are read straight from the installed pyyeti package, joined at
their four shared interface grids (3, 11, 19, 27), and fixed to a 10 kg rigid bus at those
grids. The scene floats freely (no joint restraint), with a torque actuator on the bus and a
rate sensor at grid 45, the outboard end of the truss (its mode shapes there come from NASTRAN's
displacement recovery matrix MUG1). We linearize it at rest and compare its elastic
frequencies with an independent computation from the NASTRAN matrices alone: the joined
Craig-Bampton mass and stiffness with the bus's rigid mass added to the interface's rigid-body
motion. NASTRAN itself checks the joined truss: its system run (assemble.out) prints the
free-free frequencies that :func:`linflex.structures.join_components` reproduces (tested).

``main()`` returns the largest relative difference of the scene's elastic frequencies from the
independent ones.

Run: ``python examples/scene_nastran_truss.py`` (needs pyyeti: ``pip install "linflex[nastran]"``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg

import linflex
from linflex.linearize import linearize
from linflex.structures import join_components, nastran_modal_data

BUS_MASS = 10.0  # kg
BUS_INERTIA = (0.6, 0.5, 0.5)  # kg m^2 about the bus's mass centre
BUS_COM = (-0.3, 0.0, 0.0)  # m, behind the interface
INTERFACE = np.array([600.0, 150.0, 150.0])  # mm: centre of the four interface grids, the body origin
N_MODES = 12  # the lowest 12 of the truss's 30 fixed-interface modes (10.4 to 87.9 rad/s)


def pyyeti_models() -> Path:
    """The directory of NASTRAN test models in the installed pyyeti package."""
    try:
        import pyyeti
    except ImportError as err:
        raise linflex.MethodUnavailableError('this example reads pyyeti\'s NASTRAN test models: '
                                             'pip install "linflex[nastran]"') from err
    return Path(pyyeti.__file__).parent / "tests" / "nas2cam_extseout"


def independent_frequencies(truss) -> np.ndarray:
    """Elastic frequencies [rad/s] of bus + truss from the Craig-Bampton matrices (SI units)."""
    b, q = truss.boundary, truss.modal
    R = truss.rigid_body_modes(INTERFACE)  # mm and rad about the interface centre
    R[:, :3] *= 1e3  # per metre of translation
    K, M = np.asarray(truss.K), np.asarray(truss.M)
    c = np.asarray(BUS_COM)
    c_x = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
    bus = np.block([[BUS_MASS * np.eye(3), -BUS_MASS * c_x],
                    [BUS_MASS * c_x, np.diag(BUS_INERTIA) - BUS_MASS * c_x @ c_x]])
    # Coordinates (rigid motion [m, rad] of the interface centre, modal coordinates [sqrt(kg) m]);
    # NASTRAN's are mm, rad and sqrt(kg) mm, with energies in kg mm^2/s^2 = 1e-6 J.
    T = np.zeros((K.shape[0], 6 + q.size))
    T[b, :6] = R
    _, V = scipy.linalg.eigh(K[np.ix_(q, q)], M[np.ix_(q, q)])  # the fixed-interface modes, ascending
    T = T[:, :6 + N_MODES]
    T[q, 6:] = 1e3 * V[:, :N_MODES]
    mass = 1e-6 * T.T @ M @ T
    mass[:6, :6] += bus
    stiffness = 1e-6 * T.T @ K @ T
    lam = scipy.linalg.eigh(stiffness[6:, 6:], mass[6:, 6:] - mass[6:, :6] @ np.linalg.solve(mass[:6, :6],
                                                                                             mass[:6, 6:]),
                            eigvals_only=True)
    return np.sqrt(lam)


def main() -> float:
    models = pyyeti_models()
    truss = join_components([models / "inboard.op4", models / "outboard.op4"])
    data = nastran_modal_data(truss, reference=INTERFACE, length_unit=1e-3, n_modes=N_MODES)
    scene = linflex.Scene(
        name="nastran_truss",
        bodies=(linflex.Body(name="spacecraft", mass=BUS_MASS, inertia=BUS_INERTIA, com=BUS_COM, type="flexible",
                             modal_data=data),),
        joints=(linflex.Joint(name="float", type="free", child="spacecraft"),),
        sensors=(linflex.Sensor(name="rate_45", type="rate", body="spacecraft", node="grid_45"),),
        actuators=(linflex.Actuator(name="torque", type="torque", body="spacecraft"),))
    model = linflex.compile_model(scene)
    sys = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs))).sys
    eig = np.linalg.eigvals(sys.A)
    scene_w = np.sort(eig.imag[eig.imag > 1e-6])
    reference = independent_frequencies(truss)
    error = float(np.max(np.abs(scene_w - reference) / reference))
    print(f"truss: {truss.boundary.size} interface freedoms, {truss.modal.size} component modes; "
          f"{model.n_states} states in the scene")
    print("first elastic frequencies [rad/s]:", np.array2string(scene_w[:6], precision=4))
    print(f"largest relative difference from the Craig-Bampton matrices: {error:.1e}")
    return error


if __name__ == "__main__":
    main()
