"""The notebooks in examples/ run from top to bottom (their code cells as one script, figures drawn off-screen);
each checks its own results against the physics it shows, so a wrong render fails here."""

import json
import os
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NOTEBOOKS = sorted(EXAMPLES.glob("*.ipynb"))


def test_there_are_notebooks():
    assert {p.stem for p in NOTEBOOKS} >= {"prism", "rainbow", "denoise"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    nb = json.loads(path.read_text())
    assert all(not c.get("outputs") for c in nb["cells"] if c["cell_type"] == "code"), "outputs are stripped"
    source = "\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code")
    monkeypatch.chdir(EXAMPLES)
    exec(compile(source, str(path), "exec"), {"__name__": "__main__"})
    import matplotlib.pyplot as plt

    plt.close("all")
