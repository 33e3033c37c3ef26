"""What ParaView reads is what the points carry: every written field read back and compared."""

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes, scenes
from fe_mpm.io import ParticleWriter
from fe_mpm.output import SimulationOutput
from fe_mpm.particles import MaterialPoints


def _points(g: int, n: int = 7, seed: int = 3) -> MaterialPoints:
    rng = np.random.default_rng(seed)
    x0 = rng.random((n, g))
    points = MaterialPoints(
        x=x0 + 0.1 * rng.random((n, g)),
        volume=rng.random(n) + 0.5,
        mass=rng.random(n) + 2.0,
        F=np.eye(g) + 0.1 * rng.random((n, g, g)),
        x0=x0,
        velocity=rng.standard_normal((n, g)),
    )
    stress = rng.standard_normal((n, 3, 3))
    points.stress = stress + np.swapaxes(stress, 1, 2)
    points.cell = rng.integers(0, 50, n).astype(np.int32)
    points.history = {"plastic_strain": rng.random(n), "be": rng.random((n, 3, 3))}
    return points


def _frames(pvd) -> list[tuple[float, str]]:
    root = ET.parse(pvd).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    (collection,) = list(root)
    assert collection.tag == "Collection"
    assert not (root.text or "").strip() and not (collection.tail or "").strip()
    assert all(d.tag == "DataSet" for d in collection)
    return [(float(d.get("timestep")), d.get("file")) for d in collection]


@pytest.mark.parametrize("g", [2, 3])
def test_every_field_is_written_as_the_points_carry_it(tmp_path, g):
    points = _points(g)
    n = len(points)
    writer = ParticleWriter(tmp_path / "new" / "folder", name="pts")  # made, parents too
    extra = np.arange(n, dtype=float) * 0.25
    vector = np.arange(3 * n, dtype=float).reshape(n, 3)
    path = writer.write(0.125, points, marker=extra, arrow=vector)
    assert path == tmp_path / "new" / "folder" / "pts_000000.vtu"
    mesh = meshio.read(path)
    assert mesh.points.shape == (n, 3)
    for name in ("displacement", "velocity"):
        assert mesh.point_data[name].shape == (n, 3), name
    assert np.array_equal(mesh.point_data["arrow"], vector)
    assert np.array_equal(mesh.points[:, :g], points.x)
    assert np.all(mesh.points[:, g:] == 0.0)
    assert np.array_equal(mesh.cells_dict["vertex"].ravel(), np.arange(n))
    data = mesh.point_data
    assert np.array_equal(data["displacement"][:, :g], points.x - points.x0)
    assert np.all(data["displacement"][:, g:] == 0.0)
    assert np.array_equal(data["velocity"][:, :g], points.velocity)
    assert np.all(data["velocity"][:, g:] == 0.0)
    assert np.array_equal(data["volume"], points.volume)
    assert np.array_equal(data["mass"], points.mass)
    F = data["deformation_gradient"].reshape(n, 3, 3)
    assert np.array_equal(F[:, :g, :g], points.F)
    if g == 2:
        assert np.all(F[:, 2, :2] == 0) and np.all(F[:, :2, 2] == 0) and np.all(F[:, 2, 2] == 1)
    assert np.array_equal(data["stress"].reshape(n, 3, 3), points.stress)
    assert np.allclose(
        data["pressure"], -np.trace(points.stress, axis1=1, axis2=2) / 3, rtol=0, atol=1e-15
    )
    assert np.array_equal(data["cell"], points.cell)
    assert np.array_equal(data["plastic_strain"], points.history["plastic_strain"])
    assert np.array_equal(data["be"].reshape(n, 3, 3), points.history["be"])
    assert np.array_equal(data["marker"].ravel(), extra)


def test_the_collection_lists_every_frame_with_its_time_and_a_new_writer_clears_old_frames(
    tmp_path,
):
    points = _points(2)
    writer = ParticleWriter(tmp_path)
    times = (0.0, 0.1 + 1e-9, 2.5)
    for t in times:
        points.x += 0.01
        writer.write(t, points)
    frames = _frames(writer.pvd)
    assert writer.pvd == tmp_path / "particles.pvd"
    assert [f for _, f in frames] == [f"particles_{k:06d}.vtu" for k in range(3)]
    assert [t for t, _ in frames] == pytest.approx(times, rel=1e-10, abs=0)
    last = meshio.read(tmp_path / frames[-1][1])
    assert np.array_equal(last.points[:, :2], points.x)

    ParticleWriter(tmp_path)  # a new run into the same folder
    assert not list(tmp_path.glob("particles_*.vtu"))
    (tmp_path / "other_000000.vtu").write_text("")
    ParticleWriter(tmp_path, name="particles")
    assert (tmp_path / "other_000000.vtu").exists()


