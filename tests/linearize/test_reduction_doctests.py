"""The Examples sections of the reduction modules run and print what they claim."""

import doctest
import importlib

import pytest

MODULES = ["_balanced", "_modal", "_exchange", "_reduction_split", "_reduction_minimal", "_reduction_svd_modes"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(f"linflex.linearize.{name}")
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
