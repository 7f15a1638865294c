"""Plant/controller loops with named channels and the classic transfer-function types.

The seven DISCOS transfer-function types (reference notes, section 6) are presets of one state-space
interconnection in which each actuator and each sensor channel is either closed or cut; no
polynomial is formed.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, as_linear_system, discretize, pade

__all__ = ["Loop", "transfer_function", "TRANSFER_FUNCTION_KINDS"]

def _names(keys, available: tuple[str, ...], what: str, among: str = "the plant has") -> tuple[str, ...]:
    if isinstance(keys, (str, int, np.integer)):
        keys = [keys]
    try:
        keys = list(keys)
    except TypeError:
        raise ModelError(f"{what} must be a signal name or a sequence of names, got {type(keys).__name__}") from None
    if not keys:
        raise ModelError(f"{what} is empty: a loop needs at least one channel")
    out = []
    for key in keys:
        if isinstance(key, (int, np.integer)):
            if not -len(available) <= key < len(available):
                raise ModelError(f"{what}: index {key} out of range for {len(available)} signals")
            out.append(available[key])
        elif key in available:
            out.append(key)
        else:
            raise ModelError(f"{what}: unknown signal {key!r}; {among} {list(available)}")
    dup = {k for k in out if out.count(k) > 1}
    if dup:
        raise ModelError(f"{what}: channels repeat: {sorted(dup)}")
    return tuple(out)


@dataclass(frozen=True, init=False, eq=False)
class Loop:
    """A feedback loop of a plant and a controller joined by named channels.

    Parameters
    ----------
    plant : LinearSystem, SecondOrderSystem or control.StateSpace
        Plant inputs are actuator commands and disturbances, plant outputs sensor signals and
        performance outputs.
    controller : LinearSystem, SecondOrderSystem or control.StateSpace
        Its ``k``-th input is the plant output ``sensors[k]``; its ``j``-th output drives the
        plant input ``actuators[j]``.
    sensors : str or sequence of str (or int), optional
        Plant outputs fed to the controller, in the order of the controller inputs. Default: all
        of them, in order (a controller with as many inputs as the plant has outputs).
    actuators : str or sequence of str (or int), optional
        Plant inputs driven by the controller, in the order of the controller outputs. Default:
        all of them, in order (a controller with as many outputs as the plant has inputs).

    Notes
    -----
    **Sampled and delayed loops.** Plant and controller may carry input and output delays [s]
    (a computational delay is the controller's ``output_delay``; an actuator delay the plant's
    ``input_delay``). A **discrete controller** (``dt``) on a continuous plant makes a
    sampled-data loop: the plant is discretized with a zero-order hold at the controller's
    ``dt`` (:func:`~linflex.discretize`, its input delays exact even when they are not whole
    periods; every plant input, disturbances included, is held over a period), and every
    transfer function of the loop is a discrete system, exact **at the sample instants**
    (between samples the continuous plant moves, which no discrete model shows). Whole-period
    delays of a discrete loop are exact shift registers inside the interconnection. A
    continuous loop keeps its delays exact where they sit at the boundary of the result: the
    open-loop kinds (``open_loop()`` and :func:`stability_margins` of the loop) carry them as
    input and output delays; delays inside a closed loop make it irrational and those kinds
    are refused (take :func:`~linflex.pade` of plant or controller, with its error, first).
    ``plant`` is then the sampled plant the loop analyses and ``continuous_plant`` the one given.
    A discrete controller's own delays are whole periods (``z^-k``); a computational delay that
    is not a whole number of periods (20 ms at 10 Hz) belongs on the continuous plant's
    ``input_delay`` of the actuator channels, which the sampling makes exact (one held state per
    delayed actuator). Sensor delays of a sampled loop must be whole periods.

    **Negative feedback.** Plant input ``u[actuators[j]] = r_j - beta_j`` where ``beta`` are the
    controller outputs and ``r`` external inputs at the same point; controller input
    ``e_k = y[sensors[k]] + n_k`` with sensor noise ``n``. The loop transfer function broken at
    the plant input is therefore ``L = K P`` (:meth:`open_loop`) and the closed-loop
    characteristic equation is ``det(I + L(s)) = 0``::

        r -->(+)--u--> [ P ] --y_s--+--> y
              -|                    |
               +--beta-- [ K ] <-e-(+)<-- n

    Attributes
    ----------
    plant, controller : LinearSystem
    sensors, actuators : tuple of str
        Names of plant outputs and plant inputs.
    continuous_plant : LinearSystem or None
        The plant as given when the loop sampled it for a discrete controller, else None.
    dt : float or None
        Sampling period [s] of a sampled loop (the controller's), None for a continuous loop.

    Raises
    ------
    ModelError
        For unknown or repeated channel names, a controller whose input/output counts do not
        match the named sensors/actuators, a discrete plant with a continuous controller or with
        another sampling period, or a plant output delay that is not a whole number of the
        controller's periods.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> P = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    >>> K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[4.0]])
    >>> loop = Loop(P, K, sensors="angle", actuators="torque")
    >>> loop.open_loop().outputs, loop.open_loop().inputs
    (('y0',), ('torque',))

    The same plant under a 10 Hz PD, ``u[k] = 4 e[k] + 20 (e[k] - e[k-1])``, with a 20 ms
    computational delay on the torque: a discrete loop, exact at the samples.

    >>> pd = LinearSystem([[0.0]], [[1.0]], [[-20.0]], [[24.0]], dt=0.1)
    >>> sampled = Loop(P.with_(input_delay=0.02), pd, sensors="angle", actuators="torque")
    >>> sampled.dt, sampled.plant.states
    (0.1, ('x0', 'x1', 'torque.held'))
    """

    plant: LinearSystem
    controller: LinearSystem
    sensors: tuple[str, ...]
    actuators: tuple[str, ...]
    continuous_plant: LinearSystem | None

    def __init__(self, plant, controller, *, sensors=None, actuators=None) -> None:
        plant = as_linear_system(plant, "plant", discrete=True, delay=True)
        controller = as_linear_system(controller, "controller", discrete=True, delay=True)
        continuous_plant = None
        if plant.is_discrete and plant.dt != controller.dt:
            raise ModelError(
                f"plant is discrete (dt = {plant.dt} s) but the controller "
                + ("is continuous" if controller.dt is None else f"has dt = {controller.dt} s")
                + ": a loop samples a continuous plant for a discrete controller, not the reverse"
            )
        if controller.is_discrete and not plant.is_discrete:
            continuous_plant, plant = plant, discretize(plant, controller.dt, "zoh")
        for given, ours, theirs, what, side in ((sensors, controller.n_inputs, plant.outputs, "sensors", "inputs"),
                                                (actuators, controller.n_outputs, plant.inputs, "actuators", "outputs")):
            if given is None and ours != len(theirs):
                raise ModelError(f"name the {what}=: the controller has {ours} {side[:-1] if ours == 1 else side} and "
                                 f"the plant {len(theirs)} {'outputs' if what == 'sensors' else 'inputs'} {list(theirs)}")
        sensors = _names(plant.outputs if sensors is None else sensors, plant.outputs, "sensors")
        actuators = _names(plant.inputs if actuators is None else actuators, plant.inputs, "actuators")
        if controller.n_inputs != len(sensors):
            raise ModelError(
                f"controller has {controller.n_inputs} inputs but {len(sensors)} sensors were named {list(sensors)}"
            )
        if controller.n_outputs != len(actuators):
            raise ModelError(
                f"controller has {controller.n_outputs} outputs but {len(actuators)} actuators were named "
                f"{list(actuators)}"
            )
        object.__setattr__(self, "plant", plant)
        object.__setattr__(self, "controller", controller)
        object.__setattr__(self, "sensors", sensors)
        object.__setattr__(self, "actuators", actuators)
        object.__setattr__(self, "continuous_plant", continuous_plant)

    @property
    def dt(self) -> float | None:
        """Sampling period [s] of a sampled loop, None for a continuous one."""
        return self.controller.dt

    def open_loop(self) -> LinearSystem:
        """The loop transfer function ``L = K P`` broken at the plant input (``"open_loop_at_input"``).

        Returns
        -------
        LinearSystem
            Inputs named by the actuators, outputs by the controller outputs; states of the plant
            then of the controller. The closed loop is stable iff ``det(I + L)`` has no
            right-half-plane zeros beyond the open-loop unstable poles (Nyquist).
        """
        return transfer_function(self, "open_loop_at_input")

    def __repr__(self) -> str:
        return (
            f"Loop(plant={self.plant!r}, controller={self.controller!r}, sensors={list(self.sensors)!r}, "
            f"actuators={list(self.actuators)!r})"
        )


@dataclass(frozen=True)
class _Interconnection:
    """A loop with some channels cut, as named blocks of one state-space realization.

    Inputs ``w`` (plant inputs, m) and ``n`` (sensor noise, ns); outputs ``y`` (plant outputs,
    p), ``beta`` (controller outputs, na), ``u`` (applied plant inputs, m) and ``e`` (controller
    inputs, ns); state ``[xp; xk]``::

        x'  = A x + B["w"] w + B["n"] n
        out = C[out] x + D[out]["w"] w + D[out]["n"] n      for out in y, beta, u, e
    """

    A: np.ndarray
    B: Mapping[str, np.ndarray]
    C: Mapping[str, np.ndarray]
    D: Mapping[str, Mapping[str, np.ndarray]]
    states: tuple[str, ...] | None
    dt: float | None = None

    def system(self, output: str, rows, input: str, cols, *, outputs, inputs, sign: float = 1.0) -> LinearSystem:
        """The channels ``rows`` of output block ``output`` from ``cols`` of input block ``input``."""
        rows, cols = list(rows), list(cols)
        return LinearSystem(self.A, self.B[input][:, cols], sign * self.C[output][rows, :],
                            sign * self.D[output][input][np.ix_(rows, cols)],
                            states=self.states, inputs=inputs, outputs=outputs, dt=self.dt)


def _interconnect(loop: Loop, *, cut_actuators=(), cut_sensors=()) -> _Interconnection:
    """The loop with the named actuator and sensor channels cut (all others closed).

    ``Ea`` (m x na) places closed controller outputs on the plant inputs, ``S`` (ns x p) picks
    the closed sensors. With ``F = I + Dk S Dp Ea`` (the algebraic loop)::

        beta = F^-1 (Dk S [Cp 0] + [0 Ck]) x + F^-1 Dk S Dp w + F^-1 Dk n
        u    = w - Ea beta,   y = [Cp 0] x + Dp u,   e = S y + n
        x'   = diag(Ap, Ak) x + [Bp u; Bk e]
    """
    P, K = _rational(loop.plant, "plant"), _rational(loop.controller, "controller")
    n_p, n_k = P.n_states, K.n_states
    m, p = P.n_inputs, P.n_outputs
    na, ns = len(loop.actuators), len(loop.sensors)
    Ea = np.zeros((m, na))
    for j, name in enumerate(loop.actuators):
        if name not in cut_actuators:
            Ea[P.inputs.index(name), j] = 1.0
    S = np.zeros((ns, p))
    for k, name in enumerate(loop.sensors):
        if name not in cut_sensors:
            S[k, P.outputs.index(name)] = 1.0
    F = np.eye(na) + K.D @ S @ P.D @ Ea
    try:
        with warnings.catch_warnings():
            # singularity is detected from the pivots just below
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            lu = scipy.linalg.lu_factor(F, check_finite=False)
        ok = np.min(np.abs(np.diag(lu[0]))) > 1e-12 * max(1.0, np.max(np.abs(F)))
    except (ValueError, np.linalg.LinAlgError):
        ok = False
    if not ok:
        raise ModelError(
            "the loop is ill-posed: I + Dk Dp (controller and plant feedthrough around the loop) is singular"
        )
    Cpx = np.hstack([P.C, np.zeros((p, n_k))])
    Ckx = np.hstack([np.zeros((na, n_p)), K.C])
    Bx = scipy.linalg.lu_solve(lu, K.D @ S @ Cpx + Ckx)
    Bw = scipy.linalg.lu_solve(lu, K.D @ S @ P.D)
    Bv = scipy.linalg.lu_solve(lu, K.D)
    Ux, Uw, Uv = -Ea @ Bx, np.eye(m) - Ea @ Bw, -Ea @ Bv
    Yx, Yw, Yv = Cpx + P.D @ Ux, P.D @ Uw, P.D @ Uv
    Ex, Ew, Ev = S @ Yx, S @ Yw, S @ Yv + np.eye(ns)
    states = list(P.states) + [f"controller.{s}" for s in K.states]
    return _Interconnection(
        A=scipy.linalg.block_diag(P.A, K.A) + np.vstack([P.B @ Ux, K.B @ Ex]),
        B={"w": np.vstack([P.B @ Uw, K.B @ Ew]), "n": np.vstack([P.B @ Uv, K.B @ Ev])},
        C={"y": Yx, "beta": Bx, "u": Ux, "e": Ex},
        D={"y": {"w": Yw, "n": Yv}, "beta": {"w": Bw, "n": Bv}, "u": {"w": Uw, "n": Uv}, "e": {"w": Ew, "n": Ev}},
        states=tuple(states) if len(set(states)) == len(states) else None,
        dt=K.dt,
    )


def _rational(sys: LinearSystem, name: str) -> LinearSystem:
    """A discrete system's whole-period delays as exact shift registers; a continuous delay is refused."""
    if not sys.has_delay:
        return sys
    if sys.is_discrete:
        return pade(sys, 1).sys
    raise ModelError(
        f"the {name} has delays inside this loop's closed channels: a continuous closed loop with delays is not "
        f"rational; analyse the open loop (its delays kept exact) or take linflex.pade({name}, order) "
        f"(error reported) first"
    )


def _boundary_delays(loop: Loop, at_input: bool) -> tuple[LinearSystem, LinearSystem, NDArray, NDArray]:
    """Plant and controller without delays, and the delays of an open loop moved to its inputs and outputs.

    Broken at the plant input (``at_input``) the path is actuator -> plant -> sensor ->
    controller -> controller output: the plant's actuator input delays stay on the result's
    inputs, the controller's output delays on its outputs, and the interior delays (sensor output
    plus controller input) move to the outputs when they are equal on every channel (a SISO loop
    always). Broken at the sensors the roles swap.
    """
    P, K = loop.plant, loop.controller
    act = [P.inputs.index(a) for a in loop.actuators]
    sen = [P.outputs.index(s) for s in loop.sensors]
    if at_input:
        first, last = P.input_delay[act], K.output_delay
        interior = P.output_delay[sen] + K.input_delay
    else:
        first, last = K.input_delay, P.output_delay[sen]
        interior = K.output_delay + P.input_delay[act]
    if interior.size and np.ptp(interior) > 0:
        if first.size != 1 or last.size != 1:
            raise ModelError(
                "the loop's delays between plant and controller differ from channel to channel: the open loop is "
                "not a system with input and output delays; take linflex.pade of plant or controller first"
            )
    extra = interior.max(initial=0.0)
    return (P.with_(input_delay=None, output_delay=None), K.with_(input_delay=None, output_delay=None),
            first, last + extra)


def _delayed_open_loop(loop: Loop, build, at_input: bool) -> LinearSystem:
    """An open-loop kind of a continuous delayed loop: the undelayed one with its boundary delays."""
    P, K, first, last = _boundary_delays(loop, at_input)
    bare = Loop(P, K, sensors=loop.sensors, actuators=loop.actuators)
    return build(bare).with_(input_delay=first, output_delay=last)


# How each kind is formed: which channels are cut, and which output and input channels of the
# interconnection it keeps (``opened``: the actuators cut for "quasi_open_loop"; ``at``: where
# sensitivities are taken). Indices are within the blocks of _Interconnection.
def _actuator_columns(loop: Loop, names) -> list[int]:
    return [loop.plant.inputs.index(a) for a in names]


def _sensor_rows(loop: Loop) -> list[int]:
    return [loop.plant.outputs.index(s) for s in loop.sensors]


def _open_loop_at_input(loop: Loop, at: str, opened) -> LinearSystem:
    if loop.dt is None and (loop.plant.has_delay or loop.controller.has_delay):
        return _delayed_open_loop(loop, lambda bare: _open_loop_at_input(bare, at, opened), True)
    ic = _interconnect(loop, cut_actuators=loop.actuators)
    return ic.system("beta", range(len(loop.actuators)), "w", _actuator_columns(loop, loop.actuators),
                     outputs=loop.controller.outputs, inputs=loop.actuators)


def _open_loop_at_output(loop: Loop, at: str, opened) -> LinearSystem:
    # Injection at the controller input, the loop cut at the sensors: -(n -> y) = P K.
    if loop.dt is None and (loop.plant.has_delay or loop.controller.has_delay):
        return _delayed_open_loop(loop, lambda bare: _open_loop_at_output(bare, at, opened), False)
    ic = _interconnect(loop, cut_sensors=loop.sensors)
    return ic.system("y", _sensor_rows(loop), "n", range(len(loop.sensors)),
                     outputs=loop.sensors, inputs=loop.controller.inputs, sign=-1.0)


def _closed_loop(loop: Loop, at: str, opened) -> LinearSystem:
    P = loop.plant
    return _interconnect(loop).system("y", range(P.n_outputs), "w", range(P.n_inputs),
                                      outputs=P.outputs, inputs=P.inputs)


def _closed_loop_sensor_noise(loop: Loop, at: str, opened) -> LinearSystem:
    P = loop.plant
    return _interconnect(loop).system("y", range(P.n_outputs), "n", range(len(loop.sensors)),
                                      outputs=P.outputs, inputs=[f"{s}.noise" for s in loop.sensors])


def _quasi_open_loop(loop: Loop, at: str, opened) -> LinearSystem:
    ic = _interconnect(loop, cut_actuators=opened)
    rows = [loop.actuators.index(a) for a in opened]
    return ic.system("beta", rows, "w", _actuator_columns(loop, opened),
                     outputs=[loop.controller.outputs[j] for j in rows], inputs=opened)


def _sensitivity(loop: Loop, at: str, opened) -> LinearSystem:
    ic = _interconnect(loop)
    if at == "output":  # S_o: sensor noise -> controller input
        return ic.system("e", range(len(loop.sensors)), "n", range(len(loop.sensors)),
                         outputs=loop.sensors, inputs=loop.sensors)
    # S_i: actuator injection -> applied plant input
    columns = _actuator_columns(loop, loop.actuators)
    return ic.system("u", columns, "w", columns, outputs=loop.actuators, inputs=loop.actuators)


def _complementary_sensitivity(loop: Loop, at: str, opened) -> LinearSystem:
    ic = _interconnect(loop)
    if at == "output":  # T_o = -(sensor noise -> sensor output)
        return ic.system("y", _sensor_rows(loop), "n", range(len(loop.sensors)),
                         outputs=loop.sensors, inputs=loop.sensors, sign=-1.0)
    # T_i: actuator injection -> controller output
    return ic.system("beta", range(len(loop.actuators)), "w", _actuator_columns(loop, loop.actuators),
                     outputs=loop.actuators, inputs=loop.actuators)


_KINDS: dict[str, Callable[[Loop, str, tuple], LinearSystem]] = {
    "plant": lambda loop, at, opened: loop.plant,
    "controller": lambda loop, at, opened: loop.controller,
    "open_loop_at_input": _open_loop_at_input,
    "open_loop_at_output": _open_loop_at_output,
    "closed_loop": _closed_loop,
    "closed_loop_sensor_noise": _closed_loop_sensor_noise,
    "quasi_open_loop": _quasi_open_loop,
    "sensitivity": _sensitivity,
    "complementary_sensitivity": _complementary_sensitivity,
}
TRANSFER_FUNCTION_KINDS = tuple(_KINDS)


def transfer_function(loop: Loop, kind: str, *, input=None, output=None, opened=None, at: str = "output") -> LinearSystem:
    """One of the classic transfer-function types of a loop, as a state-space system.

    Parameters
    ----------
    loop : Loop
    kind : str
        One of (DISCOS type in brackets, reference notes section 6):

        - ``"plant"`` [I]: ``P``, all plant inputs to all plant outputs.
        - ``"controller"`` [II]: ``K``.
        - ``"open_loop_at_input"`` [III]: ``L_i = K P``, actuator injection to controller outputs
          with the loop cut at the plant input.
        - ``"open_loop_at_output"`` [IV]: ``L_o = P K``, controller-input injection to sensors with
          the loop cut at the sensors. DISCOS Type IV with noise added (``+``) equals ``-L_o``.
        - ``"closed_loop"`` [V]: control ratio, plant inputs (external ``r`` at the actuators,
          disturbances elsewhere) to plant outputs, all loops closed.
        - ``"closed_loop_sensor_noise"`` [VI]: sensor noise ``n`` (inputs ``"<sensor>.noise"``)
          to plant outputs, all loops closed (``-T_o`` on the sensors).
        - ``"quasi_open_loop"`` [VII]: the actuator channels named by ``opened`` cut, the others
          closed; injection at the opened actuators to the matching controller outputs.
        - ``"sensitivity"``: ``S_o = (I + P K)^-1`` (``at="output"``, sensors to sensors) or
          ``S_i = (I + K P)^-1`` (``at="input"``, actuators to actuators).
        - ``"complementary_sensitivity"``: ``T_o = I - S_o`` or ``T_i = I - S_i``.

        The open-loop kinds are return ratios: ``det(I + L)`` is the closed-loop characteristic
        ratio ``det(sI - A_closed) / det(sI - A_open)``.
    input, output : str, int or sequence, optional
        Channels of the result to keep (names or indices of the result's inputs/outputs).
    opened : str or sequence of str, optional
        For ``"quasi_open_loop"``: the actuators whose channels are cut; default all of ``input``
        or, when that is not given, the first actuator.
    at : {"output", "input"}
        Where sensitivity and complementary sensitivity are taken.

    Returns
    -------
    LinearSystem
        Built by state-space interconnection (no polynomial). States are the plant states then the
        controller states (named ``controller.<state>``) except for ``"plant"`` and
        ``"controller"``; the realization is not reduced to a minimal one.

    Raises
    ------
    ModelError
        For an unknown kind, unknown channels, ``opened`` or ``at="input"`` given for a kind
        they do not apply to, or an ill-posed loop.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> P = LinearSystem([[0.0]], [[1.0]], [[1.0]], inputs=["u"], outputs=["y"])   # 1/s
    >>> K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[2.0]])
    >>> T = transfer_function(Loop(P, K, sensors="y", actuators="u"), "closed_loop")
    >>> T.A.tolist()                                                          # 1/(s + 2)
    [[-2.0]]
    """
    if not isinstance(loop, Loop):
        raise ModelError(f"loop must be a Loop, got {type(loop).__name__}")
    if kind not in TRANSFER_FUNCTION_KINDS:
        raise ModelError(f"kind must be one of {list(TRANSFER_FUNCTION_KINDS)}, got {kind!r}")
    if at not in ("output", "input"):
        raise ModelError(f"at must be 'output' or 'input', got {at!r}")
    if at == "input" and kind not in ("sensitivity", "complementary_sensitivity"):
        raise ModelError(f"at='input' applies to kinds 'sensitivity' and 'complementary_sensitivity' only, not "
                         f"{kind!r} (the open loop at the plant input is kind 'open_loop_at_input')")
    if opened is not None and kind != "quasi_open_loop":
        raise ModelError(f"opened= applies to kind 'quasi_open_loop' only, not {kind!r}")
    if kind == "quasi_open_loop":
        opened = _names(opened if opened is not None else input if input is not None else loop.actuators[0],
                        loop.actuators, "opened", "the loop's actuators are")
        if input is not None and _names(input, opened, "input", "the opened channels are") == opened:
            input = None  # the result's inputs are exactly the opened channels
    result = _KINDS[kind](loop, at, opened)
    if input is not None or output is not None:
        result = result.subsystem(inputs=input, outputs=output)
    return result
