"""linflex.frequency (see ARCHITECTURE.md)."""

if __name__ != "linflex.frequency":
    raise ImportError(
        "this folder is the linflex.frequency package: install linflex (pip install -e .) and "
        "write 'import linflex.frequency', not 'import frequency'"
    )

__all__: list[str] = []
