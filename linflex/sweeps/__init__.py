"""Parameter sweeps: grids and seeded samples of scene parameters, run serially, in processes or on Dask."""

from ._cases import parameter_grid, parameter_sample, vary_scene
from ._spec import load_sweep_spec
from ._sweep import SweepResult, sweep, sweep_scatter_plot

__all__ = ["SweepResult", "load_sweep_spec", "parameter_grid", "parameter_sample", "sweep", "sweep_scatter_plot",
           "vary_scene"]
