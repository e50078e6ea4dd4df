"""The notebooks run top to bottom (issue 5): each is executed in a fresh kernel from its own
folder, as Jupyter would, on the data the project makes (and ../shared/data/real where present).
Nothing is written back: the committed copies keep the outputs of a full run."""

import os
from pathlib import Path

import pytest


nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(path, monkeypatch):
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's inline backend keeps figures
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                                     resources={"metadata": {"path": str(path.parent)}})
    client.execute()  # raises CellExecutionError naming the cell on any failure
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors
    assert any(o.get("output_type") == "display_data" for c in nb.cells
               for o in c.get("outputs", [])), "a study notebook shows at least one figure"


def test_notebooks_are_committed_with_outputs():
    """The committed notebooks read well on their own: every code cell that ran has its outputs
    and no cell holds an error."""
    assert len(NOTEBOOKS) >= 2
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        code = [c for c in nb.cells if c.cell_type == "code"]
        assert all(c.get("execution_count") for c in code), path.name
        assert not any(o.get("output_type") == "error" for c in code for o in c["outputs"])
        assert os.path.getsize(path) < 2_000_000, f"{path.name}: keep figures small"
