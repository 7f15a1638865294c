"""Sampled and delayed systems on the continuous engine, exactly.

The frequency-domain engine (grids, crossings, Nyquist count, disk margins) works on the
imaginary axis of a continuous system. Two exact reductions bring the other systems there:

- **Delays** ``exp(-s tau)`` multiply the channels of ``G(s)``: the evaluator
  (:class:`AxisEvaluator`) evaluates the undelayed ``G`` and multiplies by
  ``exp(-s (tau_out_i + tau_in_j))``, no approximation. The structure (poles, grid) is the
  undelayed system's: a delay has no poles.
- **Sampled systems** are analysed on the w-plane, ``z = (1 + s T/2) / (1 - s T/2)``
  (:func:`linflex.system.w_plane`): the unit circle is the imaginary axis, the outside of the
  disk the right half-plane, so magnitudes, phases, margins and encirclements are unchanged and
  a frequency ``nu`` of the w-plane is the real frequency ``omega = (2/T) arctan(nu T/2)`` [rad/s].
  The engine takes its structure (poles, zeros, grids) from the w-plane system, and the values
  from the discrete system itself, evaluated at ``z`` by the same evaluator (so the a-posteriori
  error estimate is the one of the discrete evaluation, with no rounding of the map in the
  values); whole-period delays are the exact factors ``z^-k``. A pole at ``z = -1`` (an undamped
  oscillation at the Nyquist frequency) has no w-plane image and is refused by ``w_plane``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem
from linflex.system import w_plane

from ._evaluate import TransferEvaluator

__all__ = ["AxisEvaluator", "SensitivityEvaluator", "axis_evaluator", "engine_system"]


def engine_system(sys: LinearSystem) -> LinearSystem:
    """The continuous, undelayed system whose structure the engine analyses.

    A continuous system without its delays (their factors have modulus 1 on the axis and no
    poles), or the w-plane image of a discrete one (its whole-period delays realized exactly).
    """
    if sys.is_discrete:
        return w_plane(sys)[0]
    if sys.has_delay:
        return sys.with_(input_delay=None, output_delay=None)
    return sys


def axis_evaluator(sys: LinearSystem, method: str = "auto", rtol: float = 1e-11, second_order=None):
    """A :class:`TransferEvaluator` for a plain continuous system, else an :class:`AxisEvaluator`."""
    if not sys.is_discrete and not sys.has_delay:
        return TransferEvaluator(sys, method, rtol, second_order)
    return AxisEvaluator(sys, method, rtol)


class AxisEvaluator:
    """The engine's evaluator for a delayed or sampled system (the interface of :class:`TransferEvaluator`).

    ``at(s)`` takes points ``s`` of the engine's plane (the w-plane for a sampled system) and
    returns ``G`` there, delays included; ``__call__(omega)`` is ``at(j omega)``.
    """

    def __init__(self, sys: LinearSystem, method: str = "auto", rtol: float = 1e-11) -> None:
        self.original = sys
        self.base = TransferEvaluator(sys.with_(input_delay=None, output_delay=None), method, rtol)
        self.engine = engine_system(sys)
        self.sys = self.engine
        self.dt = sys.dt
        self.tau = sys.output_delay[:, None] + sys.input_delay[None, :]
        self.periods = np.round(self.tau / sys.dt).astype(int) if sys.is_discrete else None
        self.D = np.asarray(self.engine.D, dtype=float) if sys.is_discrete else self.base.D
        self.shape = self.base.shape
        self._poles = None

    # the evaluator's bookkeeping is the base evaluator's
    @property
    def error(self) -> float:
        return self.base.error

    @property
    def worst(self) -> complex:
        return self.base.worst

    @property
    def last_error(self) -> NDArray[np.float64]:
        return self.base.last_error

    @property
    def n_evaluations(self) -> int:
        return self.base.n_evaluations

    @property
    def label(self) -> str:
        return self.base.label

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Poles of the engine system [1/s] (w-plane poles for a sampled system)."""
        if self._poles is None:
            if self.dt is None:
                self._poles = self.base.poles
            else:
                A = self.engine.A
                self._poles = np.linalg.eigvals(A) if A.shape[0] else np.zeros(0, complex)
        return self._poles

    def point(self, s) -> NDArray[np.complex128]:
        """The point where the system itself is evaluated: ``s``, or ``z`` for a sampled system."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        if self.dt is None:
            return s
        h = 0.5 * self.dt * s
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (1.0 + h) / (1.0 - h)
        return np.where(np.isinf(s), -1.0 + 0j, z)

    def at(self, s) -> NDArray[np.complex128]:
        """``G`` at engine points ``s`` [1/s], delays included, shape ``(n_s, p, m)``."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        x = self.point(s)
        G = self.base.at(x)
        if self.dt is None:
            if not self.tau.any():
                return G
            factor = np.exp(-s[:, None, None] * self.tau[None])
        elif self.periods.any():
            factor = x[:, None, None] ** (-self.periods[None])
        else:
            return G
        # at a pole (G infinite) the factor would make inf * 0j = nan: the value stays infinite
        with np.errstate(invalid="ignore"):
            return np.where(np.isfinite(G), G * factor, G)

    def __call__(self, omega) -> NDArray[np.complex128]:
        """``G`` at ``j omega`` of the engine's axis, shape ``(n_omega, p, m)`` (``omega`` [rad/s])."""
        return self.at(1j * np.atleast_1d(np.asarray(omega, dtype=float)))

    def siso(self, omega) -> NDArray[np.complex128]:
        """``G`` of a 1x1 system at ``j omega`` [rad/s] of the engine's axis, as a 1-D array."""
        return self(omega)[:, 0, 0]

    def snap_axis(self, spec) -> int:
        """The continuous policy's snapping, for a delayed continuous system; none on the unit circle.

        Parameters
        ----------
        spec : Spectrum
            The classified poles.

        Returns
        -------
        int
            The number of eigenvalues moved.
        """
        return self.base.snap_axis(spec) if self.dt is None else 0

    def cause(self, s: complex) -> str:
        """Why the evaluation at the engine point ``s`` is inaccurate, in words."""
        return self.base.cause(complex(self.point(s)[0]))

    def warn_if_inaccurate(self, what: str, threshold: float = 1e-4, stacklevel: int = 3) -> None:
        """As :meth:`TransferEvaluator.warn_if_inaccurate` (the point named in the system's own plane)."""
        self.base.warn_if_inaccurate(what, threshold, stacklevel + 1)


