"""Reorienting a spinning gyrostat by spinning up one wheel (Banerjee's reorientation manoeuvre).

The spacecraft of ``gyrostat.toml`` spins at 5 rpm about its major axis x. Its three reaction
wheels are at rest; a fuel-slosh pendulum and a nutation damper dissipate energy. The motor of
the wheel on the minor axis z applies a constant torque for 300 s, until that wheel holds the
whole angular momentum H. Angular momentum is conserved (the motor torque is internal), so the
body turns until its minor axis points along H: the spin ends about the minimum-inertia axis.

``main()`` returns the final angle [deg] between the body's z axis and the angular momentum.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import linflex

SCENE = Path(__file__).with_name("gyrostat.toml")


def body_z_in_inertial(q: np.ndarray) -> np.ndarray:
    """Third column of the rotation matrix of the unit quaternion q = [w, x, y, z]."""
    w, x, y, z = q
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), w * w - x * x - y * y + z * z])


def main(plot: bool = False) -> float:
    model = linflex.compile_model(linflex.load_scene(SCENE))
    H0 = float(np.linalg.norm(np.asarray(model.momentum(model.x0, 0.0), dtype=float)))  # |H| [N m s]
    spin_up = 300.0
    t = np.linspace(0.0, 900.0, 1801)
    response = linflex.simulate(
        model, t, inputs={"motor_z": lambda s: H0 / spin_up if s < spin_up else 0.0}, rtol=1e-9, atol=1e-11)
    H = response.momentum
    z_axis = np.array([body_z_in_inertial(q) for q in response.x[:, :4]])
    cosine = np.sum(z_axis * H, axis=1) / np.linalg.norm(H, axis=1)
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    drift = np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0])
    print(f"angle between z and H: {angle[0]:.1f} deg -> {angle[-1]:.2f} deg; momentum drift {drift:.1e}")
    if plot:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots()
        ax.plot(t, angle)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("angle between z and H [deg]")
        fig.savefig(Path.cwd() / "gyrostat.png")
    return float(angle[-1])


if __name__ == "__main__":
    print(main(plot=True))
