"""Systems of other libraries as linflex systems: python-control ``StateSpace`` and
``TransferFunction``, scipy.signal ``lti`` and ``dlti``, ``(A, B, C, D[, dt])`` and
``(num, den[, dt])`` tuples (what :func:`~linflex.system._linear.as_linear_system` takes besides
linflex's own types), and the signal names python-control accepts. Each conversion returns the
arguments ``(args, kwargs)`` of the :class:`~linflex.system.LinearSystem` that ``_linear.py``
builds (this module is below it: no import circle)."""

from __future__ import annotations

import numpy as np

from ._errors import ModelError, ShapeError
from ._realization import check_realization, siso_realization
from ._signals import check_positive, real_array


def sampling_period(dt) -> float | None:
    """``dt`` as a sampling period [s], or None for continuous time (python-control's 0 included)."""
    if dt is None or (not isinstance(dt, bool) and isinstance(dt, (int, float, np.integer, np.floating)) and dt == 0):
        return None
    if isinstance(dt, (bool, np.bool_)):
        raise ModelError(
            f"dt must be a sampling period in seconds or None, got {dt!r} (python-control's dt=True, "
            f"'discrete with unspecified period', has no frequency axis; give the period)"
        )
    return check_positive(dt, "dt")   # the sampling period [s]


def _system(*args, **kwargs) -> tuple[tuple, dict]:
    """The arguments of a LinearSystem, as given."""
    return args, kwargs


# python-control refuses "." in input and output names: to_control writes it as this character.
_CONTROL_DOT = "$"


def to_control_name(label: str) -> str:
    return label.replace(".", _CONTROL_DOT)


def from_control_name(label: str) -> str:
    return label.replace(_CONTROL_DOT, ".")


def control_dt(dt, name: str) -> float | None:
    """python-control's ``dt`` (0 continuous, True unspecified, a period) as a linflex ``dt``."""
    if dt is True:
        raise ModelError(
            f"{name}: a discrete-time system of unspecified sampling period (dt=True) has no frequency axis; "
            f"give its period (control.ss(..., dt=0.1))"
        )
    return sampling_period(dt)


def from_control(sys, name: str) -> tuple[tuple, dict]:
    """A python-control ``StateSpace`` or ``TransferFunction`` as a LinearSystem (names mapped back)."""
    import control

    if not isinstance(sys, (control.StateSpace, control.TransferFunction)):
        raise ModelError(
            f"{name}: expected a control.StateSpace or control.TransferFunction, got {type(sys).__name__}"
        )
    dt = control_dt(sys.dt, name)
    if isinstance(sys, control.TransferFunction) and sys.ninputs == sys.noutputs == 1:
        # one input and one output: the controllable canonical form of num / den, exact in the
        # coefficients (python-control's own realization without slycot). With slycot, control.ss
        # takes SLICOT's TD04AD, whose orthogonal staircase perturbs the realization by eps of its
        # norm: 1 / s^4 + 2 / (s + 1) then differs from the transfer function by 3e-4 at 1e-3
        # rad/s, an error no evaluation of the realization can see.
        A, B, C, D = siso_realization(np.asarray(sys.num[0][0], float), np.asarray(sys.den[0][0], float), name)
        return _system(A, B, C, D, inputs=[from_control_name(n) for n in sys.input_labels],
                            outputs=[from_control_name(n) for n in sys.output_labels], dt=dt)
    if isinstance(sys, control.TransferFunction):
        tf = sys
        for which, rows in (("num", tf.num), ("den", tf.den)):  # SLICOT's TD04AD does not return on them
            for i, row in enumerate(rows):
                for j, c in enumerate(row):
                    if not np.all(np.isfinite(np.asarray(c, float))):
                        raise ShapeError(f"{name}: the transfer function's {which}[{i}][{j}] has non-finite "
                                         "coefficients")
        try:
            sys = control.ss(sys)
        except Exception as err:  # python-control raises several types (ControlMIMONotImplemented, ValueError)
            raise ModelError(f"{name}: python-control cannot realize this transfer function: {err}") from err
        check_realization(tf, sys, name)
    return _system(
        sys.A, sys.B, sys.C, sys.D, states=list(sys.state_labels),
        inputs=[from_control_name(n) for n in sys.input_labels],
        outputs=[from_control_name(n) for n in sys.output_labels], dt=dt,
    )


def from_scipy(sys, name: str) -> tuple[tuple, dict]:
    """A scipy.signal ``lti`` or ``dlti`` (state space, transfer function or zeros-poles-gain)."""
    import scipy.signal

    if not isinstance(sys, (scipy.signal.lti, scipy.signal.dlti)):
        raise ModelError(f"{name}: expected a scipy.signal lti or dlti system, got {type(sys).__name__}")
    if isinstance(sys, scipy.signal.dlti) and sys.dt is True:
        raise ModelError(
            f"{name}: a scipy.signal.dlti of unspecified sampling period (dt=True, its default) has no frequency "
            f"axis; give its period (scipy.signal.dlti(..., dt=0.1))"
        )
    dt = sampling_period(sys.dt) if isinstance(sys, scipy.signal.dlti) else None
    if not isinstance(sys, scipy.signal.StateSpace):
        tf = sys.to_tf()
        num, den = np.asarray(tf.num, dtype=float), np.asarray(tf.den, dtype=float)
        # scipy's own to_ss gives a static gain a spurious state at the origin: one output is realized
        # as (num, den) is; several outputs of a static gain get no state either
        if num.ndim == 1 or num.shape[0] == 1:
            return _system(*siso_realization(num.ravel(), den, name), dt=dt)
        if np.trim_zeros(den, "f").size == 1:
            gains = [siso_realization(row, den, f"{name} (output {i})")[3] for i, row in enumerate(num)]
            return _system(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((num.shape[0], 0)), np.vstack(gains),
                                dt=dt)
    try:
        ss = sys.to_ss()
    except ValueError as err:  # scipy's tf2ss: "Improper transfer function"
        raise ModelError(f"{name}: scipy cannot realize this system: {err}") from err
    return _system(ss.A, ss.B, ss.C, ss.D, dt=dt)


def from_tuple(sys: tuple, name: str) -> tuple[tuple, dict]:
    """``(A, B, C, D[, dt])`` matrices or ``(num, den[, dt])`` polynomial coefficients."""
    if len(sys) in (4, 5):
        return _system(*sys[:4], dt=sys[4] if len(sys) == 5 else None)
    if len(sys) not in (2, 3):
        raise ModelError(
            f"{name}: a tuple must be (A, B, C, D[, dt]) or (num, den[, dt]), got {len(sys)} entries"
        )
    dt = sys[2] if len(sys) == 3 else None
    num = real_array(np.atleast_1d(sys[0]), f"{name}[0] (num)", "vector")
    den = real_array(np.atleast_1d(sys[1]), f"{name}[1] (den)", "vector")
    return _system(*siso_realization(num, den, name), dt=dt)
