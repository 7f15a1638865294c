"""Validation at the boundary of the numerical frequency-domain API (one place, one wording)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem, ShapeError, as_linear_system

__all__ = ["checked_system", "checked_omega", "sampled_omega"]


def checked_system(sys, name: str = "sys", *, need_io: bool = True, square: bool = False, discrete: bool = False,
                   delay: bool = False) -> LinearSystem:
    """``sys`` as a real :class:`~linflex.LinearSystem`, or a :class:`~linflex.LinflexError`.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system.
    name : str
        The argument's name, for the messages.
    need_io : bool
        Require at least one input and one output.
    square : bool
        Require as many outputs as inputs (a loop).
    discrete, delay : bool
        Whether the caller handles discrete-time systems and delays (else they are refused, as
        :func:`~linflex.as_linear_system` does).

    Returns
    -------
    LinearSystem
        The system.

    Raises
    ------
    ModelError
        For an unknown type, or a discrete or delayed system where the caller does not handle it.
    ShapeError
        For a system without inputs or outputs, or a non-square loop.
    """
    sys = as_linear_system(sys, name, discrete=discrete, delay=delay)
    p, m = sys.shape
    if need_io and (p == 0 or m == 0):
        raise ShapeError(f"{name} has {p} outputs and {m} inputs: a transfer function needs at least one of each")
    if square and p != m:
        raise ShapeError(
            f"{name} must be square (the loop is closed output i to input i): it has {p} outputs and {m} inputs"
        )
    return sys


def checked_omega(omega, name: str = "omega") -> NDArray[np.float64]:
    """A 1-D array of positive finite frequencies [rad/s], or a :class:`~linflex.ShapeError`.

    Parameters
    ----------
    omega : array_like
        Frequencies [rad/s].
    name : str
        The argument's name, for the messages.

    Returns
    -------
    ndarray
        A float copy, in the given order.

    Raises
    ------
    ShapeError
        If ``omega`` is not a non-empty 1-D real array of positive finite frequencies (0 is the
        static gain, not a frequency of the imaginary axis the response is defined on: a system
        with an integrator has no value there).
    """
    arr = np.asarray(omega)
    if np.iscomplexobj(arr):
        raise ShapeError(f"{name} must hold real frequencies in rad/s, got complex values")
    try:
        w = np.array(arr, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"{name} must be an array of frequencies in rad/s: {err}") from err
    if w.ndim == 0:
        w = w.reshape(1)
    if w.ndim != 1 or w.size == 0:
        raise ShapeError(f"{name} must be a non-empty 1-D array, got shape {w.shape}")
    bad = ~np.isfinite(w) | (w <= 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ShapeError(f"{name}[{i}] = {w[i]} is not a positive finite frequency [rad/s]")
    return w


def sampled_omega(omega: NDArray[np.float64], dt: float | None, name: str = "omega") -> NDArray[np.float64]:
    """Frequencies [rad/s] of a sampled system checked against the Nyquist frequency ``pi / dt``.

    Parameters
    ----------
    omega : ndarray
        Positive frequencies [rad/s] (from :func:`checked_omega`).
    dt : float or None
        Sampling period [s]; None for a continuous system (``omega`` returned as is).
    name : str
        The argument's name, for the messages.

    Returns
    -------
    ndarray
        ``omega`` itself.

    Raises
    ------
    ShapeError
        For a frequency above the Nyquist frequency (the response of a sampled system is
        periodic in ``omega``: it has no other values there).
    """
    if dt is not None:
        nyquist = np.pi / dt
        bad = omega > nyquist * (1 + 4 * np.finfo(float).eps)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ShapeError(
                f"{name}[{i}] = {omega[i]} rad/s is above the Nyquist frequency pi/dt = {nyquist:.6g} rad/s "
                f"of the sampled system (dt = {dt} s)"
            )
    return omega
