"""Under mpiexec, a distributed mesh stops every rank at once; serial meshes per rank run.

Distributed material points are not there yet, so a Simulation on a mesh shared by
several ranks must refuse on every rank (a refusal on one rank alone would leave the
others waiting in a collective call). Meshes on ``MPI.COMM_SELF`` are independent
serial runs, one per rank, and must give the serial answer.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

SCRIPT = """
import sys
from pathlib import Path
import numpy as np
import fe_mpm
import dolfinx.mesh
from mpi4py import MPI

comm = MPI.COMM_WORLD if sys.argv[1] == "world" else MPI.COMM_SELF
# One file per rank: the ranks' stdout reaches mpiexec interleaved, even within a line.
out = Path(sys.argv[2]) / f"rank{MPI.COMM_WORLD.rank}.txt"
mesh = dolfinx.mesh.create_rectangle(comm, [[0, 0], [1, 1]], [4, 4],
                                     dolfinx.mesh.CellType.triangle)
points = fe_mpm.seed(mesh, per_cell=3, density=2000.0)
try:
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e7, 0.3), body_force=(0, -9.81),
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))])
    sim.run(1.0, 2, progress=False)
    out.write_text(f"rank {MPI.COMM_WORLD.rank} ran: {sim.history[-1].reactions} "
                   f"{points.stress[:, 1, 1].min():.6e}")
except NotImplementedError as err:
    out.write_text(f"rank {MPI.COMM_WORLD.rank} refused: {err}")
"""


def _mpiexec() -> str:
    here = Path(sys.executable).parent / "mpiexec"
    found = str(here) if here.exists() else shutil.which("mpiexec")
    assert found, "mpiexec is neither beside the interpreter nor on the PATH"
    return found


def _run(tmp_path, comm):
    """Exit code and output of ``mpiexec -n 2``, and what each rank wrote (rank order)."""
    script = tmp_path / "scene.py"
    script.write_text(SCRIPT)
    done = subprocess.run(
        [_mpiexec(), "-n", "2", sys.executable, str(script), comm, str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ),
    )
    ranks = [tmp_path / f"rank{r}.txt" for r in range(2)]
    return (
        done.returncode,
        done.stdout + done.stderr,
        [p.read_text() if p.exists() else "" for p in ranks],
    )


def test_a_distributed_mesh_is_refused_on_every_rank(tmp_path):
    code, out, lines = _run(tmp_path, "world")
    assert code == 0, out
    assert lines[0].startswith("rank 0 refused: ") and lines[1].startswith("rank 1 refused: ")
    assert all("fe-mpm runs on one MPI rank for now" in line for line in lines)


def test_serial_meshes_run_independently_on_each_rank(tmp_path):
    code, out, lines = _run(tmp_path, "self")
    assert code == 0, out
    assert lines[0].startswith("rank 0 ran: ") and lines[1].startswith("rank 1 ran: ")
    ran = [line.split(" ran: ")[1] for line in lines]
    assert ran[0] == ran[1]  # the same serial answer on both ranks
