"""Time simulation: nonlinear models (SUNDIALS through CasADi, or scipy) and linear systems (exact for held inputs)."""

from ._linear_response import forced_response, impulse_response, initial_response, step_response
from ._simulate import TimeResponse, simulate, time_response_plot

__all__ = [
    "TimeResponse", "simulate", "time_response_plot",
    "forced_response", "impulse_response", "initial_response", "step_response",
]
