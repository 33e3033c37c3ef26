"""The README's first script runs as printed and gives Cook's membrane its answer.

Found 2026-12-06: the script, the first thing a new user runs, stopped in its third
step with a point outside the grid (the grid fitted the membrane, which then moved
out of it). It is now run here as the README prints it.
"""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from fe_mpm import meshes

README = Path(__file__).resolve().parents[1] / "README.md"

#: Kratos MPM's u_A,y for the u form, n = 16, ν = 0.33 (tests/test_cook.py's table).
KRATOS_U_16 = 0.2787


def first_script() -> str:
    """The code block under the README's "A first script" heading."""
    found = re.search(r"## A first script\n\n```python\n(.*?)```", README.read_text(), re.S)
    assert found, "README.md has no 'A first script' code block"
    return found.group(1)


def test_the_readmes_first_script_runs_without_a_warning_and_meets_kratos(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # its output_dir is relative
    scope: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(compile(first_script(), str(README), "exec"), scope)  # noqa: S102
    sim = scope["sim"]
    tip = sim.marker("A") - np.array(meshes.COOK_POINT_A)
    # Four load steps against Kratos's one: the README's grid moves the tip by 0.07 %.
    assert tip[1] == pytest.approx(KRATOS_U_16, rel=5e-3)
    assert len(sim.history) == 4 and (tmp_path / "out_cook" / "particles.pvd").exists()
