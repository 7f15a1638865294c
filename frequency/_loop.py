"""Plant/controller loops with named channels and the classic transfer-function types.

The seven DISCOS transfer-function types (reference notes, section 6) are presets of one state-space
interconnection in which each actuator and each sensor channel is either closed or cut; no
polynomial is formed.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from linflex import LinearSystem, ModelError, as_linear_system

__all__ = ["Loop", "transfer_function", "TRANSFER_FUNCTION_KINDS"]

TRANSFER_FUNCTION_KINDS = (
    "plant",
    "controller",
    "open_loop_at_input",
    "open_loop_at_output",
    "closed_loop",
    "closed_loop_sensor_noise",
    "quasi_open_loop",
    "sensitivity",
    "complementary_sensitivity",
)


def _names(keys, available: tuple[str, ...], what: str) -> tuple[str, ...]:
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
            raise ModelError(f"{what}: unknown signal {key!r}; the plant has {list(available)}")
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
    sensors : str or sequence of str (or int)
        Plant outputs fed to the controller, in the order of the controller inputs.
    actuators : str or sequence of str (or int)
        Plant inputs driven by the controller, in the order of the controller outputs.

    Notes
    -----
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

    Raises
    ------
    ModelError
        For unknown or repeated channel names, or a controller whose input/output counts do not
        match the named sensors/actuators.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> P = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    >>> K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[4.0]])
    >>> loop = Loop(P, K, sensors="angle", actuators="torque")
    >>> loop.open_loop().outputs, loop.open_loop().inputs
    (('y0',), ('torque',))
    """

    plant: LinearSystem
    controller: LinearSystem
    sensors: tuple[str, ...]
    actuators: tuple[str, ...]

    def __init__(self, plant, controller, *, sensors, actuators) -> None:
        plant = as_linear_system(plant, "plant")
        controller = as_linear_system(controller, "controller")
        sensors = _names(sensors, plant.outputs, "sensors")
        actuators = _names(actuators, plant.inputs, "actuators")
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


def _interconnect(loop: Loop, closed_actuators, closed_sensors):
    """The loop with some channels cut, as matrices.

    Inputs ``[w (plant inputs, m); n (sensor noise, ns)]``; outputs ``[y (p); beta (na);
    u (m, applied plant inputs); e (ns, controller inputs)]``; state ``[xp; xk]``.
    ``Ea`` (m x na) places closed controller outputs on the plant inputs, ``S`` (ns x p) picks
    the closed sensors. With ``F = I + Dk S Dp Ea`` (the algebraic loop)::

        beta = F^-1 (Dk S [Cp 0] + [0 Ck]) x + F^-1 Dk S Dp w + F^-1 Dk n
        u    = w - Ea beta,   y = [Cp 0] x + Dp u,   e = S y + n
        x'   = diag(Ap, Ak) x + [Bp u; Bk e]
    """
    P, K = loop.plant, loop.controller
    n_p, n_k = P.n_states, K.n_states
    m, p = P.n_inputs, P.n_outputs
    na, ns = len(loop.actuators), len(loop.sensors)
    Ea = np.zeros((m, na))
    for j, name in enumerate(loop.actuators):
        if closed_actuators[j]:
            Ea[P.inputs.index(name), j] = 1.0
    S = np.zeros((ns, p))
    for k, name in enumerate(loop.sensors):
        if closed_sensors[k]:
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
    A = scipy.linalg.block_diag(P.A, K.A) + np.vstack([P.B @ Ux, K.B @ Ex])
    B = np.block([[P.B @ Uw, P.B @ Uv], [K.B @ Ew, K.B @ Ev]])
    C = np.vstack([Yx, Bx, Ux, Ex])
    D = np.block([[Yw, Yv], [Bw, Bv], [Uw, Uv], [Ew, Ev]])
    rows = {"y": slice(0, p), "beta": slice(p, p + na), "u": slice(p + na, p + na + m),
            "e": slice(p + na + m, p + na + m + ns)}
    cols = {"w": slice(0, m), "n": slice(m, m + ns)}
    return A, B, C, D, rows, cols


