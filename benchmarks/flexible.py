"""Flexible bodies: accuracy against cost of modal models, and cost against node count.

Issue 4's benchmark, three tables:

1. Spin-up of a cantilever on a hub (Kane, Ryan and Banerjee 1987): a 10 m cantilever
   (EI = 1.4e4 N m^2, EA = 2.8e7 N, 1.2 kg/m) on a hub spun up to 6 rad/s in 15 s, in-plane
   bending, 30 s simulated. Reference: the rigid-segment model (reference notes section 9.1) with
   10 segments (converged to 0.03 % of the peak against 20 segments).
2. The hub with two solar arrays (``examples/spacecraft_arrays.toml``) under its PD attitude loop:
   a 50 N m pulse of the yaw wheel's motor for 2 s (about half the first array period), 30 s
   simulated. The yaw manoeuvre bends the arrays in the hub's x-y plane only (antisymmetric), so
   the reference is the same scene with each array as a chain of 12 rigid segments bending about
   z (6 segments shown for its own convergence). The arrays' structural damping is set to zero in
   every model, since a modal damping ratio has no exact counterpart in joint dampers.
3. Node-count independence: a free hub with one flexible appendage of 6 synthetic modes built
   from 100, 1 000 and 10 000 mass points: compile time, CasADi graph size and the median time of
   one evaluation of the compiled state derivative. The modal integrals are node sums computed
   once when the model is built, so only that step grows with the node count.

For 2, 4, 8 and 16 modes (per array in the scene), with the motion-induced geometric stiffness
on and off: largest tip-deflection error relative to the reference's peak, compile and
simulation time.

Run: ``python benchmarks/flexible.py [--quick]``.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import linflex  # noqa: E402
from linflex import Beam, ModalData, beam_modal_data  # noqa: E402

EI, EA, MASS, LENGTH = 1.4e4, 2.8e7, 1.2, 10.0
TIMEPTS = np.linspace(0.0, 30.0, 301)
SPIN = linflex.Joint(name="spin", type="revolute", child="hub", axis=(0.0, 0.0, 1.0),
                     prescribed={"profile": "spinup", "rate": 6.0, "ramp_time": 15.0})
HUB = linflex.Body(name="hub", mass=1.0, inertia=(1.0, 1.0, 1.0))


def reference_tip(segments: int = 10):
    bodies, joints = linflex.rigid_segment_beam("beam", length=LENGTH, EI=EI, mass_per_length=MASS,
                                                segments=segments, parent="hub")
    model = linflex.compile_model(linflex.Scene(name="segments", effects=("joint_springs",),
                                                bodies=(HUB, *bodies), joints=(SPIN, *joints)))
    start = time.perf_counter()
    response = linflex.simulate(model, TIMEPTS, rtol=1e-8, atol=1e-10)
    seconds = time.perf_counter() - start
    angles = np.cumsum(np.column_stack([response[f"beam_joint{k}.angle"] for k in range(segments)]), axis=1)
    lengths = np.full(segments, LENGTH / segments)
    lengths[-1] /= 2
    return np.sin(angles) @ lengths, seconds


def spinup_scene(n_modes: int, geometric: bool = True):
    """``(scene, modal data)`` of the spin-up: the hub spun up by the prescribed profile with the
    cantilever of ``n_modes`` modes along x (tip in-plane deflection: ``eta @ tip[1]``)."""
    # EIy = 10 EI keeps the out-of-plane modes above the in-plane ones of interest.
    data = beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=EA, EIy=10 * EI, EIz=EI, GJ=1e4,
                                mass_per_length=MASS, elements=24), n_modes)
    scene = linflex.Scene(name="spinup", effects=("geometric_stiffness",) if geometric else (),
                          bodies=(HUB, linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
                          joints=(SPIN, linflex.Joint(name="clamp", type="fixed", parent="hub", child="beam")))
    return scene, data


def modal_case(n_modes: int, geometric: bool, repeats: int):
    scene, data = spinup_scene(n_modes, geometric)
    start = time.perf_counter()
    model = linflex.compile_model(scene)
    compile_seconds = time.perf_counter() - start
    seconds, response = median_time(lambda: linflex.simulate(model, TIMEPTS, rtol=1e-8, atol=1e-10), repeats)
    _, tip, _ = data.node("0.end")
    return np.column_stack([response[f"beam.eta{k}"] for k in range(n_modes)]) @ tip[1], compile_seconds, seconds


def spinup_table(quick: bool) -> None:
    reference, reference_seconds = reference_tip()
    peak = float(np.max(np.abs(reference)))
    print("### Spin-up of a cantilever on a hub\n")
    print(f"reference: 10 rigid segments, peak in-plane tip deflection {peak:.4f} m, "
          f"simulated in {reference_seconds:.2f} s\n")
    print("| modes | geometric stiffness | max tip error / peak | compile [s] | simulate [s] |")
    print("|---|---|---|---|---|")
    for n_modes in (2, 4) if quick else (2, 4, 8, 16):
        for geometric in (True, False):
            tip, compile_seconds, seconds = modal_case(n_modes, geometric, 1 if quick else 3)
            error = float(np.max(np.abs(tip - reference))) / peak
            shown = f"{error:.2e}" if error < 1e3 else f"diverges ({error:.0e})"
            print(f"| {n_modes} | {'on' if geometric else 'off'} | {shown} | {compile_seconds:.3f} | {seconds:.3f} |")


# -- the hub with two solar arrays ------------------------------------------------------------

ARRAYS = linflex.load_scene(Path(__file__).resolve().parents[1] / "examples" / "spacecraft_arrays.toml")
ARRAY_NAMES = ("array_left", "array_right")
PULSE = {"motor_z": lambda t: 50.0 if t < 2.0 else 0.0}  # [N m] on the yaw wheel's motor


def undamped_arrays(n_modes: int, geometric: bool) -> linflex.Scene:
    scene = linflex.vary_scene(ARRAYS, {f"bodies.{name}.modes": n_modes for name in ARRAY_NAMES})
    bodies = tuple(dataclasses.replace(b, beam={**b.beam, "damping": 0.0}) if b.beam else b for b in scene.bodies)
    effects = scene.effects if geometric else tuple(e for e in scene.effects if e != "geometric_stiffness")
    return dataclasses.replace(scene, bodies=bodies, effects=effects)


def compile_and_simulate(scene, timepts):
    """``(response, compile seconds, simulation seconds)`` of the yaw-wheel pulse on ``scene``."""
    start = time.perf_counter()
    model = linflex.compile_model(scene)
    compile_seconds = time.perf_counter() - start
    start = time.perf_counter()
    response = linflex.simulate(model, timepts, inputs=PULSE)
    return response, compile_seconds, time.perf_counter() - start


def arrays_modal_case(n_modes: int, geometric: bool, timepts):
    """In-plane (x) tip deflections of both arrays in hub axes, (n_time, 2) [m], and seconds."""
    scene = undamped_arrays(n_modes, geometric)
    response, compile_seconds, seconds = compile_and_simulate(scene, timepts)
    tips = []
    for name in ARRAY_NAMES:
        body = next(b for b in scene.bodies if b.name == name)
        _, tip, _ = body.resolved_modal_data().node("0.end")
        tips.append(np.column_stack([response[f"{name}.eta{k}"] for k in range(n_modes)]) @ tip[0])
    return np.column_stack(tips), compile_seconds, seconds


def arrays_segment_case(segments: int, timepts):
    """The same tip deflections with each array as ``segments`` rigid segments bending about z."""
    spec = next(b for b in ARRAYS.bodies if b.name == ARRAY_NAMES[0]).beam
    length, EI, rho = spec["length"], spec["EI"], spec["mass_per_length"]
    # The clamped half segment at each root does not move: it joins the hub (a thin rod along y
    # from y = 1 m, with the arrays' torsional inertia about its axis).
    half = length / segments / 2
    mass, arm = rho * half, 1.0 + half / 2
    rod = mass * (arm**2 + half**2 / 12)
    hub = ARRAYS.bodies[0]
    inertia = np.diag(np.asarray(hub.inertia, dtype=float)) + 2 * np.diag(
        [rod, spec["torsional_inertia_per_length"] * half, rod])
    bodies = [dataclasses.replace(hub, mass=hub.mass + 2 * mass, inertia=inertia.tolist())]
    joints = [j for j in ARRAYS.joints if j.child == hub.name]
    for name, side in zip(ARRAY_NAMES, (1.0, -1.0)):
        b, j = linflex.rigid_segment_beam(name, length=length, EI=EI, mass_per_length=rho, segments=segments,
                                          parent=hub.name, root=(0.0, side, 0.0), direction=(0.0, side, 0.0),
                                          bending_axis=(0.0, 0.0, 1.0))
        bodies += b
        joints += j
    effects = tuple(e for e in ARRAYS.effects if e != "geometric_stiffness") + ("joint_springs",)
    scene = dataclasses.replace(ARRAYS, bodies=tuple(bodies), joints=tuple(joints), effects=effects)
    response, compile_seconds, seconds = compile_and_simulate(scene, timepts)
    lengths = np.full(segments, length / segments)
    lengths[-1] /= 2
    tips = []
    for name, side in zip(ARRAY_NAMES, (1.0, -1.0)):
        angles = np.cumsum(np.column_stack([response[f"{name}_joint{k}.angle"] for k in range(segments)]), axis=1)
        tips.append(-side * np.sin(angles) @ lengths)  # about +z, +y turns to -x
    return np.column_stack(tips), compile_seconds, seconds


def arrays_table(quick: bool) -> None:
    timepts = np.linspace(0.0, 10.0 if quick else 30.0, 101 if quick else 301)
    fine, coarse = (6, 3) if quick else (12, 6)
    reference, ref_compile, ref_seconds = arrays_segment_case(fine, timepts)
    check, _, check_seconds = arrays_segment_case(coarse, timepts)
    peak = float(np.max(np.abs(reference)))
    own = float(np.max(np.abs(check - reference))) / peak
    print(f"\n### Hub with two solar arrays, yaw-wheel pulse ({timepts[-1]:.0f} s)\n")
    print(f"reference: {fine} rigid segments per array, peak in-plane tip deflection {peak:.4f} m, "
          f"compiled in {ref_compile:.2f} s, simulated in {ref_seconds:.2f} s; "
          f"{coarse} segments differ from it by {own:.2e} of the peak (simulated in {check_seconds:.2f} s)\n")
    print("| modes per array | geometric stiffness | max tip error / peak | compile [s] | simulate [s] |")
    print("|---|---|---|---|---|")
    for n_modes in (2, 4) if quick else (2, 4, 8, 16):
        for geometric in (True, False):
            tips, compile_seconds, seconds = arrays_modal_case(n_modes, geometric, timepts)
            error = float(np.max(np.abs(tips - reference))) / peak
            print(f"| {n_modes} | {'on' if geometric else 'off'} | {error:.2e} | {compile_seconds:.3f} | {seconds:.3f} |")


# -- cost against node count --------------------------------------------------------------------

def synthetic_appendage(n_points: int, n_modes: int = 6, length: float = 10.0, mass: float = 20.0) -> ModalData:
    """A straight appendage along x with smooth bending shapes in y and z (cost only: the data are
    consistent in shape, not the modes of a real structure)."""
    x = np.linspace(length / n_points, length, n_points)
    s = x / length
    positions = np.column_stack([x, np.zeros(n_points), np.zeros(n_points)])
    masses = np.full(n_points, mass / n_points)
    inertias = np.tile(np.diag([1e-3, 1e-4, 1e-4]) / n_points, (n_points, 1, 1))
    translations = np.zeros((n_points, 3, n_modes))
    rotations = np.zeros((n_points, 3, n_modes))
    for k in range(n_modes):
        j, axis = k // 2 + 1, 1 + k % 2  # pairs of bending shapes along y and z
        wave = (j - 0.5) * np.pi
        scale = 1.0 / np.sqrt(mass / 2)
        translations[:, axis, k] = scale * (1 - np.cos(wave * s))
        slope = scale * wave / length * np.sin(wave * s)
        rotations[:, 3 - axis, k] = slope if axis == 1 else -slope  # z rotation for y bending
    # Mass-normalize: Phi^T M Phi = U over the translations (the rotary inertia is tiny).
    modal_mass = np.einsum("g,gil,gik->lk", masses, translations, translations)
    unit = np.linalg.inv(np.linalg.cholesky(modal_mass)).T
    translations, rotations = translations @ unit, rotations @ unit
    frequencies = 2.0 * (np.arange(n_modes) // 2 + 1.0) ** 2
    return ModalData(positions, masses, inertias, translations, rotations, frequencies, np.full(n_modes, 0.01),
                     node_names=("tip",), node_positions=positions[-1:], node_translations=translations[-1:],
                     node_rotations=rotations[-1:], source="synthetic")


def node_count_model(n_points: int):
    """The compiled scene, its compile time [s] and a random state near ``x0``."""
    data = synthetic_appendage(n_points)
    scene = linflex.Scene(
        name="appendage", bodies=(linflex.Body(name="hub", mass=500.0, inertia=(400.0, 300.0, 450.0)),
                                  linflex.Body(name="boom", mass=0.0, type="flexible", modal_data=data)),
        joints=(linflex.Joint(name="attitude", type="spherical", child="hub"),
                linflex.Joint(name="mount", type="fixed", parent="hub", child="boom", parent_point=(1.0, 0.0, 0.0))))
    start = time.perf_counter()
    model = linflex.compile_model(scene)
    compile_seconds = time.perf_counter() - start
    x = model.x0 + 0.1 * np.random.default_rng(4).standard_normal(model.n_states)
    return model, compile_seconds, x


def node_count_table(quick: bool) -> None:
    counts = (100, 1_000, 10_000)
    cases = [node_count_model(n) for n in counts]
    calls, rounds = (200, 3) if quick else (2000, 9)
    per_call = {n: [] for n in counts}
    # Interleaved rounds after a warm-up: the first timed loop of a process runs slower.
    for round_ in range(rounds + 1):
        for n, (model, _, x) in zip(counts, cases):
            u = np.zeros(model.n_inputs)
            start = time.perf_counter()
            for _ in range(calls):
                model.evaluate_raw(x, u, 0.0, outputs=False)
            if round_:
                per_call[n].append((time.perf_counter() - start) / calls)
    print("\n### Cost against node count (6 modes, free hub with one appendage)\n")
    print("| mass points | compile [s] | graph size | median f evaluation [us] |")
    print("|---|---|---|---|")
    for n, (model, compile_seconds, _) in zip(counts, cases):
        print(f"| {n} | {compile_seconds:.3f} | {model.graph_size} | {statistics.median(per_call[n]) * 1e6:.1f} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="2 and 4 modes, one repetition, a 10 s array manoeuvre with coarser segments")
    args = parser.parse_args(argv)
    print(f"linflex {linflex.__version__}; {time.strftime('%Y-%m-%d')}; BLAS threads pinned to 1\n")
    spinup_table(args.quick)
    arrays_table(args.quick)
    node_count_table(args.quick)


if __name__ == "__main__":
    main()
