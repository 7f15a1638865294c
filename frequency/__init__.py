"""linflex.frequency: poles, zeros, transfer functions, frequency response, plots, root locus.

State-space and pencil algorithms only (see ARCHITECTURE.md): no polynomial above order ~10 on
any numerical path.
"""

if __name__ != "linflex.frequency":
    raise ImportError(
        "this folder is the linflex.frequency package: install linflex (pip install -e .) and "
        "write 'import linflex.frequency', not 'import frequency'"
    )

from ._loop import TRANSFER_FUNCTION_KINDS, Loop, transfer_function
from ._response import FrequencyResponse, frequency_grid, frequency_response
from ._zeros import ZPK, BodeForm, bode_form, lambda_shift_zpk, poles, zeros, zpk

__all__: list[str] = [
    "BodeForm",
    "FrequencyResponse",
    "Loop",
    "TRANSFER_FUNCTION_KINDS",
    "ZPK",
    "bode_form",
    "frequency_grid",
    "frequency_response",
    "lambda_shift_zpk",
    "poles",
    "transfer_function",
    "zeros",
    "zpk",
]
