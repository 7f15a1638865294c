"""The benchmark bicycle: self-stability against forward speed, from a scene with rolling wheels.

The scene ``bicycle.toml`` is Whipple's bicycle with the parameters of the benchmark of Meijaard,
Papadopoulos, Ruina and Schwab (2007, Proc. R. Soc. A 463:1955-1982, Table 1): four rigid bodies
(rear frame with rider, rear wheel, front frame, front wheel), a free joint, three hinges and two
``rolling`` constraints (knife-edge wheels: one holonomic and two non-holonomic rows each). The
model knows nothing of bicycles: the constraints add undetermined multipliers to Kane's
equations of the tree, and :func:`linflex.linearize.constrained_linearization` restricts the
linearization to the independent coordinates and speeds (lean, steer and the rear wheel's rate
among them).

Steady upright straight-ahead running at speed ``v`` is the same state for every ``v`` with the
speeds scaled, so the model is compiled once and linearized at each speed. The lean and steer
dynamics are the block of the independent lean (the rear frame's quaternion ``qx``, half the
lean angle), steer angle, lean rate (``wx``) and steer rate: by symmetry nothing else enters
them (``lean_steer_eigenvalues`` checks that the rest of their rows is zero). The
eigenvalues against speed are the paper's Figure 3 and Table 2; the weave speed (the weave
pair's real part crosses zero) and the capsize speed (the capsize eigenvalue crosses zero)
bound the self-stable range.

``main()`` returns ``(weave speed, capsize speed)`` [m/s].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.optimize

import linflex
from linflex.linearize import constrained_linearization

SCENE = Path(__file__).with_name("bicycle.toml")
#: The independent states: positions, heading (``qz``), lean (``qx``), the wheels' angles,
#: steer, and the three independent speeds (lean rate, steer rate, the rear wheel's rate).
INDEPENDENT = ["frame.x", "frame.y", "frame.qw", "frame.qx", "frame.qz", "rear_hub.angle", "steer.angle",
               "front_hub.angle", "frame.wx", "steer.rate", "rear_hub.rate"]
LEAN_STEER = ["frame.qx", "steer.angle", "frame.wx", "steer.rate"]


def compile_bicycle(formulation: str = "dense") -> linflex.Model:
    """The compiled scene (its initial state runs at 5 m/s)."""
    return linflex.compile_model(linflex.load_scene(SCENE), formulation=formulation)


def operating_point(model: linflex.Model, v: float) -> linflex.OperatingPoint:
    """Upright straight-ahead running at ``v`` [m/s]: the initial state with every speed scaled."""
    x = np.array(model.x0, float)
    nq = model.constraints.n_coordinates
    x[nq:] *= v / x[model.states.index("frame.vx")]
    return linflex.OperatingPoint(x, np.zeros(model.n_inputs), 0.0)


def lean_steer_eigenvalues(model: linflex.Model, v: float, method: str = "kane") -> np.ndarray:
    """The four eigenvalues [1/s] of the lean and steer dynamics at ``v`` [m/s], sorted.

    Raises AssertionError when the lean and steer rows depend on any other independent state
    beyond round-off (the block would not hold the whole dynamics).
    """
    lin = constrained_linearization(model, operating_point(model, v), method=method, allow_non_equilibrium=True,
                                    independent=INDEPENDENT)
    names = list(lin.sys.states)
    rows = [names.index(n) for n in LEAN_STEER]
    rest = [k for k in range(len(names)) if k not in rows]
    A = lin.sys.A
    coupling = float(np.max(np.abs(A[np.ix_(rows, rest)])))
    assert coupling <= 1e-9 * max(1.0, float(np.max(np.abs(A)))), f"lean/steer coupled to the rest: {coupling}"
    return np.sort_complex(np.linalg.eigvals(A[np.ix_(rows, rows)]))


def critical_speeds(model: linflex.Model, method: str = "kane") -> tuple[float, float]:
    """The weave and capsize speeds [m/s]: where the largest real part crosses zero in
    [4, 4.6] (the weave pair) and in [5.5, 6.5] m/s (the capsize eigenvalue)."""
    def growth(v: float) -> float:
        return float(np.max(lean_steer_eigenvalues(model, v, method).real))

    return tuple(scipy.optimize.brentq(growth, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
                 for lo, hi in ((4.0, 4.6), (5.5, 6.5)))


def main() -> tuple[float, float]:
    model = compile_bicycle()
    for v in range(0, 11):
        ev = lean_steer_eigenvalues(model, float(v))
        print(f"v = {v:4.1f} m/s: " + "  ".join(f"{e.real:+.6f}{e.imag:+.6f}i" for e in ev))
    weave, capsize = critical_speeds(model)
    print(f"self-stable from the weave speed {weave:.8f} m/s to the capsize speed {capsize:.8f} m/s")
    return weave, capsize


if __name__ == "__main__":
    main()
