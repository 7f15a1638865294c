"""Flexible bodies: accuracy against cost for the spin-up of a cantilever on a hub.

Issue 4's benchmark (Kane, Ryan and Banerjee 1987): a 10 m cantilever (EI = 1.4e4 N m^2,
EA = 2.8e7 N, 1.2 kg/m) on a hub spun up to 6 rad/s in 15 s, in-plane bending, 30 s simulated.
Reference: the rigid-segment model (reference notes section 9.1) with 10 segments (converged to
0.03 % of the peak against 20 segments). For 2, 4, 8 and 16 modes, with the motion-induced
geometric stiffness on and off: largest tip-deflection error relative to the reference's peak,
compile and simulation time.

Run: ``python benchmarks/flexible.py [--quick]``.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import linflex  # noqa: E402
from linflex import Beam, beam_modal_data  # noqa: E402

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


def modal_case(n_modes: int, geometric: bool, repeats: int):
    # EIy = 10 EI keeps the out-of-plane modes above the in-plane ones of interest.
    data = beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=EA, EIy=10 * EI, EIz=EI, GJ=1e4,
                                mass_per_length=MASS, elements=24), n_modes)
    scene = linflex.Scene(name="spinup", effects=("geometric_stiffness",) if geometric else (),
                          bodies=(HUB, linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
                          joints=(SPIN, linflex.Joint(name="clamp", type="fixed", parent="hub", child="beam")))
    start = time.perf_counter()
    model = linflex.compile_model(scene)
    compile_seconds = time.perf_counter() - start
    seconds, response = median_time(lambda: linflex.simulate(model, TIMEPTS, rtol=1e-8, atol=1e-10), repeats)
    _, tip, _ = data.node("0.end")
    return np.column_stack([response[f"beam.eta{k}"] for k in range(n_modes)]) @ tip[1], compile_seconds, seconds


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 and 4 modes, one repetition")
    args = parser.parse_args(argv)
    reference, reference_seconds = reference_tip()
    peak = float(np.max(np.abs(reference)))
    print(f"linflex {linflex.__version__}; {time.strftime('%Y-%m-%d')}; BLAS threads pinned to 1")
    print(f"reference: 10 rigid segments, peak in-plane tip deflection {peak:.4f} m, "
          f"simulated in {reference_seconds:.2f} s\n")
    print("| modes | geometric stiffness | max tip error / peak | compile [s] | simulate [s] |")
    print("|---|---|---|---|---|")
    for n_modes in (2, 4) if args.quick else (2, 4, 8, 16):
        for geometric in (True, False):
            tip, compile_seconds, seconds = modal_case(n_modes, geometric, 1 if args.quick else 3)
            error = float(np.max(np.abs(tip - reference))) / peak
            shown = f"{error:.2e}" if error < 1e3 else f"diverges ({error:.0e})"
            print(f"| {n_modes} | {'on' if geometric else 'off'} | {shown} | {compile_seconds:.3f} | {seconds:.3f} |")


if __name__ == "__main__":
    main()
