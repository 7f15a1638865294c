"""Nonlinear time simulation of any :class:`~linflex.NonlinearModel` (SUNDIALS through CasADi, or scipy)."""

from ._simulate import TimeResponse, simulate, time_response_plot

__all__ = ["TimeResponse", "simulate", "time_response_plot"]
