"""The public names of linflex.frequency are exactly its __all__."""

import types

import linflex.frequency as pkg

EXPECTED = {
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
}


def test_public_names_are_exactly_all():
    public = {
        name for name in dir(pkg)
        if not name.startswith("_") and not isinstance(getattr(pkg, name), types.ModuleType)
    }
    assert public == set(pkg.__all__) == EXPECTED


def test_bare_name_import_refused():
    import importlib.util
    import sys
    from pathlib import Path

    import pytest

    init = Path(pkg.__file__)
    spec = importlib.util.spec_from_file_location("frequency", init)
    module = importlib.util.module_from_spec(spec)
    with pytest.raises(ImportError, match="import linflex.frequency"):
        spec.loader.exec_module(module)
    assert "frequency" not in sys.modules or sys.modules["frequency"] is not module


def test_import_does_not_load_pyplot():
    import subprocess
    import sys

    code = "import sys, linflex.frequency; print('matplotlib.pyplot' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
