"""The notebooks run from top to bottom (small sweeps: BATCHVEH_SMALL=1), as a user would run them."""

import os
import shutil
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))


def test_notebooks_exist():
    assert [p.name for p in NOTEBOOKS] == [
        "01_seed_scenarios.ipynb",
        "02_torque_envelopes.ipynb",
        "03_motor_sizing.ipynb",
        "04_obstacles_and_missions.ipynb",
        "05_sensitivity.ipynb",
        "06_rover_on_soil.ipynb",
        "07_motors_in_the_loop.ipynb",
    ]


# the first two (the seed's scenarios, torque envelopes) in the default run; the others (11-29 s each on 2 cores
# beside another test worker) in -m slow, where motor sizing's notebook runs beside test_size's and test_sizing_light's
DEFAULT_RUN = 2


@pytest.mark.parametrize(
    "path", [p if i < DEFAULT_RUN else pytest.param(p, marks=pytest.mark.slow) for i, p in enumerate(NOTEBOOKS)],
    ids=lambda p: p.stem,
)
def test_notebook_executes(path, tmp_path, monkeypatch):
    for f in path.parent.iterdir():  # run in a copy: no outputs or results land in the repository
        if f.is_file():
            shutil.copy(f, tmp_path / f.name)
    monkeypatch.setenv("BATCHVEH_SMALL", "1")
    nb = nbformat.read(tmp_path / path.name, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit notebooks without outputs"
    NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}, env=dict(os.environ)
    ).execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if "image/png" in o.get("data", {})]
    assert images, "the notebook shows no figure"