class SensitivityEvaluator:
    """``S = (I + L)^-1`` from an evaluator of ``L``, for a delayed loop (whose ``S`` is not rational).

    The relative error of ``S`` is bounded to first order by ``||S|| ||L|| e_L`` with ``e_L``
    the relative error of ``L`` (``dS = -S dL S``). ``poles`` are the given closed-loop poles
    (a Pade approximation's: they only place grid points).
    """

    def __init__(self, ev_L, poles: NDArray[np.complex128]) -> None:
        self.ev_L = ev_L
        m = ev_L.D.shape[0]
        self.eye = np.eye(m)
        self.D = np.linalg.inv(self.eye + ev_L.D)
        self.shape = (m, m)
        self.poles = np.asarray(poles, dtype=complex)
        self.error = 0.0
        self.worst = complex("nan")
        self.last_error = np.zeros(0)
        self.n_evaluations = 0
        self.label = ev_L.label

    def at(self, s) -> NDArray[np.complex128]:
        """``S`` at engine points ``s`` [1/s], shape ``(n_s, m, m)``."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        L = self.ev_L.at(s)
        finite = np.all(np.isfinite(L), axis=(1, 2))
        S = np.zeros(L.shape, dtype=complex)  # S = 0 where L is infinite (a pole of L on the contour)
        rel = np.zeros(s.size)
        if np.any(finite):
            with np.errstate(all="ignore"):
                S[finite] = np.linalg.inv(self.eye[None] + L[finite])
                rel[finite] = (self.ev_L.last_error[finite] * np.linalg.norm(L[finite], 2, axis=(1, 2))
                               * np.linalg.norm(S[finite], 2, axis=(1, 2)))
        rel = np.where(np.isfinite(rel), rel, np.inf)
        self.last_error = rel
        self.n_evaluations += s.size
        if rel.size and rel.max() > self.error:
            j = int(np.argmax(rel))
            self.error, self.worst = float(rel[j]), complex(s[j])
        return S

    def __call__(self, omega) -> NDArray[np.complex128]:
        """``S(j omega)`` (``omega`` [rad/s] of the engine's axis), shape ``(n_omega, m, m)``."""
        return self.at(1j * np.atleast_1d(np.asarray(omega, dtype=float)))

    def siso(self, omega) -> NDArray[np.complex128]:
        """``S(j omega)`` of a single loop as a 1-D array (``omega`` [rad/s])."""
        return self(omega)[:, 0, 0]

    def cause(self, s: complex) -> str:
        """Why ``S`` at ``s`` is inaccurate: ``L``'s cause, amplified by ``||S||`` near ``-1``."""
        return f"{self.ev_L.cause(s)}, amplified by |S| where L is near -1"