class _TwoRanks:
    """A stand-in communicator: rank ``rank`` of two whose points are ``held`` by rank."""

    size = 2

    def __init__(self, rank: int, held: list[bool]):
        self.rank, self._held = rank, held

    def Barrier(self) -> None:
        pass

    def allgather(self, value: bool | None) -> list[bool | None]:
        if value is None:  # the set-up's exchange of errors: none on either rank
            return [None] * self.size
        assert value == self._held[self.rank]
        return list(self._held)


def test_a_rank_without_points_writes_no_piece_and_every_listed_piece_reads_back(tmp_path):
    """Found on a new user's run on two ranks (2026-12-05): the rank whose cells held no
    points wrote an empty .vtu, valid VTK that meshio cannot read back ("need at least
    one array to concatenate"). It now writes none, and the .pvd lists the pieces
    written; a time with no points anywhere keeps rank 0's empty piece (which ParaView
    reads and meshio does not)."""
    points, empty = _points(2), _points(2, n=0)
    writers = [ParticleWriter(tmp_path, comm=_TwoRanks(r, [True, False])) for r in (1, 0)]
    writers[0].write(0.5, empty)  # rank 1 first: rank 0 then writes the .pvd
    writers[1].write(0.5, points)
    assert [f for _, f in _frames(tmp_path / "particles.pvd")] == ["particles_000000_r0.vtu"]
    assert sorted(f.name for f in tmp_path.glob("*.vtu")) == ["particles_000000_r0.vtu"]
    assert np.array_equal(meshio.read(tmp_path / "particles_000000_r0.vtu").points[:, :2], points.x)
    nobody = ParticleWriter(tmp_path / "none", comm=_TwoRanks(0, [False, False]))
    nobody.write(1.0, empty)
    assert [f for _, f in _frames(nobody.pvd)] == ["particles_000000_r0.vtu"]
    assert (tmp_path / "none" / "particles_000000_r0.vtu").exists()


def test_a_run_writes_the_state_of_its_points_at_every_step(tmp_path):
    """Cook, J2, u-p, 3 steps with output: the frames hold t = 0 and each step's time,
    and the last frame is the points' final state (stress, F, plastic strain, position)."""
    material = fe_mpm.J2Plasticity(70.0, 0.499, 0.243, 0.135)
    sim = scenes.cook_membrane(
        4,
        formulation="up",
        material=material,
        traction=0.1125,
        output_dir=tmp_path,
        reactions={"clamp": meshes.COOK_CLAMPED},
    )
    reports = sim.run(1.0, 3, progress=False)
    frames = _frames(tmp_path / "particles.pvd")
    assert [t for t, _ in frames] == pytest.approx([0.0, 1 / 3, 2 / 3, 1.0], rel=1e-9)
    # steps.csv: a row per step with its markers and reactions, as the reports give them.
    steps = np.genfromtxt(tmp_path / "steps.csv", delimiter=",", names=True)
    assert list(steps["step"]) == [1, 2, 3]
    assert {"A_x", "A_y", "clamp_x", "clamp_y"} <= set(steps.dtype.names)
    for name, position in reports[-1].markers.items():
        np.testing.assert_array_equal([steps[f"{name}_x"][-1], steps[f"{name}_y"][-1]], position)
    for name, force in reports[-1].reactions.items():
        np.testing.assert_array_equal([steps[f"{name}_x"][-1], steps[f"{name}_y"][-1]], force)
    first = meshio.read(tmp_path / frames[0][1]).point_data
    assert np.all(first["stress"] == 0.0) and np.all(first["displacement"] == 0.0)
    last = meshio.read(tmp_path / frames[-1][1])
    points, n = sim.points, len(sim.points)
    assert np.array_equal(last.points[:, :2], points.x)
    assert np.array_equal(last.point_data["stress"].reshape(n, 3, 3), points.stress)
    assert np.array_equal(
        last.point_data["deformation_gradient"].reshape(n, 3, 3)[:, :2, :2], points.F
    )
    assert np.array_equal(last.point_data["plastic_strain"], points.history["plastic_strain"])
    assert last.point_data["plastic_strain"].max() > 0


