"""Execute the example notebooks the way Jupyter does and store their outputs in place.

``python examples/execute_notebooks.py [NAME ...]`` runs each notebook (all by default) with a
fresh kernel in its own folder (as ``jupyter nbconvert --execute`` does), writes the outputs into
the ``.ipynb`` so readers see the figures without running anything, gives every cell an id, and
records the SHA-256 of the cells' sources in the notebook's metadata (``linflex.sources_sha256``).
``tests/test_examples.py`` executes the notebooks again and fails when a committed notebook's
sources no longer match the recorded hash, that is, when its outputs are stale.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
METADATA_KEY = "linflex"


def sources_sha256(notebook) -> str:
    """SHA-256 of the notebook's cell types and sources, in order (outputs and ids left out)."""
    digest = hashlib.sha256()
    for cell in notebook.cells:
        digest.update(json.dumps([cell.cell_type, cell.source]).encode())
    return digest.hexdigest()


def execute(path: Path, *, cwd: Path | None = None, extra_source: str | None = None, timeout: int = 600):
    """Execute the notebook at ``path`` in ``cwd`` (its own folder by default) and return it.

    ``extra_source`` is run as one more cell at the end (the tests use it to hand results back);
    it is not part of the returned notebook.
    """
    import nbformat
    from nbclient import NotebookClient

    notebook = nbformat.read(path, as_version=4)
    nbformat.validator.normalize(notebook)
    if extra_source is not None:
        notebook.cells.append(nbformat.v4.new_code_cell(extra_source))
    client = NotebookClient(notebook, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(cwd or path.parent)}})
    client.execute()
    if extra_source is not None:
        notebook.cells.pop()
    notebook.metadata.setdefault(METADATA_KEY, {})["sources_sha256"] = sources_sha256(notebook)
    return notebook


def main(argv: list[str] | None = None) -> int:
    import nbformat

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="notebook names (default: every examples/*.ipynb)")
    args = parser.parse_args(argv)
    paths = [HERE / f"{n.removesuffix('.ipynb')}.ipynb" for n in args.names] or sorted(HERE.glob("*.ipynb"))
    for path in paths:
        notebook = execute(path)
        for cell in notebook.cells:
            cell.get("metadata", {}).pop("execution", None)
        nbformat.write(notebook, path)
        print(f"{path.name}: executed, outputs stored")
    return 0


if __name__ == "__main__":
    sys.exit(main())
