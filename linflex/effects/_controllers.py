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

:func:`controller_chain` puts the controller's structural ``filters`` in series with that law on
every output channel and, for a sampled controller, discretizes the chain at ``sample_time``
(Tustin; a notch prewarped at its frequency; filters given in z as they are) with the
computational ``delay`` as the output delay. :func:`sampled_controller` is what the simulator
runs at the sample instants: that discrete chain with the controller's output stages
(saturation, rate limit, quantization) and measurement noise, which are nonlinear or random and
therefore absent from the linear chain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..scene._chains import filter_matrices, is_sampled
from ..system._errors import ModelError
from ..system._filters import lead_lag, low_pass, notch
from ..system._linear import LinearSystem
from ..system._sampling import discretize
from ..system._series import series

__all__ = ["SampledController", "controller_chain", "controller_reference", "controller_system", "sampled_controller"]


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
            k = A.shape[0]
            for key, matrix, shape in (("A", A, (k, k)), ("B", B_e, (k, n_in)), ("C", C, (n_out, k)),
                                       ("D", D_e, (n_out, n_in))):
                if matrix.shape != shape:
                    raise ModelError(f"{where}.{key}: has shape {matrix.shape} but {shape} was expected ({k} "
                                     f"controller states, {n_in} inputs, {n_out} outputs)")
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


def _filter_system(spec: dict, where: str, n_out: int, dt: float | None) -> LinearSystem:
    """One filter of a chain on every channel, in continuous time or discretized at ``dt``."""
    kind = spec.get("kind")
    args = {k: v for k, v in spec.items() if k not in ("kind", "domain")}
    try:
        if kind == "notch":
            f = notch(**args)
        elif kind == "low_pass":
            f = low_pass(**args)
        elif kind == "lead_lag":
            f = lead_lag(**args)
        elif kind in ("transfer_function", "state_space"):
            f = LinearSystem(*filter_matrices(spec), dt=dt if spec.get("domain", "s") == "z" else None)
        else:
            raise ModelError(f"unknown filter kind {kind!r} (notch, low_pass, lead_lag, transfer_function, "
                             "state_space)")
        if f.dt is None and spec.get("domain", "s") == "z":
            raise ModelError("a filter in z needs the controller's sample_time")
        nyquist = None if dt is None or kind != "notch" else np.pi / dt
        if dt is not None and f.dt is None and not (nyquist and float(spec["frequency"]) >= nyquist):
            f = discretize(f, dt, "tustin", prewarp=float(spec["frequency"]) if kind == "notch" else None)
    except (ModelError, TypeError, ValueError) as err:
        raise ModelError(f"{where}: {err}") from err
    if f.dt is None and nyquist:
        # A notch is prewarped at its frequency, which Tustin's map places only below the Nyquist
        # frequency: reported on the keys the user sets (as the scene validation does), not as
        # discretize's prewarp.
        w0 = float(spec["frequency"])
        raise ModelError(f"{where}.frequency: the notch at {spec['frequency']!r} rad/s is not below the Nyquist "
                         f"frequency pi/sample_time = {nyquist:.6g} rad/s of sample_time = {dt!r} s; lower the "
                         f"frequency or make sample_time shorter than pi/frequency = {np.pi / w0:.6g} s")
    if f.n_inputs == 1 and f.n_outputs == 1 and n_out > 1:
        eye = np.eye(n_out)
        f = LinearSystem(np.kron(eye, f.A), np.kron(eye, f.B), np.kron(eye, f.C), np.kron(eye, f.D), dt=f.dt)
    if f.n_inputs != n_out or f.n_outputs != n_out:
        raise ModelError(f"{where}: has {f.n_inputs} inputs and {f.n_outputs} outputs; a filter takes one (the "
                         f"same on every channel) or {n_out} (one per channel) of each")
    return f


