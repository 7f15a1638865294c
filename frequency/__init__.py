"""linflex.frequency: poles, zeros, transfer functions, frequency response, plots, root locus.

State-space and pencil algorithms only (see ARCHITECTURE.md): no polynomial above order ~10 on
any numerical path. Plot functions import matplotlib when called.

This package holds the one frequency-domain engine of linflex, which ``linflex.stability`` and
``linflex.linearize`` use (and which imports neither): ``_spectrum.py`` (the spectrum policy:
system scale, rigid-body and undamped poles, ``rigid_tol``, indentations), ``_evaluate.py`` (the
one transfer evaluator, with an a-posteriori error estimate per point), the grid policy
(``frequency_grid``), the encirclement count (``_nyquist.count_encirclements``, clockwise,
``N = Z - P``), the zeros (``_zeros``) and the H-infinity norm (``_hinf``); ``_checks.py`` validates input at the boundary.
"""

if __name__ != "linflex.frequency":
    raise ImportError(
        "this folder is the linflex.frequency package: install linflex (pip install -e .) and "
        "write 'import linflex.frequency', not 'import frequency'"
    )

from linflex.system import PlotHandle

from ._hinf import HinfNorm, hinf_norm
from ._locus import RootLocus, root_locus
from ._loop import TRANSFER_FUNCTION_KINDS, Loop, transfer_function
from ._nyquist import NyquistResponse, nyquist_response
from ._plot import bode_envelope_plot, bode_plot, nichols_plot, nyquist_plot, root_locus_plot, sigma_plot
from ._polynomial import realize_polynomial
from ._response import FrequencyResponse, frequency_grid, frequency_response
from ._zeros import ZPK, BodeForm, bode_form, lambda_shift_zpk, poles, zeros, zpk

__all__: list[str] = [
    "BodeForm",
    "FrequencyResponse",
    "HinfNorm",
    "Loop",
    "NyquistResponse",
    "PlotHandle",
    "RootLocus",
    "TRANSFER_FUNCTION_KINDS",
    "ZPK",
    "bode_envelope_plot",
    "bode_form",
    "bode_plot",
    "frequency_grid",
    "frequency_response",
    "hinf_norm",
    "lambda_shift_zpk",
    "nichols_plot",
    "nyquist_plot",
    "nyquist_response",
    "poles",
    "realize_polynomial",
    "root_locus",
    "root_locus_plot",
    "sigma_plot",
    "transfer_function",
    "zeros",
    "zpk",
]
