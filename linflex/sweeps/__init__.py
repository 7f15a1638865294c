"""Parameter sweeps: grids and seeded samples of scene parameters, run serially, in processes or on Dask."""

from ._spec import load_sweep_spec
from ._sweep import SweepResult, parameter_grid, parameter_sample, sweep, sweep_scatter_plot, vary_scene

__all__ = ["SweepResult", "load_sweep_spec", "parameter_grid", "parameter_sample", "sweep", "sweep_scatter_plot",
           "vary_scene"]
