"""A double pendulum: large-angle motion and its small-angle frequencies.

The scene ``double_pendulum.toml`` holds two 1 kg point masses on 1 m rods. The script
simulates 20 s of large-angle motion from the scene's initial angles (energy must stay
constant), then linearizes about the hanging equilibrium by central differences of the
compiled model: the squared frequencies are ``(2 -+ sqrt 2) g / l``.

``main()`` returns the relative energy drift of the simulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import linflex

SCENE = Path(__file__).with_name("double_pendulum.toml")


def main(plot: bool = False) -> float:
    model = linflex.compile_model(linflex.load_scene(SCENE))
    t = np.linspace(0.0, 20.0, 2001)
    response = linflex.simulate(model, t, rtol=1e-11, atol=1e-12)
    drift = float(np.max(np.abs(response.energy - response.energy[0])) / abs(response.energy[0]))
    h = 1e-6
    f = lambda x: model.evaluate(x)[0]  # noqa: E731
    A = np.column_stack([(f(h * e) - f(-h * e)) / (2 * h) for e in np.eye(4)])
    w2 = np.sort(-np.linalg.eigvals(A[2:, :2]).real)
    print(f"energy drift {drift:.1e}; omega^2 = {w2} vs {(2 - np.sqrt(2)) * 9.81:.6f}, {(2 + np.sqrt(2)) * 9.81:.6f}")
    if plot:
        fig = response.plot(["shoulder.angle", "elbow.angle"]).figure
        fig.savefig(Path.cwd() / "double_pendulum.png")
    return drift


if __name__ == "__main__":
    print(main(plot=True))
