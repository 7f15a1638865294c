"""Thermal snap of a solar array: an internal load that rings the array and turns the hub.

The spacecraft of ``thermal_snap.toml`` floats free at rest. Its 6 m array carries a thermal
bending moment of 0.8 N m (a temperature difference across it in sunlight) that the array's
static bend balances at the start; entering eclipse at t = 20 s, the moment vanishes within 2 s
(a ``transition`` profile of the ``thermal`` load's ``scale``): thermal snap. The array springs
back and rings at its first bending frequency, and the hub counter-rotates: the thermal moment is
internal, so the total angular momentum stays zero. A slow thermal bending over the orbit adds a
sine at the orbital rate.

The array starts in the static bend of the initial moment (modal coordinates ``K^-1 g`` of its
6 kept modes), the hub at rest. ``main()`` returns ``(ratio, momentum, turn)``: that initial tip
deflection over the cantilever's closed form ``M L^2 / (2 EI)`` (1 within the truncation to 6
modes, about 1.5 %), the largest total angular momentum over the largest angular momentum of the
hub alone (zero up to the integrator's tolerance), and the hub's largest rate [rad/s].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import linflex

SCENE = Path(__file__).with_name("thermal_snap.toml")


def main(plot: bool = False) -> tuple[float, float, float]:
    scene = linflex.load_scene(SCENE)
    model = linflex.compile_model(scene)
    array, snap = scene.bodies[1], scene.thermal[0]
    data = array.resolved_modal_data()
    Psi = data.node(snap.node)[2]
    # The static bend of the initial moment (clamped modes: K = diag(w^2), unit modal masses).
    x0 = np.array(model.x0, dtype=float)
    eta = (Psi.T @ np.asarray(snap.moment)) / data.frequencies**2
    for k, value in enumerate(eta):
        x0[model.states.index(f"array.eta{k}")] = value
    t = np.linspace(0.0, 60.0, 1201)
    response = linflex.simulate(model, t, x0=x0, rtol=1e-10, atol=1e-12)
    tip = response.y[:, response.outputs.index("tip.z")]
    M, L, EI = snap.moment[0], array.beam["length"], array.beam["EI"]
    static = M * L**2 / (2 * EI)
    ratio = float(tip[0] / static)  # a moment about +x bends the array (along +y) towards +z
    rate = response.y[:, [response.outputs.index(f"gyro.{c}") for c in "xyz"]]
    hub = np.asarray(scene.bodies[0].inertia, dtype=float) * rate
    momentum = float(np.max(np.linalg.norm(response.momentum, axis=1)) / np.max(np.linalg.norm(hub, axis=1)))
    turn = float(np.max(np.linalg.norm(rate, axis=1)))
    print(f"initial tip deflection {tip[0] * 1e3:.3f} mm = {ratio:.4f} M L^2/(2 EI); "
          f"hub rate up to {turn:.2e} rad/s; |H| / |H_hub| <= {momentum:.1e}")
    if plot:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots()
        ax.plot(t, tip * 1e3)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("array tip deflection [mm]")
        fig.savefig(Path.cwd() / "thermal_snap.png")
    return ratio, momentum, turn


if __name__ == "__main__":
    print(main(plot=True))
