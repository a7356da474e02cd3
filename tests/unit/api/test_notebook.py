"""examples/box_vs_existing.ipynb runs from start to end (nbclient, in a kernel of this Python): it loads,
compares, reproduces the README's three-variant table from the API (its own assertion), sweeps γ, draws and
asks the capacity. Any error in any cell fails the test."""
import nbformat
import pytest
from nbclient import NotebookClient

from conftest import ROOT

NOTEBOOK = ROOT / "examples" / "box_vs_existing.ipynb"


@pytest.mark.slow
def test_the_example_notebook_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    nb = nbformat.read(NOTEBOOK, as_version=4)
    NotebookClient(nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "the README's table is reproduced: 9 figures × 3 variants" in text
    assert any("image/png" in o.get("data", {}) for o in outputs)


def test_the_committed_notebook_has_no_outputs():
    """The notebook is kept without outputs (they are made when it runs), so that it diffs and merges as code."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not c.get("outputs") and c.get("execution_count") is None for c in nb.cells if c.cell_type == "code")