def controller_chain(controller, *, delay: bool = True) -> LinearSystem:
    """The controller's linear chain: its law, then its ``filters`` in order, sampled if it is.

    Parameters
    ----------
    controller : Controller
        A scene's controller entry.
    delay : bool, optional
        Whether the computational ``delay`` [s] is the chain's ``output_delay`` (True, the
        default). A discrete :class:`LinearSystem` carries whole sampling periods of delay only;
        with ``delay=False`` the chain is returned without it, for a fractional delay to be put
        on the plant's input (``input_delay``) before the plant is discretized with the hold.

    Returns
    -------
    LinearSystem
        Inputs and outputs as :func:`controller_system` (command sign, deviations from the
        reference); states: the law's, then ``<name>.filter<k>.x<j>`` for filter ``k``.
        Without ``sample_time``: continuous time (the law and its filters in s). With it:
        ``dt = sample_time``, the continuous law and filters by Tustin's method (each notch
        prewarped at its frequency, so that its depth sits exactly at that frequency), filters
        given in z as they are, and ``output_delay = delay``. The output stages (saturation,
        rate limit, quantization) and the measurement noise are nonlinear or random: they are
        not part of the linear chain (the simulator applies them).

    Raises
    ------
    ModelError
        As :func:`controller_system`; for a filter that cannot be built (naming
        ``controllers['name'].filters[k]``); for a delay that is not a whole number of
        sampling periods while ``delay=True``.

    Examples
    --------
    A 10 Hz PD with a 20 dB notch at 10 rad/s: two discrete filter states, unit gain through
    the notch at DC.

    >>> from linflex import Controller, controller_chain
    >>> pd = Controller("pd", "pid", inputs="roll", rate_inputs="p", outputs="tx", kp=25.0, kd=70.0,
    ...                 sample_time=0.1, filters=[{"kind": "notch", "frequency": 10.0, "depth": 20.0, "width": 4.0}])
    >>> K = controller_chain(pd)
    >>> K.dt, K.states
    (0.1, ('pd.filter0.x0', 'pd.filter0.x1'))
    """
    law = controller_system(controller)
    where = f"controllers[{controller.name!r}]"
    dt = None
    if is_sampled(controller):
        try:
            dt = float(controller.sample_time)
        except (TypeError, ValueError) as err:
            raise ModelError(f"{where}.sample_time: expected a period [s], got {controller.sample_time!r}") from err
        if not (np.isfinite(dt) and dt > 0):
            raise ModelError(f"{where}.sample_time: must be positive and finite [s], got {controller.sample_time!r}")
        law = discretize(law, dt, "tustin")
    chain = law
    for k, spec in enumerate(controller.filters or ()):
        f = _filter_system(dict(spec), f"{where}.filters[{k}]", law.n_outputs, dt)
        f = f.with_(states=[f"{controller.name}.filter{k}.x{j}" for j in range(f.n_states)])
        chain = series(chain, f).with_(outputs=chain.outputs)
    tau = float(controller.delay or 0.0)
    if delay and tau:
        try:
            chain = chain.with_(output_delay=tau)
        except ModelError as err:
            raise ModelError(f"{where}.delay: {err}; controller_chain(..., delay=False) gives the chain without "
                             f"it (put the delay of {tau} s on the plant's input before its hold "
                             "discretization)") from err
    return chain


@dataclass(frozen=True)
class SampledController:
    """What the simulator runs for a sampled controller: its discrete chain and output stages.

    Attributes
    ----------
    name : str
        The controller's name.
    system : LinearSystem
        The discrete chain without the delay (:func:`controller_chain` with ``delay=False``):
        ``xc[k+1] = A xc[k] + B d[k]``, ``u[k] = C xc[k] + D d[k]``.
    reference : ndarray, shape (n_inputs,)
        Subtracted from the sampled measurements ``system.inputs`` (zeros for rate inputs)
        [sensor units].
    sample_time, delay : float
        Sampling period and computational delay [s].
    saturation, rate_limit, quantization : ndarray, shape (n_outputs,), or None
        The output stages [actuator units, actuator units/s, actuator units].
    noise : ndarray, shape (n_inputs,), or None
        Standard deviation of the measurement noise [sensor units].
    seed : int
        Seed of the noise generator.
    """

    name: str
    system: LinearSystem
    reference: Any
    sample_time: float
    delay: float
    saturation: Any = None
    rate_limit: Any = None
    quantization: Any = None
    noise: Any = None
    seed: int = 0

    def limited(self, command: NDArray[np.float64], previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """The held command after the output stages: saturation, rate limit, then quantization.

        Parameters
        ----------
        command : ndarray, shape (n_outputs,)
            The chain's output at a sample [actuator units].
        previous : ndarray, shape (n_outputs,)
            The command held before [actuator units].

        Returns
        -------
        ndarray, shape (n_outputs,)
            The command to hold [actuator units].
        """
        u = np.asarray(command, dtype=float)
        if self.saturation is not None:
            u = np.clip(u, -self.saturation, self.saturation)
        if self.rate_limit is not None:
            step = self.rate_limit * self.sample_time
            u = np.clip(u, previous - step, previous + step)
        if self.quantization is not None:
            u = self.quantization * np.round(u / self.quantization)
        return u


def sampled_controller(controller) -> SampledController:
    """The sampled controller the simulator runs (see :class:`SampledController`).

    Parameters
    ----------
    controller : Controller
        A scene's controller entry with a ``sample_time``.

    Returns
    -------
    SampledController
        The discrete chain and the output stages.

    Raises
    ------
    ModelError
        For a controller without ``sample_time``, or as :func:`controller_chain`.
    """
    if not is_sampled(controller):
        raise ModelError(f"controllers[{controller.name!r}]: not a sampled controller (no sample_time)")
    system = controller_chain(controller, delay=False)
    reference = np.zeros(system.n_inputs)
    reference[:len(_names(controller.inputs))] = controller_reference(controller)
    n_out, n_in = system.n_outputs, system.n_inputs

    def channels(value, n):
        return None if value is None else np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    return SampledController(
        name=controller.name, system=system, reference=reference, sample_time=float(controller.sample_time),
        delay=float(controller.delay or 0.0), saturation=channels(controller.saturation, n_out),
        rate_limit=channels(controller.rate_limit, n_out), quantization=channels(controller.quantization, n_out),
        noise=channels(controller.noise, n_in), seed=int(controller.seed),
    )