def test_every_frame_of_a_run_writes_the_grid_too(tmp_path, monkeypatch):
    """Found 2026-12-06 by a review: after the change that leaves a failed attempt's
    grid out, every frame but t = 0 was written without the grid's fields."""
    written = []
    write = SimulationOutput.write

    def spy(self, step, t, points, *args):
        done = write(self, step, t, points, *args)
        if done:
            written.append((step, args[2] if len(args) > 2 else True))
        return done

    monkeypatch.setattr(SimulationOutput, "write", spy)
    sim = scenes.cook_membrane(4, output_dir=tmp_path)
    sim.run(1.0, 2, progress=False)
    sim.close()
    assert written == [(0, True), (1, True), (2, True)]


def _pulled_past_its_limit(folder, **options):
    """A Tresca block pulled on its top past its limit load: it stops in step 5."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (2.0, 1.5), (12, 9))
    c = meshes.cell_centroids(mesh)
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.flatnonzero((c[:, 1] < 1) & (c[:, 0] < 1)))
    pull = fe_mpm.PointTraction(
        "pull",
        np.c_[np.linspace(1 / 12, 11 / 12, 6), np.ones(6)],
        np.full(6, 1 / 6),
        (400.0, 0.0),
        scale=lambda t: t,
    )
    return fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.MohrCoulomb.tresca(1e4, 0.3, 100.0),
        "u",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        point_tractions=[pull],
        output_dir=folder,
        output_every=3,
        min_step=0.02,
        **options,
    )


@pytest.mark.parametrize("loop", ["run", "step"])
def test_a_run_that_stops_writes_its_last_accepted_step(tmp_path, loop):
    """Found 2026-12-06 by a helper: with output_every=3 a run that stopped in step 5 had
    written steps 1–3 only, so step 4, the one showing the limit, was in neither the
    frames nor steps.csv; a script's own loop of steps lost it too, even after close()."""
    sim = _pulled_past_its_limit(tmp_path)
    with pytest.raises(fe_mpm.ConvergenceError, match="in step 5"):
        if loop == "run":
            sim.run(1.0, 20, progress=False)
        else:
            for k in range(1, 21):
                sim.step(k / 20)
    sim.close()
    assert sim.step_number == 4
    steps = np.genfromtxt(tmp_path / "steps.csv", delimiter=",", names=True)
    assert list(steps["step"]) == [1, 2, 3, 4]
    frames = _frames(tmp_path / "particles.pvd")
    assert frames[-1][0] == pytest.approx(sim.t, rel=1e-12)
    last = meshio.read(tmp_path / frames[-1][1])
    assert np.array_equal(last.points[:, :2], sim.points.x)


def test_a_run_with_point_domains_writes_each_domain_as_a_cell_with_its_points_fields(tmp_path):
    """Cook, Neo-Hookean, u-p, point domains, 5 N over 4 steps on n = 8:
    ``domains.pvd`` lists the frames of ``particles.pvd``, and in each frame every
    point's domain is one triangle of its corners, centred on the point, with
    the point's stress and volume; the triangles' areas add up to the body's volume
    (no domain is redrawn here, so the domains tile the body as they move)."""
    sim = scenes.cook_membrane(
        8, traction=5 / 16, margin=2, output_dir=tmp_path, point_domains=True
    )
    reports = sim.run(1.0, 4, progress=False)
    assert sim.domains.resets == 0
    # steps.csv as without domains (for an hour of 2026-12-06 it was not written:
    # the domains' step sets the output aside; a reviewer's catch).
    steps = np.genfromtxt(tmp_path / "steps.csv", delimiter=",", names=True)
    assert list(steps["step"]) == [1, 2, 3, 4]
    np.testing.assert_array_equal(steps["t"], [r.t for r in reports])
    frames = _frames(tmp_path / "domains.pvd")
    assert [t for t, _ in frames] == [t for t, _ in _frames(tmp_path / "particles.pvd")]
    assert len(frames) == 5
    for _, name in (frames[0], frames[-1]):
        mesh = meshio.read(tmp_path / name)
        (block,) = mesh.cells
        assert block.type == "triangle" and len(block.data) == len(sim.points)
        corners = mesh.points[block.data][:, :, :2]
        centroids = corners.mean(axis=1)
        particles = meshio.read(tmp_path / name.replace("domains", "particles"))
        np.testing.assert_allclose(centroids, particles.points[:, :2], rtol=0, atol=1e-12)
        for field in ("stress", "volume", "deformation_gradient"):
            assert np.array_equal(mesh.cell_data[field][0], particles.point_data[field])
        edges = corners[:, 1:] - corners[:, :1]
        areas = 0.5 * np.linalg.det(edges)
        assert np.all(areas > 0)  # all turned one way, as VTK wants (found by a helper)
        assert areas.sum() == pytest.approx(particles.point_data["volume"].sum(), rel=1e-10)
    # The last frame's domains, each with its corners in some order.
    assert np.array_equal(np.sort(corners, axis=1), np.sort(sim.domains.corners, axis=1))
    # Cells as the grid's input numbers them: the same on any number of ranks.
    original = sim.mesh.topology.original_cell_index[sim.points.cell]
    assert np.array_equal(particles.point_data["cell"], original)
    assert np.array_equal(mesh.cell_data["cell"][0], original)


