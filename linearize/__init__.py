"""linflex.linearize: linearization about operating points, trim, and model reduction."""

if __name__ != "linflex.linearize":
    raise ImportError(
        "this folder is the linflex.linearize package: install linflex (pip install -e .) and "
        "write 'import linflex.linearize', not 'import linearize'"
    )

__all__: list[str] = []
