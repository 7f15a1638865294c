"""linflex.stability (see ARCHITECTURE.md)."""

if __name__ != "linflex.stability":
    raise ImportError(
        "this folder is the linflex.stability package: install linflex (pip install -e .) and "
        "write 'import linflex.stability', not 'import stability'"
    )

__all__: list[str] = []
