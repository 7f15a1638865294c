"""Scene entries, part three: wheels, surfaces, sensors, actuators, disturbances and controllers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._chains import check_chain
from ._entries import ACTUATOR_TYPES, CONTROLLER_TYPES, PROFILES, SENSOR_TYPES, _Entry
from ._joints import _profile_problems as profile_problems
from ._problems import Problems, SceneContext, hint, is_numeric
from ._values import profile_function


def sensor_width(sensor) -> int:
    """Number of output signals of a sensor (1 with an axis or for wheel speeds, else 3)."""
    return 1 if sensor.type == "wheel_speed" or sensor.axis is not None else 3


def actuator_width(actuator) -> int:
    """Number of command signals of an actuator (or of a disturbance)."""
    return 1 if actuator.type == "wheel_torque" or actuator.axis is not None else 3


@dataclass(frozen=True)
class Wheel(_Entry):
    """A momentum wheel on ``body`` spinning about ``axis`` (body axes).

    ``spin_inertia`` and ``transverse_inertia`` [kg m^2] about the wheel's centre, ``mass``
    [kg] at ``point`` [m]. ``mode="constant"`` keeps the relative ``speed`` [rad/s];
    ``mode="torque"`` makes the speed a state driven by a ``wheel_torque`` actuator (``speed``
    is then its initial value). Gyroscopic coupling needs the ``wheel_gyroscopics`` effect;
    without it the wheel is a locked rigid part of its body.

    On a flexible body without ``node`` the wheel sits on the body's rigid part (its frame, at
    ``point``). With ``node``, naming a node of its modal data, the wheel sits there: its mass
    moves with the node (translation ``Phi q``) and its spin axis turns with the node's small
    rotation (``Psi q``), so its gyroscopic torque couples into the modes; ``axis`` is in body
    axes (the node axes when undeformed) and ``point`` is then unused. The wheel's mass is not
    part of the modal data: its inertia loads are not in the ``geometric_stiffness`` matrices
    (add it to the modal data, for example with :class:`linflex.PointMassAt`, when they matter).

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    body : str
        The body carrying the wheel.
    spin_inertia : float
        Moment of inertia about the spin axis [kg m^2].
    axis : array_like of 3 floats
        Spin axis in body axes [-] (normalized).
    transverse_inertia : float
        Moment of inertia about a transverse axis through its centre [kg m^2].
    mass : float
        Mass [kg].
    point : array_like of 3 floats
        Centre in body axes [m] (unused with ``node``).
    mode : str
        How the spin is driven: ``"constant"`` holds the relative ``speed``; ``"torque"`` makes
        the speed a state driven by a ``wheel_torque`` actuator.
    speed : float
        Spin rate relative to the body [rad/s] (the initial value in ``torque`` mode).
    node : str, optional
        A node of the body's modal data the wheel sits at.

    Examples
    --------
    >>> from linflex import Wheel
    >>> Wheel("rw1", "hub", spin_inertia=0.05, axis=(1, 0, 0), mode="torque").mode
    'torque'
    """

    name: str
    body: str
    spin_inertia: float
    axis: Any = (0.0, 0.0, 1.0)
    transverse_inertia: float = 0.0
    mass: float = 0.0
    point: Any = (0.0, 0.0, 0.0)
    mode: str = "constant"
    speed: float = 0.0
    node: str | None = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.spin_inertia, f"{path}.spin_inertia", "kg m^2", nonnegative=True, kind="inertia")
        out.number(self.transverse_inertia, f"{path}.transverse_inertia", "kg m^2", nonnegative=True, kind="inertia")
        out.number(self.mass, f"{path}.mass", "kg", nonnegative=True, kind="mass")
        out.number(self.speed, f"{path}.speed", "rad/s", kind="rate")
        out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.inapplicable(self, "point", path, self.node is None, "a wheel at a node sits there")
        out.choice(self.mode, f"{path}.mode", ("constant", "torque"), "wheel mode")
        if self.mode == "torque" and context.lacks("wheel_gyroscopics"):
            out.add(f"{path}.mode", "a torque-driven wheel needs the 'wheel_gyroscopics' effect (add it to effects)")
        context.check_node(out, f"{path}.node", self.body, self.node)


@dataclass(frozen=True)
class Surface(_Entry):
    """A flat plate of ``area`` [m^2] on ``body`` with outward ``normal`` and centre of pressure
    ``point`` (body axes), ``reflectivity`` (specular fraction, 0..1) for ``solar_pressure`` and
    ``drag_coefficient`` for ``aerodynamic_drag``.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    body : str
        The body carrying the plate.
    area : float
        Plate area [m^2].
    normal : array_like of 3 floats
        Outward normal in body axes [-] (normalized).
    point : array_like of 3 floats
        Centre of pressure in body axes [m].
    reflectivity : float
        Specular fraction of the reflected sunlight [-], 0..1.
    drag_coefficient : float
        Aerodynamic drag coefficient [-] (2.2 is the usual free-molecular value).

    Examples
    --------
    >>> from linflex import Surface
    >>> Surface("panel", "hub", area=4.0, normal=(0, 0, 1), reflectivity=0.3).area
    4.0
    """

    name: str
    body: str
    area: float
    normal: Any = (1.0, 0.0, 0.0)
    point: Any = (0.0, 0.0, 0.0)
    reflectivity: float = 0.0
    drag_coefficient: float = 2.2

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.area, f"{path}.area", "m^2", positive=True)
        out.vector(self.normal, f"{path}.normal", "-", nonzero=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        if out.number(self.reflectivity, f"{path}.reflectivity", "-", nonnegative=True) and self.reflectivity > 1:
            out.add(f"{path}.reflectivity", f"must lie in [0, 1], got {self.reflectivity}")
        out.number(self.drag_coefficient, f"{path}.drag_coefficient", "-", nonnegative=True)


@dataclass(frozen=True)
class Sensor(_Entry):
    """A sensor on ``body`` (or on ``wheel`` for ``wheel_speed``).

    ``attitude``: the small-angle attitude of the body relative to the scene frame,
    ``vee((C - C^T)/2)`` [rad]; ``rate``: inertial angular velocity in body axes [rad/s]
    (relative to the scene frame with ``relative = true``); ``position``, ``velocity``: of
    ``point`` relative to the scene frame in scene axes [m, m/s]; ``acceleration``: inertial
    acceleration of ``point`` in body axes [m/s^2]; ``wheel_speed`` [rad/s]. With ``axis`` the
    sensor has one output (the projection), otherwise three (``name.x``, ``.y``, ``.z``).
    On a flexible body, ``node`` names a node of its modal data: the sensor then moves with the
    structure there (translation ``Phi q``, small rotation ``Psi q``) and ``point`` is unused.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    type : str
        What it measures: ``"attitude"`` [rad], ``"rate"`` [rad/s], ``"position"`` [m],
        ``"velocity"`` [m/s], ``"acceleration"`` [m/s^2] or ``"wheel_speed"`` [rad/s].
    body : str, optional
        The body it is on (all types but ``wheel_speed``).
    wheel : str, optional
        The wheel of a ``wheel_speed`` sensor.
    point : array_like of 3 floats
        Location in body axes [m] (``position``, ``velocity``, ``acceleration``).
    axis : array_like of 3 floats, optional
        Sensitive axis in body axes [-]: one output, the projection; three outputs without it.
    relative : bool
        For ``rate``: relative to the scene frame instead of inertial.
    node : str, optional
        A node of the body's modal data the sensor moves with.

    Examples
    --------
    >>> from linflex import Sensor
    >>> Sensor("gyro_x", "rate", body="hub", axis=(1, 0, 0)).type
    'rate'
    """

    name: str
    type: str
    body: str | None = None
    wheel: str | None = None
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None
    relative: bool = False
    node: str | None = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        if not out.choice(self.type, f"{path}.type", SENSOR_TYPES, "sensor type"):
            return
        out.inapplicable(self, "relative", path, self.type == "rate", "only rate sensors measure relative rates")
        if not isinstance(self.relative, bool):
            out.add(f"{path}.relative", f"expected true or false, got {self.relative!r}")
        if self.type == "wheel_speed":
            for key in ("body", "node", "axis"):
                out.inapplicable(self, key, path, False, "a wheel_speed sensor reads its wheel")
            out.inapplicable(self, "point", path, False, "a wheel_speed sensor reads its wheel")
            if (out.name_ref(self.wheel, f"{path}.wheel", list(context.wheels), "wheel")
                    and context.lacks("wheel_gyroscopics")):
                out.add(f"{path}", "a wheel_speed sensor needs the 'wheel_gyroscopics' effect")
            return
        out.inapplicable(self, "wheel", path, False, "only wheel_speed sensors read a wheel")
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        if self.axis is not None:
            out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        at_point = self.type in ("position", "velocity", "acceleration")
        out.inapplicable(self, "point", path, at_point and self.node is None,
                         "a sensor at a node moves with the node" if self.node is not None
                         else f"a {self.type} sensor measures the body's rotation, not a point")
        context.check_node(out, f"{path}.node", self.body, self.node)


@dataclass(frozen=True)
class Actuator(_Entry):
    """An actuator whose command is an input of the model.

    ``torque`` [N m] on ``body`` about ``axis`` (body axes; three commands without ``axis``);
    ``force`` [N] at ``point`` along ``axis`` (body axes); ``thruster`` [N] likewise, active
    with the ``thrusters`` effect; ``wheel_torque`` [N m] of the motor of ``wheel`` (reaction on
    its body). On a flexible body, ``node`` names a node of its modal data where the torque or
    force acts (axes turned by the node's small rotation); ``point`` is then unused.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    type : str
        ``"torque"`` [N m], ``"force"`` [N], ``"thruster"`` [N] or ``"wheel_torque"`` [N m].
    body : str, optional
        The body it acts on (all types but ``wheel_torque``).
    wheel : str, optional
        The wheel whose motor a ``wheel_torque`` actuator drives.
    point : array_like of 3 floats
        Point of application in body axes [m] (forces and thrusters).
    axis : array_like of 3 floats, optional
        Direction in body axes [-]: one command; three commands without it.
    node : str, optional
        A node of the body's modal data where it acts.

    Examples
    --------
    >>> from linflex import Actuator
    >>> Actuator("motor_x", "torque", body="hub", axis=(1, 0, 0)).type
    'torque'
    """

    name: str
    type: str
    body: str | None = None
    wheel: str | None = None
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None
    node: str | None = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        if not out.choice(self.type, f"{path}.type", ACTUATOR_TYPES, "actuator type"):
            return
        if self.type == "wheel_torque":
            for key in ("body", "node", "axis", "point"):
                out.inapplicable(self, key, path, False, "a wheel_torque actuator drives its wheel's motor")
            wheel = context.wheels.get(self.wheel) if isinstance(self.wheel, str) else None
            if out.name_ref(self.wheel, f"{path}.wheel", list(context.wheels), "wheel") and wheel.mode != "torque":
                out.add(f"{path}.wheel", f"wheel {self.wheel!r} has mode {wheel.mode!r}; a wheel_torque actuator "
                                         "needs mode = 'torque'")
            return
        out.inapplicable(self, "wheel", path, False, "only wheel_torque actuators drive a wheel")
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        if self.axis is not None:
            out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        elif self.type == "thruster":
            out.add(f"{path}.axis", "a thruster needs an axis (its thrust direction in body axes)")
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.inapplicable(self, "point", path, self.type != "torque" and self.node is None,
                         "an actuator at a node acts there" if self.node is not None
                         else "a torque acts on the whole body, not at a point")
        context.check_node(out, f"{path}.node", self.body, self.node)


@dataclass(frozen=True)
class Disturbance(_Entry):
    """A named disturbance input: a ``torque`` [N m] on ``body`` about ``axis`` or a ``force``
    [N] at ``point`` along ``axis`` (body axes; three inputs ``name.x``, ``.y``, ``.z`` without
    ``axis``). Unlike an actuator it has no command output and no controller drives it.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    type : str
        ``"torque"`` [N m] or ``"force"`` [N].
    body : str
        The body it acts on.
    point : array_like of 3 floats
        Point of application of a force in body axes [m].
    axis : array_like of 3 floats, optional
        Direction in body axes [-]: one input; three inputs without it.

    Examples
    --------
    >>> from linflex import Disturbance
    >>> Disturbance("gust", "force", body="hub", point=(0, 0, 1)).type
    'force'
    """

    name: str
    type: str
    body: str
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.type, f"{path}.type", ("torque", "force"), "disturbance type")
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        if self.axis is not None:
            out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")


#: The units of an input profile's keys that are not in the input's own units.
_PROFILE_UNITS = {"rate": "input units/s", "frequency": "rad/s", "phase": "rad", "ramp_time": "s", "time": "s",
                  "start": "s", "duration": "s"}


@dataclass(frozen=True)
class InputProfile(_Entry):
    """A time profile of a model input: an actuator's command or a disturbance (``[[inputs]]``).

    ``input`` names the input (an actuator or a disturbance with one signal, or one channel
    ``name.x``, ``.y``, ``.z`` of a three-axis one); ``profile`` and its keys are those of a
    joint's ``prescribed`` profile: ``"constant"`` (``value``), ``"ramp"`` (``offset``,
    ``rate``), ``"sine"`` (``offset``, ``amplitude``, ``frequency``, ``phase``), ``"spinup"``
    (``offset``, ``rate``, ``ramp_time``), ``"step"`` (``time``, ``before``, ``after``),
    ``"table"`` (``times``, ``values``, a cubic spline held at its ends) or ``"transition"``
    (``start``, ``duration``, ``before``, ``after``: a smooth change). :func:`linflex.simulate`
    applies a scene's profiles when it is given no other inputs; on an actuator driven by a
    controller the profile adds to the controller's command.

    Parameters
    ----------
    input : str
        The model input the profile drives.
    profile : str
        ``"constant"``, ``"ramp"``, ``"sine"``, ``"spinup"``, ``"step"``, ``"table"`` or
        ``"transition"``.
    value : float, optional
        For ``constant``: the value [input units, N or N m].
    offset : float, optional
        For ``ramp``, ``sine``, ``spinup``: the value at t = 0 (the mean of a sine) [input units].
    rate : float, optional
        For ``ramp``: the slope [input units/s]; for ``spinup``: the final rate [input units/s].
    amplitude : float, optional
        For ``sine``: the amplitude [input units].
    frequency : float, optional
        For ``sine``: the angular frequency [rad/s].
    phase : float, optional
        For ``sine``: the phase at t = 0 [rad].
    ramp_time : float, optional
        For ``spinup``: the duration of the ramp [s].
    time : float, optional
        For ``step``: when the step happens [s].
    before, after : float, optional
        For ``step`` and ``transition``: the values before and after it [input units].
    times : list of float, optional
        For ``table``: the points' times [s], increasing, at least 4.
    values : list of float, optional
        For ``table``: the values at ``times`` [input units].
    start : float, optional
        For ``transition``: when the change begins [s].
    duration : float, optional
        For ``transition``: how long it takes [s], positive (a cycloidal blend: rate and
        acceleration zero at both ends).

    Examples
    --------
    >>> from linflex import InputProfile
    >>> InputProfile("gust", "step", time=1.0, before=0.0, after=0.5).profile
    'step'
    """

    input: str
    profile: str
    value: Any = None
    offset: Any = None
    rate: Any = None
    amplitude: Any = None
    frequency: Any = None
    phase: Any = None
    ramp_time: Any = None
    time: Any = None
    before: Any = None
    after: Any = None
    times: Any = None
    values: Any = None
    start: Any = None
    duration: Any = None

    def as_profile(self) -> dict:
        """The profile as a joint's ``prescribed`` mapping (``{"profile": ..., key: value}``).

        Returns
        -------
        dict
            ``profile`` and the keys that are set.
        """
        keys = PROFILES.get(self.profile, ())
        return {"profile": self.profile, **{k: getattr(self, k) for k in keys if getattr(self, k) is not None}}

    def signal(self):
        """The profile as a function of time ``t`` [s] returning a float [input units] (validated entry).

        Returns
        -------
        callable
            ``t -> value``, the function a joint's ``prescribed`` profile of the same keys follows.
        """
        function = profile_function(self.as_profile())
        return lambda t: float(function(float(t)))

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        names = []
        for entries, what in ((context.actuators.values(), "actuator"), (context.scene.disturbances, "disturbance")):
            for entry in entries:
                if what == "actuator" and entry.type == "thruster" and context.lacks("thrusters"):
                    continue
                width = actuator_width(entry) if hasattr(entry, "type") else 1
                names += [entry.name] if width == 1 else [f"{entry.name}.{c}" for c in "xyz"]
        if isinstance(self.input, str) and f"{self.input}.x" in names:
            out.add(f"{path}.input", f"{self.input!r} has three channels: name one, '{self.input}.x', "
                                     f"'{self.input}.y' or '{self.input}.z'")
        else:
            out.name_ref(self.input, f"{path}.input", names, "input (an actuator or disturbance)")
        if not out.choice(self.profile, f"{path}.profile", tuple(PROFILES), "profile"):
            return
        allowed = PROFILES[self.profile]
        for key in ("value", "offset", "rate", "amplitude", "frequency", "phase", "ramp_time", "time", "before",
                    "after", "times", "values", "start", "duration"):
            if getattr(self, key) is None:
                continue
            if key not in allowed:
                out.add(f"{path}.{key}", f"does not apply to a {self.profile!r} profile (its keys: "
                                         f"{', '.join(allowed)}; remove it)")
            elif key not in ("times", "values"):
                out.number(getattr(self, key), f"{path}.{key}", _PROFILE_UNITS.get(key, "input units"))
        if self.profile == "constant" and self.value is None:
            out.add(f"{path}.value", "a 'constant' profile needs 'value'")
        profile_problems(out, path, self.as_profile())


@dataclass(frozen=True)
class Controller(_Entry):
    """A controller from sensor signals to actuator commands (the ``control`` effect).

    The controller sees ``e = reference - y`` for its ``inputs`` (scalar sensor signals, one per
    channel) and adds its outputs to the commands of ``outputs`` (scalar actuators).
    ``pid``: ``u = kp e + ki int(e) - kd r`` with ``r`` the signals of ``rate_inputs`` (gains are
    scalars or one per channel); ``state_space``: ``xc' = A xc + B e``, ``u = C xc + D e``;
    ``transfer_function``: ``num``, ``den`` (highest power first), the same for every channel.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    type : str
        ``"pid"``, ``"state_space"`` or ``"transfer_function"``.
    inputs : str or list of str
        Scalar sensor signals it reads, one per channel.
    outputs : str or list of str
        Scalar actuators it commands, one per channel.
    reference : float or list of float, optional
        Set point of each input [sensor units, e.g. rad] (default 0).
    rate_inputs : str or list of str, optional
        For ``pid``: the rate signals the derivative gain acts on, one per channel.
    kp : float or list of float
        Proportional gain [actuator units per sensor unit, e.g. N m/rad].
    ki : float or list of float
        Integral gain [actuator units per sensor unit and second, e.g. N m/(rad s)].
    kd : float or list of float
        Derivative gain on ``rate_inputs`` [actuator units per rate unit, e.g. N m s/rad].
    A, B, C, D : array_like, optional
        For ``state_space``: the controller's matrices, ``xc' = A xc + B e``, ``u = C xc + D e``
        (``A`` [1/s], ``B``, ``C``, ``D`` in the channels' units).
    num, den : array_like, optional
        For ``transfer_function``: numerator and denominator coefficients in s, highest power
        first [channel units times s^k for the coefficient of s^k].
    sample_time : float, optional
        Sampling period [s] of a flight-computer controller: the law runs at the sample
        instants ``t0 + k sample_time`` on the sampled measurements, its continuous law and
        filters discretized by Tustin's method (a notch prewarped at its frequency), and its
        commands are held between samples. None (the default): a continuous controller.
    delay : float
        Computational delay [s] of a sampled controller: each command takes effect ``delay``
        seconds after its sample (0 by default).
    hold : str
        How a sampled controller's command is held between samples: ``"zoh"`` (zero-order hold).
    filters : list of mappings, optional
        Structural filters in series with the law on every output channel, in order, each a
        table of a ``kind`` and its keys: notch (``frequency`` [rad/s], ``depth`` [dB],
        ``width`` [rad/s]), low_pass (``frequency`` [rad/s], ``damping`` [-]), lead_lag
        (``zero`` and ``pole`` [rad/s], ``gain`` [-]), transfer_function (``num``, ``den``) or
        state_space (``A``, ``B``, ``C``, ``D``), these two with ``domain`` "s" (default) or "z"
        (which needs ``sample_time``), single-input single-output or one input and output per
        channel. The filters are :func:`linflex.notch`, :func:`linflex.low_pass` and
        :func:`linflex.lead_lag`.
    saturation : float or list of float, optional
        Symmetric limit of each held command, ``|u| <= saturation`` [actuator units, e.g. N m].
    rate_limit : float or list of float, optional
        Largest change of each held command per second [actuator units/s]: at most
        ``rate_limit sample_time`` from one sample to the next.
    quantization : float or list of float, optional
        Quantum of each held command [actuator units]: commands are rounded to multiples of it.
    noise : float or list of float, optional
        Standard deviation of white Gaussian noise added to each sampled measurement (the
        ``inputs`` then the ``rate_inputs``) [sensor units, e.g. rad, rad/s].
    seed : int
        Seed of the noise generator (0 by default): a run is reproducible.

    The output stages act on the held command of a sampled controller in this order:
    saturation, rate limit, quantization; they, the delay, the noise and filters in z need
    ``sample_time``. Only what a controller names is simulated.

    Examples
    --------
    >>> from linflex import Controller
    >>> pd = Controller("pd_x", "pid", inputs="att_x", outputs="motor_x", rate_inputs="gyro_x", kp=25.0, kd=70.0)
    >>> pd.kp, pd.kd
    (25.0, 70.0)
    """

    name: str
    type: str
    inputs: Any
    outputs: Any
    reference: Any = None
    rate_inputs: Any = None
    kp: Any = 0.0
    ki: Any = 0.0
    kd: Any = 0.0
    A: Any = None
    B: Any = None
    C: Any = None
    D: Any = None
    num: Any = None
    den: Any = None
    sample_time: Any = None
    delay: Any = 0.0
    hold: Any = "zoh"
    filters: Any = ()
    saturation: Any = None
    rate_limit: Any = None
    quantization: Any = None
    noise: Any = None
    seed: Any = 0

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.type, f"{path}.type", CONTROLLER_TYPES, "controller type")
        # the rate inputs are read only with a derivative gain (controller_system drops them otherwise)
        reads_rates = (self.rate_inputs is not None and is_numeric(self.kd)
                       and bool(np.any(np.asarray(self.kd, dtype=float) != 0)))
        n_rates = len(self._names(self.rate_inputs)) if reads_rates else 0
        check_chain(self, out, path, len(self._names(self.inputs)) + n_rates, len(self._names(self.outputs)))
        ins = self._names(self.inputs)
        outs = self._names(self.outputs)
        for k, name in enumerate(ins):
            sensor = context.sensors.get(name) if isinstance(name, str) else None
            if out.name_ref(name, f"{path}.inputs[{k}]", list(context.sensors), "sensor"):
                if sensor_width(sensor) != 1:
                    out.add(f"{path}.inputs[{k}]", f"sensor {name!r} has 3 signals; give it an axis to feed a "
                                                   "controller channel")
                if sensor.type == "acceleration":
                    out.add(f"{path}.inputs[{k}]", "acceleration sensors cannot feed a controller (algebraic loop)")
        for k, name in enumerate(outs):
            actuator = context.actuators.get(name) if isinstance(name, str) else None
            if actuator is None:
                out.add(f"{path}.outputs[{k}]", f"{name!r} is no actuator{hint(name, list(context.actuators))}")
            elif actuator_width(actuator) != 1:
                out.add(f"{path}.outputs[{k}]", f"actuator {name!r} has 3 commands; give it an axis to be a "
                                                "controller channel")
            elif actuator.type == "thruster" and context.lacks("thrusters"):
                out.add(f"{path}.outputs[{k}]", f"actuator {name!r} is a thruster but the 'thrusters' effect is not "
                                                "included")
        if not ins:
            out.add(f"{path}.inputs", "a controller needs at least one sensor input")
        if not outs:
            out.add(f"{path}.outputs", "a controller needs at least one actuator output")
        if self.reference is not None:
            ref = [self.reference] if isinstance(self.reference, (int, float)) else self.reference
            out.array(ref, f"{path}.reference", (len(ins),), "sensor units", f"{len(ins)} values (one per input)")
        for key in ("kp", "ki", "kd", "rate_inputs"):
            out.inapplicable(self, key, path, self.type == "pid", "only pid controllers take gains and rate inputs")
        for key in ("A", "B", "C", "D"):
            out.inapplicable(self, key, path, self.type == "state_space", "only state_space controllers take matrices")
        for key in ("num", "den"):
            out.inapplicable(self, key, path, self.type == "transfer_function",
                             "only transfer_function controllers take polynomials")
        if self.type == "pid":
            self._check_pid(out, path, context, len(ins), len(outs))
        elif self.type == "state_space":
            self._check_state_space(out, path, len(ins), len(outs))
        elif self.type == "transfer_function":
            self._check_transfer_function(out, path, len(ins), len(outs))

    @staticmethod
    def _names(value: Any) -> list:
        return [value] if isinstance(value, str) else list(value) if isinstance(value, (list, tuple)) else [value]

    def _check_pid(self, out: Problems, path: str, context: SceneContext, n_in: int, n_out: int) -> None:
        if n_in != n_out:
            out.add(path, f"a pid controller has one channel per input and output; got {n_in} inputs and "
                          f"{n_out} outputs")
        for key in ("kp", "ki", "kd"):
            value = getattr(self, key)
            vals = [value] if isinstance(value, (int, float)) else value
            out.array(vals, f"{path}.{key}", (np.size(vals) if np.size(vals) in (1, n_in) else n_in,),
                      "command per sensor unit", f"a scalar or {n_in} gains")
        rates = self.rate_inputs
        kd_nonzero = is_numeric(self.kd) and bool(np.any(np.asarray(self.kd, dtype=float) != 0))
        if rates is None:
            if kd_nonzero:
                out.add(f"{path}.kd", "a derivative gain needs rate_inputs (rate sensors, one per channel)")
            return
        rates = self._names(rates)
        if len(rates) != n_in:
            out.add(f"{path}.rate_inputs", f"expected {n_in} sensor names (one per channel), got {len(rates)}")
        for k, name in enumerate(rates):
            if (out.name_ref(name, f"{path}.rate_inputs[{k}]", list(context.sensors), "sensor")
                    and sensor_width(context.sensors[name]) != 1):
                out.add(f"{path}.rate_inputs[{k}]", f"sensor {name!r} has 3 signals; give it an axis")

    def _check_state_space(self, out: Problems, path: str, n_in: int, n_out: int) -> None:
        mats = {}
        for key in ("A", "B", "C", "D"):
            value = getattr(self, key)
            if value is None:
                if key != "D":
                    out.add(f"{path}.{key}", "required for a state_space controller")
                continue
            arr = np.asarray(value, dtype=float) if is_numeric(value) else None
            if arr is None or arr.ndim != 2 or not np.all(np.isfinite(arr)):
                out.add(f"{path}.{key}", f"expected a finite matrix (array of rows), got {value!r}")
            else:
                mats[key] = arr
        if {"A", "B", "C"} <= set(mats):
            nx = mats["A"].shape[0]
            expect = {"A": (nx, nx), "B": (nx, n_in), "C": (n_out, nx), "D": (n_out, n_in)}
            for key, arr in mats.items():
                if arr.shape != expect[key]:
                    out.add(f"{path}.{key}", f"has shape {arr.shape} but {expect[key]} was expected "
                                             f"({nx} controller states, {n_in} inputs, {n_out} outputs)")

    def _check_transfer_function(self, out: Problems, path: str, n_in: int, n_out: int) -> None:
        if n_in != n_out:
            out.add(path, f"a transfer_function controller has one channel per input and output; got {n_in} "
                          f"and {n_out}")
        for key in ("num", "den"):
            value = getattr(self, key)
            arr = np.asarray(value, dtype=float) if is_numeric(value) else None
            if arr is None or arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                out.add(f"{path}.{key}", f"expected a list of polynomial coefficients, got {value!r}")
            elif key == "den" and arr[0] == 0:
                out.add(f"{path}.den", "the leading coefficient must not be zero")
        if is_numeric(self.num) and is_numeric(self.den) and np.size(self.num) > np.size(self.den):
            out.add(f"{path}.num", "improper transfer function (numerator degree above the denominator's)")
