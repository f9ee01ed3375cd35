"""Lessons as notebooks: jupytext reads a lesson's .py as it is, nbclient runs it headless in a Jupyter kernel.

The notebook must print the same figures as the script (checked by the same
function as tests/test_lessons.py), write its recording and figures, and show the
recording in an inline Rerun viewer (a rerun-notebook widget in its outputs).
"""

from __future__ import annotations

import os
from pathlib import Path

import jupytext
import nbformat
from nbclient import NotebookClient

from tests.test_lessons import LESSONS, ROOT, check_11

WIDGET = "application/vnd.jupyter.widget-view+json"


def run_notebook(name: str, out_dir: Path, monkeypatch) -> tuple[str, nbformat.NotebookNode]:
    """Execute lesson ``name`` as a notebook in quick mode; returns (its stdout, the executed notebook)."""
    nb = jupytext.read(LESSONS / f"{name}.py")
    assert len(nb.cells) > 3  # the script is split into cells, not run as one
    monkeypatch.setenv("PHYS2D_LESSON", name)  # the kernel inherits the environment
    monkeypatch.setenv("PHYS2D_LESSON_ARGS", f"--quick --out {out_dir}")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    monkeypatch.setenv("MPLBACKEND", "Agg")  # no GUI in a headless kernel
    client = NotebookClient(nb, kernel_name="python3", timeout=600, resources={"metadata": {"path": str(LESSONS)}})
    client.execute()
    stdout = "".join(
        o.get("text", "")
        for cell in nb.cells
        if cell.cell_type == "code"
        for o in cell.outputs
        if o.output_type == "stream" and o.name == "stdout"
    )
    return stdout, nb


def test_lesson_11_runs_as_a_notebook_with_the_viewer_inline(tmp_path, monkeypatch):
    out, nb = run_notebook("11_catto_figures", tmp_path, monkeypatch)
    errors = [o for cell in nb.cells for o in cell.get("outputs", []) if o.output_type == "error"]
    assert not errors, errors
    assert out.startswith("CLAIM: ") and "\nTAKEAWAY: " in out
    check_11(out, tmp_path)  # the same figures the script prints, held to the same expectations
    rrd = tmp_path / "11_catto_figures.rrd"
    assert f"rerun {rrd}" in out
    widgets = [o for cell in nb.cells for o in cell.get("outputs", []) if WIDGET in o.get("data", {})]
    assert widgets, "no inline viewer in the notebook's outputs"
    assert not list(LESSONS.glob("*.ipynb"))  # nothing written beside the lessons: the .py stays the only source
