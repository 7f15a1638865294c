"""Gravity-gradient pitch libration of a rigid satellite in LVLH.

The satellite of ``satellite_lvlh.toml`` starts 2 deg off nadir in pitch. The gravity-gradient
torque makes it librate about nadir with the frequency ``n sqrt(3 (Ix - Iz) / Iy)`` (``n`` the
orbital rate). The script simulates two orbits, measures the libration period from the zero
crossings of the pitch sensor, and also linearizes the model about nadir pointing.

``main()`` returns the measured pitch frequency divided by the textbook one (1 when right).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import linflex

SCENE = Path(__file__).with_name("satellite_lvlh.toml")


def main(plot: bool = False) -> float:
    scene = linflex.load_scene(SCENE)
    model = linflex.compile_model(scene)
    n = scene.orbit.mean_motion
    Ix, Iy, Iz = 900.0, 1100.0, 400.0
    expected = n * np.sqrt(3 * (Ix - Iz) / Iy)
    t = np.linspace(0.0, 2 * 2 * np.pi / n, 4001)
    response = linflex.simulate(model, t, rtol=1e-10, atol=1e-12)
    pitch = response["pitch"]
    crossings = t[:-1][(pitch[:-1] > 0) & (pitch[1:] <= 0)]
    measured = 2 * np.pi / np.mean(np.diff(crossings))
    print(f"pitch libration: {measured:.6e} rad/s, textbook {expected:.6e} rad/s")
    if plot:
        fig = response.plot(["pitch"]).figure
        fig.savefig(Path.cwd() / "satellite_lvlh.png")
    return float(measured / expected)


if __name__ == "__main__":
    print(main(plot=True))