def _pick(loop, A, B, C, D, rows, cols, out_rows, in_cols, outputs, inputs, sign=1.0):
    states = list(loop.plant.states) + [f"controller.{s}" for s in loop.controller.states]
    if len(set(states)) != len(states):
        states = None
    return LinearSystem(
        A, B[:, in_cols], sign * C[out_rows, :], sign * D[np.ix_(out_rows, in_cols)],
        states=states, inputs=inputs, outputs=outputs,
    )


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
        For an unknown kind, unknown channels or an ill-posed loop.

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
    if opened is not None and kind != "quasi_open_loop":
        raise ModelError(f"opened= applies to kind 'quasi_open_loop' only, not {kind!r}")
    P, K = loop.plant, loop.controller
    na, ns = len(loop.actuators), len(loop.sensors)
    act_idx = [P.inputs.index(a) for a in loop.actuators]
    sen_idx = [P.outputs.index(s) for s in loop.sensors]
    if kind == "plant":
        result = P
    elif kind == "controller":
        result = K
    else:
        closed_a, closed_s, sign = [True] * na, [True] * ns, 1.0
        ctrl_out = list(K.outputs)
        noise = [f"{s}.noise" for s in loop.sensors]
        if kind == "open_loop_at_input":
            closed_a = [False] * na
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            out_rows = list(range(r["beta"].start, r["beta"].stop))
            in_cols = [c["w"].start + i for i in act_idx]
            result = _pick(loop, *mats, out_rows, in_cols, ctrl_out, list(loop.actuators))
        elif kind == "open_loop_at_output":
            closed_s = [False] * ns
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            out_rows = [r["y"].start + i for i in sen_idx]
            in_cols = list(range(c["n"].start, c["n"].stop))
            result = _pick(loop, *mats, out_rows, in_cols, list(loop.sensors), list(K.inputs), sign=-1.0)
        elif kind == "closed_loop":
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            result = _pick(loop, *mats, list(range(r["y"].start, r["y"].stop)),
                           list(range(c["w"].start, c["w"].stop)), list(P.outputs), list(P.inputs))
        elif kind == "closed_loop_sensor_noise":
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            result = _pick(loop, *mats, list(range(r["y"].start, r["y"].stop)),
                           list(range(c["n"].start, c["n"].stop)), list(P.outputs), noise)
        elif kind == "quasi_open_loop":
            if opened is None:
                opened = input if input is not None else loop.actuators[0]
            opened = _names(opened, loop.actuators, "opened")
            closed_a = [a not in opened for a in loop.actuators]
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            jj = [loop.actuators.index(a) for a in opened]
            out_rows = [r["beta"].start + j for j in jj]
            in_cols = [c["w"].start + act_idx[j] for j in jj]
            result = _pick(loop, *mats, out_rows, in_cols, [ctrl_out[j] for j in jj], list(opened))
            if input is not None and _names(input, opened, "input") == opened:
                input = None
        else:  # sensitivity / complementary sensitivity
            mats = _interconnect(loop, closed_a, closed_s)
            r, c = mats[4], mats[5]
            comp = kind == "complementary_sensitivity"
            if at == "output":
                # S_o: noise -> controller input e; T_o = -(noise -> sensor output)
                rows = [r["y"].start + i for i in sen_idx] if comp else list(range(r["e"].start, r["e"].stop))
                cols = list(range(c["n"].start, c["n"].stop))
                names = list(loop.sensors)
                sign = -1.0 if comp else 1.0
            else:
                # S_i: actuator injection -> applied plant input u; T_i: -> controller output beta
                rows = list(range(r["beta"].start, r["beta"].stop)) if comp else [r["u"].start + i for i in act_idx]
                cols = [c["w"].start + i for i in act_idx]
                names = list(loop.actuators)
            result = _pick(loop, *mats, rows, cols, names, names, sign=sign)
    if input is not None or output is not None:
        result = result.subsystem(inputs=input, outputs=output)
    return result