def test_a_new_run_clears_what_an_earlier_one_left_in_its_folder(tmp_path):
    """A run with point domains and a pressure field, then a plain one in the same
    folder: the first run's ``domains.pvd`` (ParaView showed domains past the second
    run's end), ``grid_pressure.bp`` and an earlier ``walls.csv`` are gone; a name
    that would split a CSV column is refused."""
    scenes.cook_membrane(4, formulation="up", traction=0.1, output_dir=tmp_path,
                         point_domains=True).run(1.0, 1, progress=False)  # fmt: skip
    (tmp_path / "walls.csv").write_text("step,t,wall\n")
    assert (tmp_path / "domains.pvd").exists() and (tmp_path / "grid_pressure.bp").exists()
    sim = scenes.cook_membrane(4, formulation="u", traction=0.1, output_dir=tmp_path)
    sim.run(1.0, 1, progress=False)
    sim.close()
    left = {p.name for p in tmp_path.iterdir()}
    assert not {"domains.pvd", "grid_pressure.bp", "walls.csv"} & left
    assert not any(name.startswith("domains_") for name in left)
    assert {"particles.pvd", "grid.bp", "steps.csv"} <= left
    with pytest.raises(ValueError, match=r"marker name 'tip,left' must be .* without commas"):
        sim.add_marker("tip,left", (48.0, 52.0))


def test_a_grid_cut_by_create_submesh_writes_its_output_and_refuses_a_checkpoint(tmp_path):
    """A grid cut from another by ``dolfinx.mesh.create_submesh`` (a gate's slot, a
    weir plate) has no original cell indices in DOLFINx 0.11: the first output
    stopped with "Mixed topology unsupported" (a helper's sluice gate, 2026-12-06;
    ``benchmarks/tank_drain.py`` with its default output too). Output now numbers
    the cells globally; a checkpoint, which needs the input numbering, is refused
    with what to do."""
    from fe_mpm._dolfinx import dolfinx

    whole = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    keep = np.flatnonzero(meshes.cell_centroids(whole)[:, 1] < 0.75).astype(np.int32)
    grid = dolfinx.mesh.create_submesh(whole, 2, keep)[0]
    points = fe_mpm.seed(grid, 3, density=1.0, cells=np.arange(8))
    sim = fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(1e3, 0.3),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.0, -1.0),
        output_dir=tmp_path,
    )
    sim.run(1.0, 1, progress=False)
    frame = meshio.read(sorted(tmp_path.glob("particles*.vtu"))[-1])
    assert np.array_equal(np.sort(frame.point_data["cell"]), np.sort(points.cell))
    with pytest.raises(ValueError, match="no original cell indices.*create_submesh"):
        sim.checkpoint(tmp_path / "checkpoints")
    assert not list(tmp_path.glob("checkpoints/*"))  # no half-made folder left


def test_the_progress_bar_ends_at_its_total_when_the_step_shares_overshoot_it():
    """Each step counts as its share of the nominal step, and shares summed from step
    times overshoot the total by round-off: tqdm warned of clamping at the last step
    (the copper Taylor bar's runs, found by a helper, 2026-12-07)."""
    import warnings
    from types import SimpleNamespace

    from fe_mpm.report import ProgressBar

    bar = ProgressBar(10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for k in range(10):
            step = (k + 1) * 0.1 - k * 0.1  # 0.1 give or take an ulp or two
            bar.update(SimpleNamespace(t=0.1 * k, dt=step * (1 + 1e-12), newton_iterations=1), 0.1)
        bar.close()
    assert bar._bar.n == 10
