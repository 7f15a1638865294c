"""Project-level rules from ARCHITECTURE.md and STYLE.md: packaging, imports, public API, docs."""

import doctest
import importlib
import pkgutil
import subprocess
import sys

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib
from pathlib import Path

import pytest

import linflex

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("linearize", "frequency", "stability")


def package_folders():
    for top in ("linflex", *LAYERS):
        for init in sorted((ROOT / top).rglob("__init__.py")):
            folder = init.parent.relative_to(ROOT)
            parts = folder.parts
            yield folder, ".".join(parts) if parts[0] == "linflex" else "linflex." + ".".join(parts)


def test_every_package_folder_is_listed_in_pyproject():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(config["tool"]["setuptools"]["packages"])
    for folder, name in package_folders():
        assert name in listed, f"{folder} has an __init__.py but {name!r} is not in pyproject.toml"
    mapping = config["tool"]["setuptools"]["package-dir"]
    for layer in LAYERS:
        assert mapping[f"linflex.{layer}"] == layer


@pytest.mark.parametrize("layer", LAYERS)
def test_layers_refuse_their_bare_name(layer):
    result = subprocess.run([sys.executable, "-c", f"import {layer}"], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode != 0
    assert f"import linflex.{layer}" in result.stderr


def test_import_does_not_load_pyplot():
    code = (
        "import sys, linflex, linflex.linearize, linflex.frequency, linflex.stability\n"
        "bad = [m for m in ('matplotlib.pyplot', 'matplotlib') if m in sys.modules]\n"
        "print(','.join(bad))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "matplotlib.pyplot" not in result.stdout


def test_core_imports_no_layer():
    code = "import sys, linflex\nprint([m for m in sys.modules if m.startswith(('linflex.linearize', 'linflex.frequency', 'linflex.stability'))])"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]"


def public_names(module):
    return {
        name for name in dir(module)
        if not name.startswith("_") and not isinstance(getattr(module, name), type(sys))
    }


@pytest.mark.parametrize("name", ["linflex", *(f"linflex.{layer}" for layer in LAYERS), "linflex.stability.report"])
def test_public_names_equal_all(name):
    module = importlib.import_module(name)
    extra = public_names(module) - set(module.__all__) - {"annotations"}
    missing = set(module.__all__) - set(dir(module))
    assert not extra, f"{name} exposes names not in __all__: {sorted(extra)}"
    assert not missing, f"{name}.__all__ lists missing names: {sorted(missing)}"


def test_core_public_api():
    assert set(linflex.__all__) >= {
        "LinearSystem", "SecondOrderSystem", "NonlinearModel", "OperatingPoint", "as_linear_system",
        "LinflexError", "ModelError", "NotAnEquilibriumError", "__version__",
    }


def test_linearize_public_api():
    import linflex.linearize as lz

    assert set(lz._LINEARIZATION_API) == {
        "METHODS", "JacobianBlocks", "Linearization", "TrimResult", "find_operating_point",
        "jacobian_function", "linearize", "scaled_residual", "FrozenTimeModes", "TrajectoryLinearization",
        "linearize_along", "ConstrainedLinearization", "constrained_linearization", "StiffnessShares",
        "stiffness_shares", "LinearComparison", "compare_linear_nonlinear",
    }
    assert set(lz._REDUCTION_API) == {
        "BalancedTruncation", "MinimalRealization", "ModalTruncation", "PlantControllerPartition",
        "ProjectedModesReduction", "StableSplit", "VariableExchange", "balanced_truncation", "exchange_variables",
        "minimal_realization", "modal_truncation", "plant_controller_partition", "projected_modes_reduction",
        "split_stable",
    }


def all_modules():
    names = ["linflex"]
    for info in pkgutil.walk_packages(linflex.__path__, "linflex."):
        names.append(info.name)
    return names


@pytest.mark.parametrize("name", all_modules())
def test_docstring_examples_run(name):
    # STYLE.md rule 18: examples in docstrings run. Doctest through the installed names, since
    # the layer folders refuse import under their bare names.
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_py_typed_is_shipped():
    assert (ROOT / "linflex" / "py.typed").exists()
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "py.typed" in config["tool"]["setuptools"]["package-data"]["linflex"]


def test_cli_version():
    result = subprocess.run([sys.executable, "-m", "linflex.cli", "--version"], capture_output=True, text=True)
    assert result.stdout.strip() == f"linflex {linflex.__version__}"
