"""Rigid-body design: the inertia a loop sees at low frequency, and PD/PID gains from a bandwidth.

Below its flexible modes a spacecraft's attitude loop is a double integrator ``theta = u / (J s^2)``
per axis, where ``J`` is the inertia of the whole vehicle (hub, appendages and wheels moving as
one). :func:`rigid_inertia` reads that ``J`` exactly from a linear plant (the coefficient of
``1/s^2`` of its transfer matrix at the origin, from the rigid-body block of an ordered Schur
form); :func:`pid_from_bandwidth` places the closed-loop poles of ``J s^2 + kd s + kp`` (and an
integrator's real pole) at a chosen natural frequency and damping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex.frequency._spectrum import classify
from linflex.system import ModelError, as_linear_system, check_positive, frozen_array

__all__ = ["PIDGains", "RigidInertia", "pid_from_bandwidth", "rigid_inertia"]


@dataclass(frozen=True)
class RigidInertia:
    """The inertia a set of loops sees below its flexible modes (result of :func:`rigid_inertia`).

    Attributes
    ----------
    matrix : ndarray, shape (n_channels, n_channels)
        ``J`` such that the plant's transfer matrix is ``J^-1 / s^2 + O(1/s)`` at the origin, in
        actuator units per sensor acceleration (``kg m^2`` for torque [N m] to angle [rad]);
        signed: negative where a positive command turns the sensed angle negative (a wheel
        motor's reaction torque on the hub).
    axes : ndarray, shape (n_channels,)
        Its diagonal: the inertia of each channel alone [kg m^2 for torque to angle].
    inputs, outputs : tuple of str
        The channels: actuators (plant inputs) and sensors (plant outputs), paired in order.
    n_rigid : int
        Number of rigid-body (zero) eigenvalues of the plant (spectrum policy).
    error_estimate : float
        A posteriori relative error of ``matrix`` [-]: the relative residual of the Sylvester
        equation that separates the rigid block, times the condition of the separation.
    """

    matrix: NDArray[np.float64]
    axes: NDArray[np.float64]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    n_rigid: int
    error_estimate: float


def rigid_inertia(plant, *, inputs=None, outputs=None, rigid_tol: float | None = None) -> RigidInertia:
    """The low-frequency (rigid-body) inertia of the loops from ``inputs`` to ``outputs``.

    Parameters
    ----------
    plant : LinearSystem or any system :func:`linflex.as_linear_system` takes
        The linearized plant, continuous time, from actuator commands to attitude sensors.
    inputs, outputs : sequence of str or int, optional
        The actuators and the attitude sensors (angles), paired in order; default all.
    rigid_tol : float, optional
        Radius [1/s] under which an eigenvalue is a rigid-body one; default the spectrum policy
        of ``frequency/_spectrum.py`` (round-off of a Jordan block at the origin).

    Returns
    -------
    RigidInertia
        ``J`` with ``G(s) = J^-1 / s^2 + O(1/s)``: the vehicle's whole inertia about the sensed
        axes, appendages included (they follow the hub rigidly below their modes).

    Raises
    ------
    ModelError
        If the channels are not square, the plant has no rigid-body double integrator on them
        (``lim s^2 G(s)`` singular), or the plant is discrete or delayed.

    Examples
    --------
    Two axes of inertia 800 and 600 kg m^2, the second driven by a wheel's reaction:

    >>> from linflex import LinearSystem
    >>> plant = LinearSystem([[0, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 0], [0, 0, 0, 0]],
    ...                      [[0, 0], [0, 0], [1 / 800, 0], [0, -1 / 600]], [[1, 0, 0, 0], [0, 1, 0, 0]])
    >>> rigid_inertia(plant).axes.round(6).tolist()
    [800.0, -600.0]
    """
    sys = as_linear_system(plant, "plant").subsystem(inputs=inputs, outputs=outputs)
    if sys.n_inputs != sys.n_outputs or sys.n_inputs == 0:
        raise ModelError(f"rigid_inertia: pair each actuator with one sensor; got {sys.n_inputs} inputs "
                         f"and {sys.n_outputs} outputs")
    spec = classify(sys.A, rigid_tol, B=sys.B, C=sys.C)
    radius = max(spec.rigid_radius, float(np.abs(spec.poles[spec.rigid]).max(initial=0.0)))
    T, Z, k = scipy.linalg.schur(sys.A, output="real", sort=lambda re, im: np.hypot(re, im) <= radius)
    if k == 0:
        raise ModelError("rigid_inertia: the plant has no rigid-body (zero) eigenvalue: its loops are not "
                         "double integrators at low frequency")
    T11, T12, T22 = T[:k, :k], T[:k, k:], T[k:, k:]
    # Decouple the rigid block: T11 X - X T22 = -T12, so that [[I, X], [0, I]] block-diagonalizes T.
    X = scipy.linalg.solve_sylvester(T11, -T22, -T12) if T22.size else np.zeros((k, 0))
    ZB, CZ = Z.T @ sys.B, sys.C @ Z
    Br = ZB[:k] - X @ ZB[k:]
    Cr = CZ[:, :k]
    inverse = Cr @ T11 @ Br            # the coefficient of 1/s^2 of Cr (sI - T11)^-1 Br
    scale = np.linalg.norm(Cr, 2) * np.linalg.norm(T11, 2) * np.linalg.norm(Br, 2)
    if np.linalg.matrix_rank(inverse, tol=1e-10 * max(scale, 1e-300)) < sys.n_inputs:
        raise ModelError(
            f"rigid_inertia: lim s^2 G(s) is singular on the channels {list(sys.inputs)} -> {list(sys.outputs)}: "
            "some loop has no rigid-body double integrator (is each sensor an angle driven by its actuator?)"
        )
    J = np.linalg.inv(inverse)
    residual = np.linalg.norm(T11 @ X - X @ T22 + T12) / max(np.linalg.norm(T12), np.linalg.norm(T11), 1e-300)
    separation = 1.0 + np.linalg.norm(X, 2)
    error = float(residual * separation**2 * np.linalg.cond(inverse) + np.finfo(float).eps * separation)
    return RigidInertia(frozen_array(J), frozen_array(np.diag(J).copy()), sys.inputs, sys.outputs, int(k), error)


@dataclass(frozen=True)
class PIDGains:
    """PD or PID gains per axis from :func:`pid_from_bandwidth`.

    Attributes
    ----------
    kp : ndarray
        Proportional gains [actuator units per sensor unit, N m/rad for torque and angle].
    kd : ndarray
        Derivative gains [N m s/rad], on the measured rate.
    ki : ndarray
        Integral gains [N m/(rad s)]; zeros for a PD.
    bandwidth : float
        The closed-loop natural frequency placed [rad/s].
    damping : float
        The closed-loop damping ratio placed [-].
    """

    kp: NDArray[np.float64]
    kd: NDArray[np.float64]
    ki: NDArray[np.float64]
    bandwidth: float
    damping: float

    def controller(self, name: str, *, inputs, outputs, rate_inputs, **fields):
        """These gains as a scene's PID :class:`~linflex.Controller` entry.

        Parameters
        ----------
        name : str
            The entry's name.
        inputs, outputs, rate_inputs : sequence of str
            Angle sensors, actuators and rate sensors, one per axis.
        **fields
            Other :class:`~linflex.Controller` fields (``reference``, ``sample_time``...).

        Returns
        -------
        Controller
            ``type = "pid"`` with ``kp``, ``kd``, ``ki`` of this design.

        Raises
        ------
        ModelError
            If ``inputs``, ``outputs`` or ``rate_inputs`` does not name one signal per axis.
        """
        from linflex.scene import Controller

        channels = {}
        for label, names in (("inputs", inputs), ("outputs", outputs), ("rate_inputs", rate_inputs)):
            names = [names] if isinstance(names, str) else list(names)   # list("roll") would be four names
            if len(names) != self.kp.size:
                raise ModelError(f"{label} must name one signal per axis ({self.kp.size}), got {names}")
            channels[label] = names
        return Controller(name, "pid", **channels, kp=self.kp.tolist(), kd=self.kd.tolist(), ki=self.ki.tolist(),
                          **fields)


def pid_from_bandwidth(inertia, bandwidth: float, damping: float = 0.7, *,
                       integral_ratio: float | None = None) -> PIDGains:
    """PD (or PID) gains that place the rigid-body closed loop at ``bandwidth`` and ``damping``.

    Per axis of inertia ``J``: the PD closed loop ``J s^2 + kd s + kp`` has the poles
    ``s^2 + 2 z w s + w^2`` with ``kp = J w^2`` and ``kd = 2 z w J``. With an integrator, the
    third pole is real at ``-a`` with ``a = integral_ratio w``: ``kp = J w^2 (1 + 2 z a/w)``,
    ``kd = J (2 z w + a)``, ``ki = J a w^2``.

    Parameters
    ----------
    inertia : float, array_like, RigidInertia or a plant
        Inertia of each axis [kg m^2] (signed, as :func:`rigid_inertia` returns it; a
        :class:`RigidInertia` gives its ``axes``; a plant, any system :func:`rigid_inertia`
        takes, gives those of :func:`rigid_inertia` with its defaults).
    bandwidth : float
        Closed-loop natural frequency ``w`` [rad/s].
    damping : float, optional
        Closed-loop damping ratio ``z`` [-], 0.7 by default.
    integral_ratio : float, optional
        ``a / w`` [-] of the integrator's pole for a PID; None for a PD.

    Returns
    -------
    PIDGains
        One gain per axis, in the sign of the inertia.

    Raises
    ------
    ModelError
        For a non-positive bandwidth, damping or integral ratio, or a zero inertia.

    Examples
    --------
    The example spacecraft's axes (``examples/spacecraft_arrays.toml``: wheels, so negative
    inertias) at 0.3 rad/s and damping 0.7:

    >>> g = pid_from_bandwidth([-3227.0, -604.0, -3327.0], 0.3)
    >>> g.kp.round(1).tolist(), g.kd.round(1).tolist()
    ([-290.4, -54.4, -299.4], [-1355.3, -253.7, -1397.3])
    """
    if not isinstance(inertia, RigidInertia):
        try:
            np.asarray(inertia, dtype=float)
        except (TypeError, ValueError):
            try:
                plant = as_linear_system(inertia, "inertia")
            except ModelError:
                raise ModelError("inertia must be a number per axis [kg m^2], a RigidInertia or a plant (a linear "
                                 f"system), got {type(inertia).__name__}") from None
            inertia = rigid_inertia(plant)   # a plant: the inertia of its rigid-body loops
    J = np.atleast_1d(np.asarray(inertia.axes if isinstance(inertia, RigidInertia) else inertia, dtype=float))
    if J.ndim != 1 or J.size == 0 or not np.all(np.isfinite(J)) or np.any(J == 0):
        raise ModelError(f"inertia must be finite and non-zero per axis [kg m^2], one axis at least, got {J.tolist()}")
    values = {"bandwidth": bandwidth, "damping": damping}
    if integral_ratio is not None:
        values["integral_ratio"] = integral_ratio
    for label, value in values.items():
        check_positive(value, label)
    w, z = float(bandwidth), float(damping)
    a = 0.0 if integral_ratio is None else float(integral_ratio) * w
    kp = J * w * w * (1.0 + 2.0 * z * a / w)
    kd = J * (2.0 * z * w + a)
    ki = J * a * w * w
    return PIDGains(frozen_array(kp), frozen_array(kd), frozen_array(ki), w, z)
