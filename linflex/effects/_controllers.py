"""A scene's controllers as linear systems from measured signals to actuator commands.

One place turns a :class:`~linflex.Controller` entry (``pid``, ``state_space`` or
``transfer_function``) into state-space form. The law a scene states is
``u = K(e, r)`` with the error ``e = reference - y`` on the ``inputs`` and the measured rates
``r`` of ``rate_inputs`` (PID derivative action on the measurement). As a function of what the
sensors measure, with ``d = y - reference``::

    xc' = A xc + B_d d             B_d = -B_e
    u   = C xc + D_d d + D_r r     D_d = -D_e,  D_r = -kd (PID)

:func:`controller_system` returns that system, inputs named by the sensors (``inputs`` then
``rate_inputs``) and outputs by the actuators; its reference is :func:`controller_reference`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..system._errors import ModelError
from ..system._linear import LinearSystem

__all__ = ["controller_reference", "controller_system"]


def _names(value) -> list[str]:
    if value is None:
        return []
    return [value] if isinstance(value, str) else list(value)


def controller_reference(controller) -> NDArray[np.float64]:
    """The reference of each of the controller's ``inputs`` (zeros when none is given).

    Parameters
    ----------
    controller : Controller
        A scene's controller entry.

    Returns
    -------
    ndarray, shape (n_inputs,)
        The reference of each input, in that sensor's units ([rad], [rad/s], [m], ...).

    Examples
    --------
    >>> from linflex import load_scene, controller_reference
    >>> scene = load_scene("examples/attitude_control.toml")
    >>> controller_reference(scene.controllers[0]).tolist()
    [0.05, -0.03, 0.02]
    """
    n = len(_names(controller.inputs))
    if controller.reference is None:
        return np.zeros(n)
    try:
        return np.broadcast_to(np.asarray(controller.reference, dtype=float), (n,)).copy()
    except ValueError as err:
        raise ModelError(f"controllers[{controller.name!r}].reference: {err}") from err


def controller_system(controller) -> LinearSystem:
    """The controller as ``u = K(y - reference, r)``: a :class:`LinearSystem` in command sign.

    Parameters
    ----------
    controller : Controller
        A scene's controller entry.

    Returns
    -------
    LinearSystem
        Inputs: the sensors of ``inputs`` (as deviations from their reference) then those of
        ``rate_inputs``; outputs: the actuators of ``outputs``; states ``<name>.x<k>`` (PID:
        one integrator per channel when any ``ki`` is non-zero). For a negative-feedback
        :class:`linflex.frequency.Loop`, negate its ``C`` and ``D``.

    Raises
    ------
    ModelError
        For an unknown type or coefficient shapes that do not match the channels.

    Examples
    --------
    A PD on two channels: the feedthrough from the angles is ``-kp`` and from the rates ``-kd``
    (``u = kp (reference - y) - kd r``):

    >>> from linflex import Controller, controller_system
    >>> pd = Controller("pd", "pid", inputs=["roll", "pitch"], rate_inputs=["p", "q"], outputs=["tx", "ty"],
    ...                 kp=[25.0, 30.0], kd=[70.0, 84.0])
    >>> sys = controller_system(pd)
    >>> sys.inputs, sys.outputs, sys.A.shape
    (('roll', 'pitch', 'p', 'q'), ('tx', 'ty'), (0, 0))
    >>> float(sys.D[0, 0]), float(sys.D[0, 2])
    (-25.0, -70.0)
    """
    ins, outs, rates = _names(controller.inputs), _names(controller.outputs), _names(controller.rate_inputs)
    n_in, n_out = len(ins), len(outs)
    where = f"controllers[{controller.name!r}]"
    if controller.type == "pid":
        if n_in != n_out:
            raise ModelError(f"{where}: a pid controller needs as many outputs as inputs ({n_out} != {n_in})")
        try:
            kp, ki, kd = (np.broadcast_to(np.asarray(g, dtype=float), (n_in,)) for g in
                          (controller.kp, controller.ki, controller.kd))
        except ValueError as err:
            raise ModelError(f"{where}: gains must be scalars or one per channel ({n_in}): {err}") from err
        if np.any(kd) and len(rates) != n_in:
            raise ModelError(f"{where}.rate_inputs: derivative gains need one rate sensor per channel "
                             f"({n_in}), got {len(rates)}")
        integrating = np.flatnonzero(ki)
        k = integrating.size
        A = np.zeros((k, k))
        B_e = np.eye(n_in)[integrating]
        C = np.zeros((n_out, k))
        C[integrating, np.arange(k)] = ki[integrating]
        D_e = np.diag(kp)
        D_r = -np.diag(kd) if np.any(kd) else np.zeros((n_out, 0))
        rates = rates if np.any(kd) else []
    elif controller.type in ("state_space", "transfer_function"):
        if controller.type == "state_space":
            try:
                A, B_e, C = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (controller.A, controller.B, controller.C))
            except (TypeError, ValueError) as err:
                raise ModelError(f"{where}: A, B, C must be numeric matrices: {err}") from err
            D_e = np.zeros((C.shape[0], B_e.shape[1])) if controller.D is None else np.atleast_2d(
                np.asarray(controller.D, dtype=float))
        else:
            from scipy import signal

            try:
                a1, b1, c1, d1 = signal.tf2ss(np.asarray(controller.num, dtype=float),
                                              np.asarray(controller.den, dtype=float))
            except (TypeError, ValueError) as err:
                raise ModelError(f"{where}: num/den: {err}") from err
            if n_in != n_out:
                raise ModelError(f"{where}: a transfer_function controller acts per channel: "
                                 f"{n_out} outputs for {n_in} inputs")
            eye = np.eye(n_in)
            A, B_e, C, D_e = np.kron(eye, a1), np.kron(eye, b1), np.kron(eye, c1), np.kron(eye, d1)
        if B_e.shape[1] != n_in or C.shape[0] != n_out:
            raise ModelError(f"{where}: B has {B_e.shape[1]} columns and C {C.shape[0]} rows for "
                             f"{n_in} inputs and {n_out} outputs")
        D_r = np.zeros((n_out, 0))
        rates = []
    else:
        raise ModelError(f"{where}.type: unknown controller type {controller.type!r} "
                         "(pid, state_space, transfer_function)")
    return LinearSystem(
        A, np.hstack([-B_e, np.zeros((A.shape[0], len(rates)))]), C, np.hstack([-D_e, D_r]),
        states=[f"{controller.name}.x{k}" for k in range(A.shape[0])],
        inputs=ins + rates, outputs=outs,
    )
