"""linflex.linearize: linearization about operating points, trim, and model reduction."""

if __name__ != "linflex.linearize":
    raise ImportError(
        "this folder is the linflex.linearize package: install linflex (pip install -e .) and "
        "write 'import linflex.linearize', not 'import linearize'"
    )

# --- linearization ---
_LINEARIZATION_API: list[str] = []
# --- end linearization ---

# --- reduction ---
_REDUCTION_API: list[str] = []
# --- end reduction ---

__all__ = _LINEARIZATION_API + _REDUCTION_API
