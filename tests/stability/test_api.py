"""The public API of linflex.stability is exactly its curated __all__."""

import types

import linflex.stability as pkg

EXPECTED = {
    "DiskMargin",
    "LoopMargins",
    "Mode",
    "ModeTable",
    "StabilityMargins",
    "modes",
    "stability_margins",
}


def test_public_names_equal_all():
    public = {n for n in dir(pkg) if not n.startswith("_") and not isinstance(getattr(pkg, n), types.ModuleType)}
    assert set(pkg.__all__) == EXPECTED
    assert public == EXPECTED
