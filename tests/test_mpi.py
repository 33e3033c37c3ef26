"""fe-mpm under ``mpiexec``: a distributed grid gives the serial answer (issue: MPI).

Each test runs a script under ``mpiexec -n 1, 2, 3`` (the venv ships ``mpiexec``; two
cores, so three ranks oversubscribe and test correctness, not speed). Each rank writes
what it saw to its own file: the ranks' stdout reaches ``mpiexec`` interleaved.

What is distributed so far: static and dynamic (Newmark) u and u-p steps with grid
supports and loads and with boundary points (PointDirichlet, PointTraction), points in
the cells each rank owns and moving to the rank whose cell they enter, markers,
reactions and point output.

Tolerances: the ranks sum the same terms in another order and MUMPS factorises in
parallel, so the answers differ from serial by round-off: measured up to 1.2e-12
relative on the tip and the vertical reaction; the bounds are 1e-10 (and 1e-9 N absolute on the
clamp's horizontal force, zero to Newton's tolerance).
"""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

SCRIPT = """
import json, sys
from pathlib import Path
import numpy as np
import fe_mpm
import dolfinx
from fe_mpm import meshes, parallel
from mpi4py import MPI

case, folder = sys.argv[1], Path(sys.argv[2])
rank = MPI.COMM_WORLD.rank
out = folder / f"rank{rank}_{MPI.COMM_WORLD.size}.json"

def cook(formulation, n, steps, load=1 / 16, margin=None, fail_at=(), restore=None,
         repartition=False, per_cell=1, **options):
    if margin is None:
        margin = 0 if steps == 1 else max(1, -(-n // 16))
    scene = meshes.cook_membrane(n=n, margin=margin)
    points = fe_mpm.seed(scene.mesh, per_cell=per_cell, density=1000.0,
                         cells=meshes.body_cells(scene))
    sim = fe_mpm.Simulation(
        scene.mesh, points, fe_mpm.NeoHookean(E=70.0, nu=0.499, density=1000.0),
        formulation=formulation, facet_tags=scene.facet_tags,
        dirichlet=[fe_mpm.Dirichlet(meshes.COOK_CLAMPED)],
        tractions=[fe_mpm.Traction(meshes.COOK_LOADED, (0.0, load), scale=lambda t: t)],
        reactions={"clamp": meshes.COOK_CLAMPED}, **options)
    sim.add_marker("A", meshes.COOK_POINT_A)
    step, failed = sim.step, []

    def failing_once(t_new, rebin=True):  # as Newton may, once the points are re-binned
        if sim.step_number + 1 in fail_at and rebin and sim.step_number + 1 not in failed:
            failed.append(sim.step_number + 1)
            sim.prepare_step(t_new)  # tracked (and migrated) before it fails
            raise fe_mpm.ConvergenceError("made to fail")
        return step(t_new, rebin)

    sim.step = failing_once
    if restore is not None:
        sim.restore(restore)
    ghosts = []

    def after(report):  # after every step
        ghosts.append(ghost_facets(sim))
        if repartition:
            sim.rebalance()

    reports = sim.run(t_end=1.0, n_steps=steps - sim.step_number, progress=False, on_step=after)
    sim.close()
    return {
        "iterations": [r.newton_iterations for r in reports],
        "tip": (sim.marker("A") - meshes.COOK_POINT_A).tolist(),
        "clamp": reports[-1].reactions["clamp"].tolist(),
        "occupied": reports[-1].occupied_cells,
        "points": len(points),
        "migrated": sum(r.migrated_points for r in reports),
        "imbalance": reports[-1].point_imbalance,
        "held": [r.held_points for r in reports],
        "repartitions": sim.repartitions,
        "ghost facets": ghosts,
        "mean increment": sim.domains is not None and sim.domains.mean_increment,
    }

def ghost_facets(sim):
    # The step's ghost facets, those between two ranks, and the owned cells they tie,
    # each summed over the ranks.
    if sim.ghost is None:
        return None
    tdim = sim.mesh.topology.dim
    owned = sim.mesh.topology.index_map(tdim).size_local
    links = sim.mesh.topology.connectivity(tdim - 1, tdim)
    across = sum(max(links.links(f)) >= owned for f in sim.ghost.facets)
    tied = sim.ghost.tied_cells()
    total = lambda k: int(parallel.total(MPI.COMM_WORLD, int(k)))
    return [total(len(sim.ghost.facets)), total(across), total(np.sum(tied < owned))]

def ghost_block(steps):
    # A 3D block falling onto a rigid floor in a box of tetrahedra, the ghost penalty on.
    mesh = meshes.rectangle_mesh((0, 0, 0), (1, 1, 1), (6, 6, 6))
    centre = meshes.cell_centroids(mesh)
    block = (centre[:, 2] > 0.3) & (centre[:, 2] < 0.7) & (centre[:, 0] < 0.7)
    points = fe_mpm.seed(mesh, per_cell=4, density=1000.0, cells=np.flatnonzero(block))
    floor = fe_mpm.RigidWall("floor", lambda x: np.isclose(x[2], 0.0))
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e5, 0.3, 1000.0), "up",
                            dynamic=True, mass="lumped", bossak_alpha=-0.3, ghost_penalty=0.1,
                            body_force=(0, 0, -9.81), walls=[floor])
    ghosts = []
    reports = sim.run(0.025 * steps, steps, progress=False,
                      on_step=lambda report: ghosts.append(ghost_facets(sim)))
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {
        "iterations": [r.newton_iterations for r in reports],
        "ghost facets": ghosts,
        "tip": [total(points.mass * points.x[:, 2]) / total(points.mass),
                reports[-1].walls["floor"].normal],
    }

def domain_block(steps):
    # A 3D block of point domains falling onto the clamped base (Newmark), the grid
    # repartitioned by its points as it goes.
    mesh = meshes.rectangle_mesh((0, 0, 0), (1, 1, 1), (5, 5, 5))
    centre = meshes.cell_centroids(mesh)
    block = (centre[:, 2] > 0.2) & (centre[:, 2] < 0.8) & (centre[:, 0] < 0.6)
    points = fe_mpm.seed(mesh, per_cell=1, density=1000.0, cells=np.flatnonzero(block))
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e5, 0.3, 1000.0), "up",
                            dynamic=True, mass="lumped", bossak_alpha=-0.3,
                            body_force=(0, 0, -9.81), point_domains=True, rebalance_above=1.01,
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[2], 0.0))])
    reports = sim.run(0.03 * steps, steps, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {
        "iterations": [r.newton_iterations for r in reports],
        "tip": [total(points.mass * points.x[:, c]) / total(points.mass) for c in (0, 2)],
        "migrated": sum(r.migrated_points for r in reports),
        "repartitions": sim.repartitions,
    }

def domain_footing(t_end, steps, restore=None, **options):
    # The rough strip footing with point domains, h = 0.2 B, to s/B = 0.8 at t = 1:
    # some domains distort and are flipped or redrawn from s/B = 0.5 on.
    from fe_mpm import scenes
    sim = scenes.strip_footing(h=0.2, points_near=3, point_domains=True, settlement=0.8,
                               **options)
    if restore is not None:
        sim.restore(restore)
    resets = []
    steps = sim.run(t_end, steps, progress=False, on_step=lambda r: resets.append(
        [int(parallel.total(MPI.COMM_WORLD, sim.domains.resets)),
         int(parallel.total(MPI.COMM_WORLD, sim.domains.flips))]))
    return {"iterations": [r.newton_iterations for r in steps],
            "tip": [scenes.footing_pressure(r) for r in steps],
            "migrated": sum(r.migrated_points for r in steps), "resets": resets}

def domain_corner():
    # A small Mohr-Coulomb block of domains in the corner of a long grid (Newmark, gravity):
    # on 3 ranks two hold no point.
    mesh = meshes.rectangle_mesh((0, 0), (8, 1), (64, 8))
    centre = meshes.cell_centroids(mesh)
    cells = np.flatnonzero((centre[:, 0] < 0.25) & (centre[:, 1] < 0.3))
    points = fe_mpm.seed(mesh, per_cell=3, density=2000.0, cells=cells)
    law = fe_mpm.MohrCoulomb(E=1e6, nu=0.3, cohesion=2e3, friction_angle=30.0, density=2000.0)
    sim = fe_mpm.Simulation(mesh, points, law, dynamic=True, mass="lumped", body_force=(0, -9.81),
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
                            point_domains=True)
    reports = sim.run(0.1, 4, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {"iterations": [r.newton_iterations for r in reports],
            "tip": [total(points.mass * points.x[:, c]) for c in (0, 1)],
            "points": MPI.COMM_WORLD.allgather(len(points))}

def corner_block(steps, **options):
    # A Mohr-Coulomb block in the left corner of a long grid, its base held by a facet tag.
    mesh = meshes.rectangle_mesh((0, 0), (4, 1), (32, 8))
    centre = meshes.cell_centroids(mesh)
    points = fe_mpm.seed(mesh, per_cell=3, density=2000.0,
                         cells=np.flatnonzero((centre[:, 0] < 1) & (centre[:, 1] < 0.75)))
    seeded = len(points)
    base = dolfinx.mesh.locate_entities_boundary(mesh, 1, lambda x: np.isclose(x[1], 0.0))
    tags = dolfinx.mesh.meshtags(mesh, 1, base, np.full(base.size, 3, dtype=np.int32))
    law = fe_mpm.MohrCoulomb(E=1e6, nu=0.3, cohesion=2e3, friction_angle=30.0, density=2000.0)
    sim = fe_mpm.Simulation(mesh, points, law, dynamic=True, mass="lumped", body_force=(0, -9.81),
                            facet_tags=tags, dirichlet=[fe_mpm.Dirichlet(3)],
                            reactions={"base": 3}, **options)
    sim.add_marker("top", (0.999, 0.7))
    reports = sim.run(0.025 * steps, steps, progress=False)
    return {
        "iterations": [r.newton_iterations for r in reports],
        "top": sim.marker("top").tolist(),
        "base": reports[-1].reactions["base"].tolist(),
        "seeded": seeded,
        "imbalance": [r.point_imbalance for r in reports],
        "repartitioned": [r.repartitioned for r in reports],
        "repartitions": sim.repartitions,
        "timings": sim.timings,
    }

def falling_block(mass, steps, restore=None, supported=True, **options):
    # A Mohr-Coulomb block dropped onto the grid's clamped base (dynamic, gravity).
    mesh = meshes.rectangle_mesh((0, 0), (2, 2), (8, 8))
    centre = meshes.cell_centroids(mesh)
    block = (abs(centre[:, 0] - 1) < 0.5) & (centre[:, 1] > 0.25) & (centre[:, 1] < 1.0)
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.flatnonzero(block))
    seeded = len(points)
    law = fe_mpm.MohrCoulomb(E=1e6, nu=0.3, cohesion=2e3, friction_angle=30.0, density=2000.0)
    sim = fe_mpm.Simulation(mesh, points, law, dynamic=True, mass=mass, body_force=(0, -9.81),
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))]
                            if supported else [], **options)
    sim.add_marker("corner", (0.501, 0.999))
    if restore is not None:
        sim.restore(restore)
    reports = sim.run(sim.t + 0.05 * steps, steps, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {
        "iterations": [r.newton_iterations for r in reports],
        "corner": sim.marker("corner").tolist(),
        "height": total(points.x[:, 1] * points.mass),
        "stress": total(points.stress[:, 1, 1] * points.volume),
        "grid energy": [r.grid_kinetic_energy for r in reports],
        "seeded": seeded,
        "migrated": sum(r.migrated_points for r in reports),
        # Rank 0 alone reads the count, as a user's `if rank == 0: print(...)` does; it
        # must need no message, or the other ranks' next collective meets it.
        "dropped": sim.dropped if MPI.COMM_WORLD.rank == 0 else None,
        "remaining": int(parallel.total(MPI.COMM_WORLD, len(points))),
    }

def outflow(folder, write):
    # Water pouring out of a grid's open end with point domains, dropped as it leaves;
    # after 80 steps a kept point lies past the grid's edge, its domain mostly inside.
    grid = meshes.rectangle_mesh((0.0, 0.0), (0.30, 0.14), (15, 7))
    centre = meshes.cell_centroids(grid)
    column = np.flatnonzero((centre[:, 0] < 0.10) & (centre[:, 1] < 0.10))
    points = fe_mpm.seed(grid, 3, density=1000.0, cells=column)
    water = fe_mpm.NewtonianFluid(2.0e6, 1.0e-3, shear_scale=2 * 1000.0 * 9.81 * 0.1,
                                  density=1000.0)
    sim = fe_mpm.Simulation(
        grid, points, water, "up", body_force=(0.0, -9.81), dynamic=True, mass="lumped",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0),
                   fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1)],
        bossak_alpha=-0.3, points_leaving="drop", point_domains=True,
        checkpoint_dir=folder / "outflow" if write else None, checkpoint_every=80)
    if write:
        sim.run(0.2, 80, progress=False)
    else:
        sim.restore(folder / "outflow" / "step_000080")
    outside = int(parallel.total(MPI.COMM_WORLD, int(np.sum(points.x[:, 0] > 0.30))))
    sim.run(sim.t + 0.0025, 1, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {"outside": outside, "dropped": sim.dropped, "mass": total(points.mass),
            "x": total(points.mass * points.x[:, 0]), "y": total(points.mass * points.x[:, 1])}

def facet_block(steps):
    # A block whose points all lie on facets: every edge's midpoint and the diagonals'.
    h, xs = 0.25, []
    for i in range(1, 7):
        xs += [((i + 0.5) * h, j * h) for j in range(7)]  # horizontal facets
        xs += [((i + 0.5) * h, (j + 0.5) * h) for j in range(6)]  # diagonal facets
    xs += [(i * h, (j + 0.5) * h) for i in range(1, 8) for j in range(6)]  # vertical
    mesh = meshes.rectangle_mesh((0, 0), (2, 2), (8, 8))
    x = np.array(xs) if rank == 0 else np.zeros((0, 2))  # migration spreads them
    volume = np.full(len(x), 1.0 / len(xs))
    points = fe_mpm.MaterialPoints(x, volume, 2000.0 * volume)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e6, 0.3, 2000.0),
                            body_force=(0, -9.81),
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))])
    # Each point and the centroid of the cell its tie gave it, from every rank, sorted.
    pairs = np.c_[points.x, meshes.cell_centroids(mesh)[points.cell]]
    pairs = np.concatenate(MPI.COMM_WORLD.allgather(pairs))
    pairs = pairs[np.lexsort(pairs.T[::-1])]
    reports = sim.run(1.0, steps, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {
        "iterations": [r.newton_iterations for r in reports],
        "cells": pairs.tolist(),
        "local points": len(points),
        "height": total(points.x[:, 1] * points.mass),
        "spread": total(points.x[:, 0] ** 2 * points.mass),
        "stress": total(points.stress[:, 1, 1] * points.volume),
        "shear": total(points.stress[:, 0, 1] ** 2 * points.volume),
    }

def nbva_slosh(steps):
    # Water in NB-VA whose surface starts tilted, sloshing in a tank with slip walls:
    # its points take the averaged volume change (a projection summed over the ranks).
    mesh = meshes.rectangle_mesh((0, 0), (1, 0.6), (10, 6))
    surface = lambda x: 0.3 + 0.1 * (x[0] - 0.5) - x[1]
    points = fe_mpm.seed(mesh, 6, density=1000.0, level_set=surface)
    water = fe_mpm.NewtonianFluid(2e9, 1e-3, density=1000.0)
    sides = lambda x: np.isclose(x[0], 0) | np.isclose(x[0], 1)
    slip = [fe_mpm.Dirichlet(sides, component=0),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0), component=1)]
    sim = fe_mpm.Simulation(mesh, points, water, "u-nbva", body_force=(0, -9.81), dynamic=True,
                            mass="lumped", bossak_alpha=-0.3, dirichlet=slip)
    reports = sim.run(0.01 * steps, steps, progress=False)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {"iterations": [r.newton_iterations for r in reports],
            "volume": total(points.volume), "mass centre": total(points.mass * points.x[:, 0]),
            "kinetic": total(points.mass * np.sum(points.velocity**2, axis=1)),
            "migrated": sum(r.migrated_points for r in reports)}

def wall_block(steps, repartition=False, graded=False, **options):
    # An elastic block sliding on a frictional rigid wall down a 30-degree slope.
    mesh = meshes.rectangle_mesh((0, 0), (3, 1), (30, 10))
    on_base = lambda x: np.isclose(x[1], 0.0)
    where, tags = on_base, None
    if graded:  # cells along the wall from 0.005 to 0.2 m, the wall given by a tag
        mesh.geometry.x[:, 0] = 0.05 * mesh.geometry.x[:, 0] + mesh.geometry.x[:, 0] ** 2 / 3
        base = dolfinx.mesh.locate_entities_boundary(mesh, 1, on_base)
        where, tags = 7, dolfinx.mesh.meshtags(mesh, 1, base, np.full(base.size, 7, np.int32))
    centre = meshes.cell_centroids(mesh)
    block = (abs(centre[:, 0] - 1.5) < 0.5) & (centre[:, 1] < 0.5)  # across the ranks
    points = fe_mpm.seed(mesh, per_cell=3, density=7800.0, cells=np.flatnonzero(block))
    wall = fe_mpm.RigidWall("base", where, friction=0.1)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(2e8, 0.3, 7800.0), dynamic=True,
                            walls=[wall], body_force=(9.81 * 0.5, -9.81 * 0.75**0.5),
                            facet_tags=tags, **options)
    after = (lambda report: sim.rebalance()) if repartition else None  # after every step
    reports = sim.run(0.01 * steps, steps, progress=False, on_step=after)
    total = lambda a: float(parallel.total(MPI.COMM_WORLD, float(np.sum(a))))
    return {
        "iterations": [r.newton_iterations for r in reports],
        "slide": total(points.mass * (points.x - points.x0)[:, 0]),
        "force": [r.walls["base"].total.tolist() for r in reports],
        "normal": [r.walls["base"].normal for r in reports],
        "nodes": len(reports[-1].walls["base"].nodes),
        "local points": len(points),
    }

def bodies():
    # Blobs of occupied cells chosen by a smooth field of their midpoints (so alike on
    # every rank count), with each cell's body as the distributed count gives it.
    from fe_mpm.bodies import bodies_of_cells
    found = {}
    for dim in (2, 3):
        comm = MPI.COMM_WORLD
        mesh = (dolfinx.mesh.create_unit_square(comm, 24, 24) if dim == 2
                else dolfinx.mesh.create_unit_cube(comm, 8, 8, 8))
        owned = np.arange(mesh.topology.index_map(dim).size_local, dtype=np.int32)
        middle = dolfinx.mesh.compute_midpoints(mesh, dim, owned)[:, :dim]
        for seed in range(4):
            waves = np.random.default_rng(seed).normal(size=(4, dim)) * 6
            field = sum(np.sin(middle @ k + i) for i, k in enumerate(waves))
            cells = owned[field > 0.8 + 0.1 * seed]
            body, count = bodies_of_cells(mesh, cells)
            found[f"{dim} {seed}"] = {"count": count, "cells": middle[field > 0.8 + 0.1 * seed]
                                      .round(9).tolist(), "body": body.tolist()}
            # The ghost cells of the blob too (as domains' pieces give), and a rank
            # with none: counted against all the cells' nodes gathered (the count's
            # first, serial-only way).
            every = np.arange(mesh.topology.index_map(dim).size_local
                              + mesh.topology.index_map(dim).num_ghosts, dtype=np.int32)
            mid = dolfinx.mesh.compute_midpoints(mesh, dim, every)[:, :dim]
            ghosts = every[sum(np.sin(mid @ k + i) for i, k in enumerate(waves)) > 0.8]
            for name, chosen in (("ghosts", ghosts), ("rank 0 none", cells[:0] if rank == 0
                                                       else cells)):
                nodes = mesh.geometry.dofmaps[0][np.unique(chosen)]
                gathered = parallel.gathered(comm, mesh.geometry.index_map().local_to_global(
                    nodes.ravel().astype(np.int32)).reshape(nodes.shape))
                from fe_mpm.bodies import body_labels
                found[f"{dim} {seed} {name}"] = [bodies_of_cells(mesh, chosen)[1],
                                                 int(body_labels(gathered).max(initial=-1)) + 1]
    return found

try:
    if case == "bodies":
        result = bodies()
    elif case == "cook":
        result = {f"{f} {n} {k}": cook(f, n, k) for f, n, k in
                  (("u", 16, 1), ("up", 16, 1), ("up", 8, 4), ("u", 8, 4), ("u-nbva", 8, 4))}
        result["output"] = cook("up", 8, 2, output_dir=folder / f"out{MPI.COMM_WORLD.size}")
        result["up-p2p1 8 2"] = cook("up-p2p1", 8, 2, per_cell=3)  # Taylor-Hood
        for f in ("u", "up") if MPI.COMM_WORLD.size < 3 else ():  # GAMG; Schur field split
            result[f"{f} 16 1 iterative"] = cook(f, 16, 1, linear_solver="iterative")
    elif case == "ghost":
        ghost = dict(load=5 / 16, margin=4, ghost_penalty=0.1)
        result = {"up 16 6": cook("up", 16, 6, per_cell=3, **ghost),
                  "up-p2p1 8 4": cook("up-p2p1", 8, 4, per_cell=3, **ghost),
                  "up 16 4 repartitioned": cook("up", 16, 4, per_cell=3, repartition=True,
                                                **ghost),
                  "3D block": ghost_block(12)}
    elif case == "crossing":
        held = dict(load=5 / 16, margin=10, fail_at=(4, 7, 9))
        result = {"up 32 4": cook("up", 32, 4), "held": cook("up", 32, 10, **held)}
    elif case == "write cook checkpoint":
        result = cook("up", 32, 10, load=5 / 16, margin=10, fail_at=(4, 7, 9),
                      checkpoint_dir=folder / "cook_ck", checkpoint_every=6, repartition=True)
    elif case == "restore cook checkpoint":
        result = cook("up", 32, 10, load=5 / 16, margin=10, fail_at=(4, 7, 9),
                      restore=folder / "cook_ck" / "step_000006")
    elif case == "corner":
        result = {"balanced": corner_block(4, rebalance_above=1.25), "as cut": corner_block(1)}
    elif case == "on facets":
        result = facet_block(2)
    elif case == "wall":
        result = {"plain": wall_block(12), "repartitioned": wall_block(12, repartition=True),
                  "domains": wall_block(12, point_domains=True, graded=True)}
    elif case == "falling":
        result = {m: falling_block(m, k) for m, k in (("consistent", 4), ("lumped", 10))}
        result["projected"] = falling_block("consistent", 4, projection_passes=8)
    elif case == "dropping":
        result = {d: falling_block("lumped", 8, supported=False, points_leaving="drop",
                                   point_domains=d == "domains") for d in ("points", "domains")}
    elif case == "write checkpoint":
        result = falling_block("lumped", 5, checkpoint_dir=folder / "ck", checkpoint_every=5)
    elif case == "restore checkpoint":
        result = falling_block("lumped", 5, restore=folder / "ck")
    elif case in ("outflow write", "outflow restore"):
        result = outflow(folder, case == "outflow write")
    elif case == "leaving":
        cook("up", 8, 4, load=5 / 16, margin=0)
        result = "finished"
    elif case == "too few":
        cook("up-p2p1", 8, 10, load=5 / 16, margin=4, per_cell=3, min_step=0.05)
        result = "finished"
    elif case == "refused":
        scene = meshes.cook_membrane(n=4)
        points = fe_mpm.seed(scene.mesh, per_cell=1)
        fe_mpm.Simulation(scene.mesh, points, fe_mpm.NeoHookean(70.0, 0.3), point_domains=True,
                          shared_increment=True)
        result = "accepted"
    elif case == "output folder is a file":
        (folder / "taken").write_text("a file")
        scene = meshes.cook_membrane(n=4)
        fe_mpm.Simulation(scene.mesh, fe_mpm.seed(scene.mesh), fe_mpm.NeoHookean(70.0, 0.3),
                          output_dir=folder / "taken")
        result = "accepted"
    elif case == "domains":
        domains = dict(load=5 / 16, margin=4, point_domains=True)
        result = {
            "up 16 8": cook("up", 16, 8, per_cell=3, **domains),
            "u-nbva 16 4": cook("u-nbva", 16, 4, **domains),
            "up-p2p1 8 4": cook("up-p2p1", 8, 4, per_cell=3, **domains),
            "3D block": domain_block(5),
            "footing": domain_footing(1.0, 8),
            "corner": domain_corner(),
        }
    elif case == "domains checkpoint":  # the footing's first 4 steps, and a checkpoint
        result = domain_footing(0.5, 4, checkpoint_dir=folder / "domains_ck", checkpoint_every=4)
    elif case == "domains restored":  # its last 4 steps
        result = domain_footing(1.0, 4, restore=folder / "domains_ck")
    elif case == "domains past the ghosts":
        import fe_mpm.simulation
        fe_mpm.simulation.DOMAIN_GHOST_LAYERS = 0  # no ghost cells to cut the domains by
        cook("up", 16, 4, load=5 / 16, margin=4, point_domains=True, min_step=0.5)
        result = "finished"
    elif case == "domain across a rank":
        # A strip of 8 × 1 cells (16 triangles); on 2 ranks, rank 1 owns those with
        # 3 < x < 5 and rank 0 the rest, without ghosts. A domain with its corners at
        # x = 1 and 7 covers rank 1's cells between them, which rank 0 does not hold.
        import basix.ufl
        import ufl
        from fe_mpm.domains import PointDomains
        from fe_mpm.tracker import Tracker
        comm = MPI.COMM_WORLD
        i = np.arange(8)
        cells = np.vstack([np.column_stack([i, i + 1, i + 10]),
                           np.column_stack([i, i + 10, i + 9])])
        x = np.vstack([np.column_stack([np.arange(9.0), np.zeros(9)]),
                       np.column_stack([np.arange(9.0), np.ones(9)])])
        middle = np.abs(x[cells].mean(axis=1)[:, 0] - 4.0) < 1.0
        parts = np.where(middle & (comm.size > 1), 1, 0).astype(np.int32)
        if rank > 0:
            cells, x, parts = cells[:0], x[:0], parts[:0]
        destinations = dolfinx.graph.adjacencylist(parts)
        element = ufl.Mesh(basix.ufl.element("Lagrange", "triangle", 1, shape=(2,)))
        mesh = dolfinx.mesh.create_mesh(
            comm, cells.astype(np.int64), element, x,
            partitioner=lambda *args: destinations._cpp_object)
        tracker = Tracker(mesh, ghosts=True)
        corners = np.array([[[1.0, 0.2], [1.0, 0.8], [7.0, 0.5]]])[: 1 if rank == 0 else 0]
        at = corners.mean(axis=1)
        points = fe_mpm.MaterialPoints(at, np.ones(len(at)), np.ones(len(at)))
        points.cell = tracker.locate(at, np.zeros(len(at), dtype=np.int32))
        domains = PointDomains(points, tracker)
        domains.corners = corners
        error = None
        try:
            pieces = domains.pieces(tracker, points.cell)
        except Exception as err:
            error = err
        parallel.raise_together(comm, domains._beyond_ghosts(tracker) or error)
        area = parallel.total(comm, float(np.sum(pieces.share)))
        result = {"shares": area, "cells": sorted(set(pieces.cell.tolist()))}
    elif case == "no ghost layer":
        # Grids without ghost cells, as gmsh's model_to_mesh builds them by default.
        def grid():
            return dolfinx.mesh.create_rectangle(MPI.COMM_WORLD, [(0, 0), (1, 1)], (8, 8),
                                                 ghost_mode=dolfinx.mesh.GhostMode.none)

        def mean_motion(sim):
            p = sim.points
            moment = parallel.total(MPI.COMM_WORLD, p.mass @ (p.x - p.x0))
            return (moment / parallel.total(MPI.COMM_WORLD, p.mass.sum())).tolist()

        result = {}
        # A block whose top cuts the cells, under the ghost penalty, its base held by tag.
        mesh = grid()
        base = dolfinx.mesh.locate_entities_boundary(mesh, 1, lambda x: np.isclose(x[1], 0.0))
        tags = dolfinx.mesh.meshtags(mesh, 1, base, np.full(base.size, 7, dtype=np.int32))
        points = fe_mpm.seed(mesh, per_cell=3, level_set=lambda x: 0.43 + 0.3 * (x[0] - 0.5) - x[1])
        sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(70.0, 0.3), ghost_penalty=0.1,
                                facet_tags=tags, dirichlet=[fe_mpm.Dirichlet(7)],
                                body_force=(0.0, -10.0), body_force_scale=lambda t: t)
        owned = lambda m: set(m.topology.original_cell_index[:m.topology.index_map(2).size_local])
        kept = owned(sim.mesh) == owned(mesh)  # the rebuilt grid's cells on the same ranks
        reports = sim.run(1.0, 3, progress=False)
        result["block"] = {"iterations": [r.newton_iterations for r in reports],
                           "motion": mean_motion(sim), "ghost facets": ghost_facets(sim),
                           "kept owners": kept, "rebuilt": sim.mesh is not mesh}
        # Water sloshing in the tank: its pressure by parts (on by default for a fluid).
        mesh = grid()
        points = fe_mpm.seed(mesh, per_cell=6, density=1000.0,
                             level_set=lambda x: 0.5 + 0.1 * (x[0] - 0.5) - x[1])
        walls = lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0)
        sim = fe_mpm.Simulation(
            mesh, points, fe_mpm.NewtonianFluid(2.0e6, 1.0e-3, 1.0e4, density=1000.0), "up",
            dirichlet=[fe_mpm.Dirichlet(walls, component=0),
                       fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1)],
            body_force=(0.0, -9.81), dynamic=True, mass="lumped")
        reports = sim.run(0.1, 10, progress=False)
        ghosts = sim.mesh.topology.index_map(2).num_ghosts
        result["water"] = {"iterations": [r.newton_iterations for r in reports],
                           "motion": mean_motion(sim), "by parts": sim._by_parts is not None,
                           "ghosts": int(parallel.total(MPI.COMM_WORLD, ghosts))}
    elif case == "boundary points":
        from fe_mpm import scenes
        cook = scenes.cook_membrane(n=16, nu=0.499, traction=5 / 16, load="points", margin=6)
        reports = cook.run(1.0, 6, progress=False)
        footing = scenes.strip_footing(h=0.2, h_far=0.2, E=1e4, points_near=3, smooth=True,
                                       settlement=0.16)
        steps = footing.run(1.0, 10, progress=False)
        platen = scenes.platen_compression(10, 3)
        squeezed = platen.run(1.0, 10, progress=False)
        # A pin of penalty points in cells a fixed base holds: its share on the base's
        # nodes goes to the base's reaction, summed on the ranks that hold the points.
        mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.5), (8, 12))
        xs = (np.arange(16) + 0.5) / 16
        def row(name, y, value, **options):
            return fe_mpm.PointDirichlet(name, np.column_stack([xs, np.full(16, y)]), 1 / 16,
                                         value, 8e6, **options)
        base = lambda x: np.isclose(x[1], 0.0)
        pinned = fe_mpm.Simulation(
            mesh, fe_mpm.seed(mesh, 3, level_set=lambda x: 1.0 - x[1]), fe_mpm.NeoHookean(1e6, 0.3),
            dirichlet=[fe_mpm.Dirichlet(base)], reactions={"base": base},
            point_dirichlet=[row("top", 1.0, lambda t: (0.0, 0.01 * t)),
                             row("pin", 0.03125, lambda t: (0.0, 0.0), reach=0.0)])
        pin = pinned.run(1.0, 1, progress=False)[-1].reactions
        result = {
            "pin": {name: force.tolist() for name, force in pin.items()},
            "platen": {"iterations": [r.newton_iterations for r in squeezed],
                       "force": [scenes.platen_force(r) for r in squeezed]},
            "cook": {"iterations": [r.newton_iterations for r in reports],
                     "tip": scenes.tip_deflection(cook),
                     "load": reports[-1].reactions["load"].tolist(),
                     "migrated": sum(r.migrated_points for r in reports)},
            "footing": {"iterations": [r.newton_iterations for r in steps],
                        "q": [scenes.footing_pressure(r) for r in steps],
                        "migrated": sum(r.migrated_points for r in steps)},
        }
    elif case == "wall gaps":
        # A disk over a floor graded along it: each node's gap, by its global index.
        mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (24, 12))
        mesh.geometry.x[:, 0] = mesh.geometry.x[:, 0] ** 2
        disk = fe_mpm.seed(mesh, 6, level_set=lambda x: np.hypot(x[0] - 0.5, x[1] - 0.3) - 0.28)
        sim = fe_mpm.Simulation(mesh, disk, fe_mpm.NeoHookean(1e6, 0.3),
                                walls=[fe_mpm.RigidWall("floor", lambda x: np.isclose(x[1], 0.0))])
        wall = sim.walls.walls[0]
        index_map = wall.gap.function_space.dofmap.index_map
        nodes = index_map.local_to_global(np.asarray(wall.gap_nodes, dtype=np.int32))
        cells = np.arange(mesh.topology.index_map(2).size_local)
        gaps = []
        for shift in np.linspace(-0.3, 0.3, 7):
            sim.walls.start_step(cells, disk.x + [shift, 0.0], disk.volume)
            gaps.append(wall.gap.x.array[wall.gap_nodes].tolist())
        x = wall.gap.function_space.tabulate_dof_coordinates()[wall.gap_nodes, 0]
        result = {"x": x.tolist(), "gaps": gaps}
    elif case == "nbva slosh":
        result = nbva_slosh(10)
    elif case == "pressure":
        scene = meshes.quarter_ring(1.0, 2.0, 0.2)
        centre = meshes.cell_centroids(scene.mesh)
        r, angle = np.hypot(centre[:, 0], centre[:, 1]), np.arctan2(centre[:, 1], centre[:, 0])
        ring = scene.cell_tags.find(meshes.RING_BODY)
        ring = ring[ring < centre.shape[0]]  # owned cells, whose centroids these are
        # No material on the inner arc's lower half: that share of its pressure is lost.
        body = ring[(r[ring] > 1.2) | (angle[ring] > np.pi / 4)]
        points = fe_mpm.seed(scene.mesh, per_cell=3, cells=body)
        sim = fe_mpm.Simulation(
            scene.mesh, points, fe_mpm.NeoHookean(1e7, 0.3), "up", facet_tags=scene.facet_tags,
            tractions=[fe_mpm.Pressure(meshes.RING_INNER, 1e3)],
            dirichlet=[fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
                       fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0)],
            reactions={"x_axis": meshes.RING_X_AXIS})
        sim.add_marker("inner", (np.cos(1.2), np.sin(1.2)))
        report = sim.run(1.0, 1, progress=False)[-1]
        result = {"inner": report.markers["inner"].tolist(),
                  "reaction": report.reactions["x_axis"].tolist(), "lost": report.lost_load}
    elif case == "point pressure":
        scene = meshes.quarter_ring(1.0, 10.0, 0.2, 2.0, h_outer=1.0)
        points = fe_mpm.seed(scene.mesh, per_cell=3, cells=scene.cell_tags.find(meshes.RING_BODY))
        x, w = meshes.facet_points(scene.mesh, scene.facet_tags.find(meshes.RING_INNER))
        sim = fe_mpm.Simulation(
            scene.mesh, points, fe_mpm.MohrCoulomb.tresca(3e6, 0.4999, 1e4), "up",
            facet_tags=scene.facet_tags, point_domains=True,
            point_tractions=[fe_mpm.PointPressure("cavity", x, w, -x, 4e4, lambda t: t)],
            dirichlet=[fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
                       fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0)])
        sim.add_marker("face", (np.cos(0.7), np.sin(0.7)))
        reports = sim.run(1.0, 6, progress=False)
        result = {"face": [r.markers["face"].tolist() for r in reports],
                  "force": [r.reactions["cavity"].tolist() for r in reports]}
    elif case in ("staged", "staged from rank 0"):  # a trench dug, a layer placed
        mesh = meshes.rectangle_mesh((0.0, 0.0), (4.0, 5.0), (8, 10))
        points = fe_mpm.seed(mesh, 3, density=2000.0, level_set=lambda x: 4.0 - x[1])
        base = lambda x: np.isclose(x[1], 0.0)  # noqa: E731
        sim = fe_mpm.Simulation(
            mesh, points, fe_mpm.MohrCoulomb(5e7, 0.3, 1e9, 0.0), "u", body_force=(0.0, -9.81),
            dirichlet=[fe_mpm.Dirichlet(base), fe_mpm.Dirichlet(
                lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], 4.0), component=0)],
            reactions={"base": base})
        sim.add_marker("crest", (1.45, 3.95))
        sim.step(1.0)
        sim.remove_points((np.abs(points.x[:, 0] - 2.0) < 0.5) & (points.x[:, 1] > 2.0))
        dug = sim.step(2.0)
        layer = [lambda x: x[1] - 4.0, lambda x: 4.5 - x[1]]
        new = fe_mpm.seed(sim.mesh, 3, density=2000.0, level_set=layer)
        if case == "staged from rank 0":  # rank 0 gives them all, the others none
            gathered = MPI.COMM_WORLD.gather(new)
            if rank == 0:
                for more in gathered[1:]:
                    new = fe_mpm.merge(new, more)
            else:
                new.keep(np.zeros(len(new), dtype=bool))
        sim.add_points(new)
        placed = sim.step(3.0)
        weight = 9.81 * float(parallel.total(MPI.COMM_WORLD, points.mass.sum()))
        result = {"base": [dug.reactions["base"].tolist(), placed.reactions["base"].tolist()],
                  "weight": weight, "crest": placed.markers["crest"].tolist(),
                  "points": int(parallel.total(MPI.COMM_WORLD, len(points)))}
    elif case == "floor":  # a drop beside a pool, domains: the pressure floor's cells
        mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (10, 10))
        low = np.flatnonzero(meshes.cell_centroids(mesh)[:, 1] < 0.3)
        pool = fe_mpm.seed(mesh, 1, density=1000.0, cells=low)
        drop = fe_mpm.MaterialPoints(x=np.array([[0.53, 0.76]]), volume=np.array([0.005 / 3]),
                                     mass=np.array([5.0 / 3]))
        sides = lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0)  # noqa: E731
        sim = fe_mpm.Simulation(
            mesh, fe_mpm.merge(pool, drop) if rank == 0 else pool,
            fe_mpm.NewtonianFluid(2e9, 1e-3, shear_scale=5886.0, density=1000.0), "up",
            dirichlet=[fe_mpm.Dirichlet(sides, component=0),
                       fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1)],
            body_force=(0.0, -9.81), dynamic=True, mass="lumped", bossak_alpha=-0.3,
            point_domains=True)
        sim.run(0.03, 3, progress=False)
        pts, nodal = sim.points, np.abs(sim.fields.pressure_values()).max()
        weighted = pts.volume @ pts.stress[:, 1, 1]
        result = {"p": parallel.largest(MPI.COMM_WORLD, nodal),
                  "weighted": float(parallel.total(MPI.COMM_WORLD, weighted))}
    elif case in ("zones", "zones nbva"):  # NB-VA: one averaged volume change per zone
        from fe_mpm import scenes
        from fe_mpm.materials import HenckyJ2
        laws = [HenckyJ2(1000.0, 0.3, 1.0), fe_mpm.MohrCoulomb.tresca(1000.0, 0.3, 1.5)]
        formulation = "up" if case == "zones" else "u-nbva"
        sim = scenes.platen_compression(6, 3, layers=laws, formulation=formulation,
                                        point_domains=True)
        reports = sim.run(0.6, 6, progress=False)
        pts = sim.points
        agree = bool(np.all(np.rint(pts.history["material"]) == pts.material))
        strain = [float(parallel.total(MPI.COMM_WORLD, pts.history["plastic_strain"][
            pts.material == k].sum())) for k in (0, 1)]
        result = {"force": [scenes.platen_force(r) for r in reports], "strain": strain,
                  "agree": parallel.total(MPI.COMM_WORLD, int(not agree)) == 0,
                  "migrated": sum(r.migrated_points for r in reports)}
    elif case in ("geostatic", "geostatic refused"):
        mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [2, 1, 1]], [4, 2, 2],
                                       dolfinx.mesh.CellType.tetrahedron)
        points = fe_mpm.seed(mesh, per_cell=4, density=2000.0)
        stress = fe_mpm.geostatic_stress(points, 1.0, 10.0, 0.3 / 0.7)
        if case == "geostatic refused" and rank == MPI.COMM_WORLD.size - 1:
            stress = stress[:-1]
        side = lambda x: np.isclose(x[0], 0) | np.isclose(x[0], 2)  # noqa: E731
        front = lambda x: np.isclose(x[1], 0) | np.isclose(x[1], 1)  # noqa: E731
        sim = fe_mpm.Simulation(
            mesh, points, fe_mpm.MohrCoulomb(1e7, 0.3, 1e4, 30.0, density=2000.0), "u-nbva",
            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[2], 0.0)),
                       fe_mpm.Dirichlet(side, component=0), fe_mpm.Dirichlet(front, component=1)],
            body_force=(0, 0, -10.0), dynamic=True, mass="lumped", initial_stress=stress)
        reports = sim.run(0.1, 5, progress=False)
        moved = float(np.abs(points.x - points.x0).max(initial=0.0))
        result = {"iterations": [r.newton_iterations for r in reports],
                  "moved": parallel.largest(MPI.COMM_WORLD, moved),
                  "points": int(parallel.total(MPI.COMM_WORLD, len(points)))}
    else:  # a serial mesh on each rank: independent runs
        mesh = fe_mpm.meshes.rectangle_mesh((0, 0), (1, 1), (4, 4), comm=MPI.COMM_SELF)
        points = fe_mpm.seed(mesh, per_cell=3, density=2000.0)
        sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e7, 0.3), body_force=(0, -9.81),
                                dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))])
        sim.run(1.0, 2, progress=False)
        result = float(points.stress[:, 1, 1].min())
except Exception as err:
    result = {"error": type(err).__name__, "message": str(err)}
out.write_text(json.dumps(result))
"""


def _mpiexec() -> str:
    here = Path(sys.executable).parent / "mpiexec"
    found = str(here) if here.exists() else shutil.which("mpiexec")
    assert found, "mpiexec is neither beside the interpreter nor on the PATH"
    return found


def _run(tmp_path: Path, case: str, ranks: int) -> list:
    """What each rank of ``mpiexec -n ranks`` wrote, in rank order."""
    script = tmp_path / "scene.py"
    script.write_text(SCRIPT)
    done = subprocess.run(
        [_mpiexec(), "-n", str(ranks), sys.executable, str(script), case, str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ),
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return [json.loads((tmp_path / f"rank{r}_{ranks}.json").read_text()) for r in range(ranks)]


def test_cook_on_two_and_three_ranks_gives_the_serial_answer(tmp_path):
    """Cook u and u-p (one step at n = 16, four at n = 8), u-nbva (four at n = 8) and
    P2/P1 (two steps at n =
    8, three points per cell) on 1, 2 and 3 ranks; its
    point output on 2 ranks: a piece per rank, every point once; and one step with the
    iterative solvers on 1 and 2 ranks."""
    runs = {ranks: _run(tmp_path, "cook", ranks) for ranks in (1, 2, 3)}
    (serial,) = runs[1]
    for ranks in (2, 3):
        _check_cook(serial, runs[ranks], ranks)
    _check_point_output(tmp_path, serial)
    # The iterative solvers under MPI (global index sets, rigid body modes of the owned
    # rows): the direct solver's iterations, and its tip to GMRES's 1e-12 residual
    # (measured 3e-11 on the u form, whose GAMG-preconditioned Krylov error is largest).
    for ranks in (1, 2):
        for rank, result in enumerate(runs[ranks]):
            for f in ("u", "up"):
                want, got = serial[f"{f} 16 1"], result[f"{f} 16 1 iterative"]
                assert got["iterations"] == want["iterations"], (ranks, rank, f)
                assert got["tip"] == pytest.approx(want["tip"], rel=1e-9), (ranks, rank, f)


def _check_cook(serial: dict, runs: list, ranks: int) -> None:
    for rank, result in enumerate(runs):
        for case in ("u 16 1", "up 16 1", "up 8 4", "u 8 4", "up-p2p1 8 2", "u-nbva 8 4"):
            want, got = serial[case], result[case]
            assert got["iterations"] == want["iterations"], (case, rank)
            # The same on every rank. The clamp's horizontal force is zero to Newton's
            # tolerance of the 1 N load (1e-10), so it is compared to that.
            for key, floor in (("tip", 1e-12), ("clamp", 1e-9)):
                for a, b in zip(got[key], want[key], strict=True):
                    assert a == pytest.approx(b, rel=1e-10, abs=floor), (case, rank, key)
            assert got["occupied"] == want["occupied"]  # a total over the ranks
    for case in ("u 16 1", "up 8 4"):  # each point on one rank only
        assert sum(r[case]["points"] for r in runs) == serial[case]["points"]
    assert all(0 < r["up 16 1"]["points"] < serial["up 16 1"]["points"] for r in runs)
    # The imbalance the reports give: the most points on a rank over the mean.
    counts = [r["up 16 1"]["points"] for r in runs]
    assert serial["up 16 1"]["imbalance"] == 1.0
    for r in runs:
        assert r["up 16 1"]["imbalance"] == pytest.approx(max(counts) * ranks / sum(counts))


def _check_point_output(folder: Path, serial: dict) -> None:
    """Each rank writes its points as a piece; the .pvd lists the pieces of each time."""
    pvd = (folder / "out2" / "particles.pvd").read_text()
    assert 'part="1" file="particles_000002_r1.vtu"' in pvd
    pieces = [meshio.read(folder / "out2" / f"particles_000002_r{r}.vtu") for r in (0, 1)]
    whole = meshio.read(folder / "out1" / "particles_000002.vtu")
    assert sum(len(p.points) for p in pieces) == len(whole.points) == serial["output"]["points"]
    both = [x for p in pieces for x in p.points.round(9).tolist()]
    assert sorted(map(tuple, both)) == sorted(map(tuple, whole.points.round(9).tolist()))


@pytest.mark.slow
def test_points_that_cross_to_another_rank_move_there_and_the_answer_stays_serial(tmp_path):
    """Cook u-p at n = 32, on 3 ranks: at 1 N its fourth step moves two points across
    the partition. "held": at 5 N (ten steps, ten rows of margin) the body sweeps through
    the grid and tens of points change rank, and steps 4, 7 and 9 fail once after
    re-binning: the retry holds each point in its last step's cell, on that cell's rank,
    so points that had migrated go back; the same points are held and the answer stays
    the serial one. The points are summed in another order: measured 6e-15.

    Then "held" on 2 ranks with the grid repartitioned by its points after every step
    (Simulation.rebalance): the held cells are found on the new partitions, and the
    answer stays the serial one. Its checkpoint after step 6 is restored on 3 ranks,
    where steps 7 and 9 fail again: the retries hold the same points in the same
    cells as the serial run (the checkpoint keeps each point's cell by its original
    index, which any partition knows) and end at its tip."""
    (serial,) = _run(tmp_path, "crossing", 1)
    assert serial["up 32 4"]["migrated"] == 0
    assert sum(serial["held"]["held"]) > 0
    for result in _run(tmp_path, "crossing", 3):
        for case in ("up 32 4", "held"):
            _check_held(result[case], serial[case], case)
            assert result[case]["migrated"] > 0, case  # it would test nothing otherwise
    want = serial["held"]
    for got in _run(tmp_path, "write cook checkpoint", 2):
        _check_held(got, want, "repartitioned on 2 ranks")
        assert got["repartitions"] == 10
    for got in _run(tmp_path, "restore cook checkpoint", 3):
        _check_held(
            got,
            {**want, "held": want["held"][6:], "iterations": want["iterations"][6:]},
            "restored",
        )
        assert sum(got["held"]) > 0


def _check_held(got: dict, want: dict, case: str) -> None:
    assert got["held"] == want["held"], case
    assert got["iterations"] == want["iterations"], case
    for a, b in zip(got["tip"], want["tip"], strict=True):
        assert a == pytest.approx(b, rel=1e-10, abs=1e-12), case


def test_points_on_facets_take_the_serial_cells_on_every_rank_count(tmp_path):
    """A block whose 120 points all lie on facets of the grid (every edge's midpoint and the
    diagonals'), under its own weight on a clamped base, seeded on rank 0 and spread by
    migration: each point lies in two cells, and the tie (Tracker.nudges) must give it the
    serial one on 2 and 3 ranks, where the facet may lie between two ranks. Before the tie
    the cell depended on where the search started (Mast's Taylor bar: 6e-4 apart in the
    wall's impulse after one step). The same cells, Newton iterations, and sums over the
    points as serial to 1e-10 (round-off of the summation order)."""
    (serial,) = _run(tmp_path, "on facets", 1)
    assert len(serial["cells"]) == 120
    for ranks in (2, 3):
        results = _run(tmp_path, "on facets", ranks)
        assert sum(r["local points"] for r in results) == 120
        assert min(r["local points"] for r in results) > 0  # it would test nothing otherwise
        for got in results:
            assert got["cells"] == serial["cells"], ranks
            assert got["iterations"] == serial["iterations"], ranks
            for key in ("height", "spread", "stress", "shear"):
                assert got[key] == pytest.approx(serial[key], rel=1e-10), (ranks, key)


def test_a_block_sliding_on_a_frictional_wall_gives_the_serial_answer_on_two_ranks(tmp_path):
    """A rigid wall's springs, friction and forces on a distributed grid: an elastic block
    slides 12 steps down a 30° slope with μ = 0.1, on both ranks' cells (each holds
    some of its points). Each node's spring lives on the ranks that hold it; the wall's
    force is summed over owned nodes once, and its node-by-node distribution is gathered whole. Same
    Newton iterations; slide and forces as serial to 1e-10 (measured 4e-16 and 1e-13).
    The same with the grid repartitioned after every step: the springs' extensions go
    with their nodes to the new grid (without them the slide differs by about 4e-8), and
    with point domains (each node's gap read from the pieces of every rank), on a grid
    whose cells along the wall grow from 0.005 to 0.2 m, the wall given by a facet tag:
    there, until 2026-12-07, the wall's default penalty (from its mean facet size)
    counted twice the tagged facets of the extra ghost cells that domains need, so 2
    ranks took another penalty than serial (a new user's Hertz contact: 3.8e-5 apart
    after one step)."""
    (serial,) = _run(tmp_path, "wall", 1)
    for result in _run(tmp_path, "wall", 2):
        for case in ("plain", "repartitioned", "domains"):
            got, want = result[case], serial[case]
            assert got["iterations"] == want["iterations"], case
            assert got["nodes"] == want["nodes"], case
            assert got["local points"] > 0, case  # it would test nothing otherwise
            assert got["slide"] == pytest.approx(want["slide"], rel=1e-10), case
            np.testing.assert_allclose(got["force"], want["force"], rtol=1e-10, atol=1e-6)
            np.testing.assert_allclose(got["normal"], want["normal"], rtol=1e-10)


def test_a_pressure_on_a_curved_face_and_its_lost_share_are_serial_on_two_ranks(tmp_path):
    """A quarter ring pressurised inside, seeded but for the cells on the lower half
    of its inner arc, so that part of the pressure loads grid nodes with no material:
    u(a) and the reaction as serial to 1e-10, and the same lost share. The arc's
    facets by tag include a rank's ghosts; counted on both ranks, they gave a share
    that depends on the partition."""
    (serial,) = _run(tmp_path, "pressure", 1)
    assert set(serial["lost"]) == {"Pressure 0"} and 0.2 < serial["lost"]["Pressure 0"] < 0.6
    for result in _run(tmp_path, "pressure", 2):
        np.testing.assert_allclose(result["inner"], serial["inner"], rtol=1e-10)
        np.testing.assert_allclose(result["reaction"], serial["reaction"], rtol=1e-10, atol=1e-6)
        assert result["lost"]["Pressure 0"] == pytest.approx(serial["lost"]["Pressure 0"], 1e-12)


def test_a_pressure_that_follows_a_cavitys_face_gives_the_serial_answer_on_two_ranks(tmp_path):
    """A cavity in Tresca clay expanded by a PointPressure to 4 c_u (its face moving
    through cells, point domains): the face's motion and the load's force at every
    step as serial to 1e-9. Each rank deforms the faces of the points it holds and
    every rank adds them up."""
    (serial,) = _run(tmp_path, "point pressure", 1)
    assert np.linalg.norm(serial["face"][-1]) > 1.02  # the face moved out
    for result in _run(tmp_path, "point pressure", 2):
        np.testing.assert_allclose(result["face"], serial["face"], rtol=1e-9)
        np.testing.assert_allclose(result["force"], serial["force"], rtol=1e-9)


def test_points_removed_and_added_between_steps_give_the_serial_answer_on_two_ranks(tmp_path):
    """A trench dug in a layer at rest, then a layer placed on it, each rank removing
    and seeding its own points: the base's reactions, the marker beside the trench and
    the points' count as serial to 1e-9, the base carrying the weight."""
    (serial,) = _run(tmp_path, "staged", 1)
    assert serial["base"][1][1] == pytest.approx(serial["weight"], rel=1e-9)
    # Rank 0 giving every new point, some in the other rank's cells: until 2026-12-06
    # an IndexError on rank 0 (the new points had no row of a last step's cell), and
    # the other rank hung (a reviewer's script).
    for result in _run(tmp_path, "staged", 2) + _run(tmp_path, "staged from rank 0", 2):
        np.testing.assert_allclose(result["base"], serial["base"], rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(result["crest"], serial["crest"], rtol=1e-9)
        assert result["points"] == serial["points"]


def test_the_pressure_floor_is_the_serial_one_where_a_cells_pieces_lie_on_two_ranks(tmp_path):
    """A drop beside a pool with point domains, one point per cell: cells holding a
    domain's pieces from both ranks got the floor once from each (each rank judged
    its own share), and the pool's nodal pressures were 0.2 % off the serial run's
    after two steps (a helper's check, 2026-12-06). Measured now: 4e-10."""
    (serial,) = _run(tmp_path, "floor", 1)
    for result in _run(tmp_path, "floor", 2):
        assert result["p"] == pytest.approx(serial["p"], rel=1e-7)
        assert result["weighted"] == pytest.approx(serial["weighted"], rel=1e-9)


@pytest.mark.parametrize("case", ["zones", "zones nbva"])
def test_a_body_of_two_laws_gives_the_serial_answer_on_two_ranks(tmp_path, case):
    """Two plastic bands side by side (a principal-space J2 and Tresca, point domains,
    u-p, and NB-VA with its average per zone) squeezed by a platen: the force at every
    step and each band's plastic strain as serial to 1e-9, and every point keeps its
    law as it moves to another rank."""
    (serial,) = _run(tmp_path, case, 1)
    assert min(serial["strain"]) > 0.0  # both bands yield
    for result in _run(tmp_path, case, 2):
        assert result["agree"]
        np.testing.assert_allclose(result["force"], serial["force"], rtol=1e-9)
        np.testing.assert_allclose(result["strain"], serial["strain"], rtol=1e-9)
    assert result["migrated"] > 0  # points did cross to the other rank


def test_the_grid_is_repartitioned_by_its_points_and_the_answer_stays_serial(tmp_path):
    """A Mohr-Coulomb block seeded in the left quarter of a long grid (Newmark, gravity,
    its base held by a facet tag): the ranks own equal shares of the cells, so on 3 ranks
    one holds every point (imbalance 3). Repartitioned by points at set-up (METIS,
    cells weighted by their points), the most points on a rank fall to within 20 % of
    the mean, the facet tag holds the base on the new grid, and the iterations, the
    marker and the base's reaction are the serial ones (measured to 1e-14)."""
    (serial,) = _run(tmp_path, "corner", 1)
    for result in _run(tmp_path, "corner", 3):
        balanced, as_cut = result["balanced"], result["as cut"]
        assert as_cut["imbalance"] == [pytest.approx(3.0)] and as_cut["repartitions"] == 0
        assert balanced["repartitions"] == 1 and max(balanced["imbalance"]) <= 1.2
        want = serial["balanced"]
        assert balanced["iterations"] == want["iterations"]
        for key in ("top", "base"):
            assert np.allclose(balanced[key], want[key], rtol=1e-10, atol=1e-9), key
    assert serial["balanced"]["repartitions"] == 0


@pytest.mark.slow
def test_a_block_falling_onto_the_base_in_dynamics_gives_the_serial_answer(tmp_path):
    """Newmark with consistent and lumped mass, Mohr-Coulomb, gravity: a block seeded on
    part of the grid (some ranks start with no points) falls onto the clamped base and
    yields (consistent mass, 4 steps of 0.05 s; lumped, 10; consistent with the
    velocity projected in 8 passes, 4). Measured against serial: iterations equal,
    marker, mass-weighted height, integrated stress and the grid's kinetic energy
    after each step to 1e-14 relative, also on 2
    ranks; on 3 ranks points cross to other ranks.

    Then the lumped run on 2 ranks with a checkpoint after its fifth step, restored on
    3 ranks and on 1 for five more: each matches the uninterrupted serial run's last
    five steps, to 1e-10 (measured 1e-15)."""
    (serial,) = _run(tmp_path, "falling", 1)
    runs = _run(tmp_path, "falling", 3)
    assert serial["projected"]["height"] != serial["consistent"]["height"]
    for mass in ("consistent", "lumped", "projected"):
        want = serial[mass]
        assert max(want["iterations"]) > 4  # the block has landed and yields
        for result in runs:
            _check_fall(result[mass], want, want["iterations"], mass)
        assert sum(r[mass]["seeded"] for r in runs) == want["seeded"]
    assert min(r["lumped"]["seeded"] for r in runs) == 0  # a rank starts empty
    assert all(r[m]["migrated"] > 0 for r in runs for m in ("consistent", "lumped", "projected"))
    want = serial["lumped"]
    _run(tmp_path, "write checkpoint", 2)
    assert (tmp_path / "ck" / "step_000005" / "points_r0001.npz").is_file()
    for ranks in (3, 1):
        for got in _run(tmp_path, "restore checkpoint", ranks):
            _check_fall(got, want, want["iterations"][5:], ranks)


def test_a_serial_checkpoint_with_a_point_past_the_grids_edge_goes_on_on_two_ranks(tmp_path):
    """Water pours out of the grid's open end with point domains (points dropped as
    their domains leave). At the checkpoint of step 80, written on one rank, a kept
    point lies past the grid's edge (its domain more than half inside). Restored on two
    ranks, such a point lay in no rank's cells and stayed on the rank that read it,
    which held none of its domain's cells, and the next step stopped as if the domain
    had stretched past the ghost cells (a helper's outflow, 2026-12-07). Now it goes to
    a rank that holds its domain's inside, and step 81 gives the serial answer."""
    (serial,) = _run(tmp_path, "outflow write", 1)
    assert serial["outside"] > 0 and serial["dropped"] > 0
    for got in _run(tmp_path, "outflow restore", 2):
        assert got["outside"] == serial["outside"] and got["dropped"] == serial["dropped"]
        for key in ("mass", "x", "y"):
            assert got[key] == pytest.approx(serial[key], rel=1e-10), key


def _check_fall(got: dict, want: dict, iterations: list, case) -> None:
    assert got["iterations"] == iterations, case
    for key in ("corner", "height", "stress"):
        assert np.allclose(got[key], want[key], rtol=1e-10, atol=0), (case, key)
    # The grid's kinetic energy, summed over the ranks' owned nodes (measured 3e-16).
    steps = len(got["grid energy"])
    assert np.allclose(got["grid energy"], want["grid energy"][-steps:], rtol=1e-10, atol=0), case


def test_points_that_fall_out_of_the_grid_are_dropped_on_every_rank_as_in_serial(tmp_path):
    """The block without its base falls out of the grid's bottom (8 steps of Newmark,
    points_leaving="drop"): the same points are dropped, and the rest fall on, as in
    serial (iterations, count, marker and height; measured equal to 1e-15). Rank 0
    reads the count alone (until 2026-12-05 that was a collective, and a user's script
    printing it on rank 0 hung). With point domains (since 2026-12-07) a point goes
    with its domain, once less than half of it is inside: 52 points go where standard
    MPM drops 48, the same on 3 ranks (one of which ends with no points: until its
    fix a division by its zero points stopped it, and the others waited for ever)."""
    (serial,) = _run(tmp_path, "dropping", 1)
    for case in ("points", "domains"):
        ran = serial[case]
        assert 0 < ran["dropped"] < ran["seeded"] == ran["dropped"] + ran["remaining"]
    assert serial["domains"]["dropped"] != serial["points"]["dropped"]  # domains decide
    for rank, both in enumerate(_run(tmp_path, "dropping", 3)):
        for case, got in both.items():
            assert got["iterations"] == serial[case]["iterations"]
            assert got["remaining"] == serial[case]["remaining"]
            assert got["dropped"] == (serial[case]["dropped"] if rank == 0 else None)
            for key in ("corner", "height"):
                assert np.allclose(got[key], serial[case][key], rtol=1e-10, atol=0), key


def test_a_point_that_leaves_the_grid_stops_every_rank_with_one_message(tmp_path):
    lines = _run(tmp_path, "leaving", 2)
    assert all(line["error"] == "PointsOutsideError" for line in lines), lines
    assert all("in none of the 2 MPI ranks' cells" in x["message"] for x in lines)
    assert all("points_leaving='drop'" in x["message"] for x in lines)


def test_a_p2_cell_left_with_too_few_points_stops_every_rank_with_one_message(tmp_path):
    """P2/P1 needs three points in every occupied cell; at 5 N Cook's points leave
    some cells with fewer, on one rank: every rank stops, the serial way."""
    (serial,) = _run(tmp_path, "too few", 1)
    lines = _run(tmp_path, "too few", 2)
    assert serial["error"] == "ConvergenceError" and "needs at least 3" in serial["message"]
    assert all(line["error"] == "ConvergenceError" for line in lines), lines
    assert all("needs at least 3 material points" in x["message"] for x in lines)
    # Counted over every rank (one rank's count, a half of serial's, until 2026-12-08).
    count = re.compile(r"but (\d+) cell\(s\) hold fewer")
    assert {count.search(x["message"]).group(1) for x in lines} == {
        count.search(serial["message"]).group(1)
    }


@pytest.mark.slow
def test_the_ghost_penalty_ties_the_same_facets_on_every_rank_count(tmp_path):
    """Cook's membrane at 5 N with the ghost penalty (γ = 0.1), u-p with three points
    per cell (6 steps), P2/P1 (4 steps; cells with fewer than three points are held
    by their group) and u-p repartitioned after every step: on 2 and 3 ranks each step
    picks the serial number of ghost facets and ties the serial number of cells, some
    facets lie between two ranks, and the iterations and the tip are the serial ones.
    So for a 3D block of tetrahedra falling onto a rigid floor (u-p, Newmark, 12
    steps): its mass centre and floor push. Measured: the tip to 2e-14 (u-p) and
    7e-11 (P2/P1) relative; the bound is 1e-9. Without the fill sent to the ghost
    cells the counts and the tip change (1e-4)."""
    (serial,) = _run(tmp_path, "ghost", 1)
    for ranks in (2, 3):
        for result in _run(tmp_path, "ghost", ranks):
            assert set(result) == set(serial), result
            for case, want in serial.items():
                got = result[case]
                assert got["iterations"] == want["iterations"], case
                facets_and_tied = [[g[0], g[2]] for g in got["ghost facets"]]
                assert facets_and_tied == [[w[0], w[2]] for w in want["ghost facets"]], case
                np.testing.assert_allclose(got["tip"], want["tip"], rtol=1e-9, atol=0)
            assert sum(g[1] for run in result.values() for g in run["ghost facets"]) > 0
    assert all(max(w[0] for w in run["ghost facets"]) > 0 for run in serial.values())
    assert serial["up 16 4 repartitioned"]["repartitions"] == 0


def test_a_layer_started_geostatic_stays_at_rest_on_two_ranks(tmp_path):
    """A 3D Mohr-Coulomb layer (u-nbva, Newmark) started with its stress at rest: on
    two ranks, as in serial, no Newton iteration and no motion (measured 0 m); an
    initial stress of the wrong shape on one rank stops both, naming the field."""
    (serial,) = _run(tmp_path, "geostatic", 1)
    for got in [serial, *_run(tmp_path, "geostatic", 2)]:
        assert got["iterations"] == [0] * 5 and got["moved"] < 1e-12, got
        assert got["points"] == serial["points"] == 384
    lines = _run(tmp_path, "geostatic refused", 2)
    assert all(line["error"] == "ValueError" for line in lines), lines
    assert all("initial_stress must have shape" in x["message"] for x in lines)
    assert "(on rank 1)" in lines[0]["message"]


def test_a_feature_not_yet_distributed_is_refused_on_every_rank(tmp_path):
    lines = _run(tmp_path, "refused", 2)
    assert all(line["error"] == "NotImplementedError" for line in lines), lines
    assert all("not yet shared_increment=True" in x["message"] for x in lines)


def test_an_output_folder_that_cannot_be_made_stops_every_rank(tmp_path):
    """Found 2026-12-06 by a helper: rank 0 stopped on it and rank 1 waited for ever."""
    lines = _run(tmp_path, "output folder is a file", 2)
    assert all(line["error"] == "OSError" for line in lines), lines
    assert all("taken' cannot be created" in x["message"] for x in lines)


@pytest.mark.slow
def test_point_domains_give_the_serial_answer_on_three_ranks_and_restart_across_counts(tmp_path):
    """Point domains cut by each rank's cells and its ghosts, their pieces assembled
    where they lie: Cook u-p at 5 N (three points per cell, 8 steps), u-nbva (4
    steps) and P2/P1 (three points per cell, 4 steps, their pieces' mean increment
    kept on every rank), a 3D block of domains falling onto the base (5 Newmark steps) on a grid
    repartitioned as it goes, the rough strip footing on h = 0.2 B (8 steps to
    s/B = 0.8; from the fourth some domains have distorted and are redrawn or
    flipped with a neighbour; on 3 ranks one pair spanned two, seen by a debug
    print), and a
    small block in the corner of a long grid (on 3 ranks two hold no point). The
    footing written after 4 steps on 2 ranks and restored on 3 goes on as in serial.
    Measured against serial: the same iterations, the tip, the mass centre and q to
    5e-12 relative (the bound is 1e-9), and points move between ranks. Defects this
    caught: the footing's redrawn domains used the pieces of their old shapes for a
    step in serial, which 2 ranks did not (q moved by 3 %); a corner past the grid's
    edge took the cell of the lower local number among equally good ones, which
    differs between partitions (the block's mass centre moved by 7e-7); a rank
    without points failed to cut its (no) domains; and the step's counts were each
    rank's own (found by a helper, 2026-12-06)."""
    (serial,) = _run(tmp_path, "domains", 1)
    redrawn, flipped = np.array(serial["footing"]["resets"]).T  # totals after each step
    assert redrawn[3] > 0 and flipped[-1] > flipped[3]  # redrawn by step 4, flipped after
    for ranks in (3,):  # 2 ranks write the checkpoint below
        for result in _run(tmp_path, "domains", ranks):
            for case, want in serial.items():
                got = result[case]
                assert got["iterations"] == want["iterations"], case
                np.testing.assert_allclose(got["tip"], want["tip"], rtol=1e-9, atol=0)
                assert case == "corner" or got["migrated"] > 0, case
                # Counted over the ranks, each cell once (until 2026-12-06 each rank
                # reported its own pieces' cells, and an imbalance of 1).
                assert got.get("occupied") == want.get("occupied"), case
            assert result["up 16 8"]["imbalance"] > 1.0
            assert result["footing"]["resets"] == serial["footing"]["resets"]
            # Three points per P2 cell: every rank keeps the pieces' mean increment.
            assert result["up-p2p1 8 4"]["mean increment"]
            assert result["3D block"]["repartitions"] > 1
    assert 0 in result["corner"]["points"]  # on 3 ranks a rank holds no point
    # Written after 4 steps on 2 ranks and restored on 3, the domains go on as in serial.
    _run(tmp_path, "domains checkpoint", 2)
    want = serial["footing"]
    for got in _run(tmp_path, "domains restored", 3):
        assert got["iterations"] == want["iterations"][4:]
        assert got["resets"] == want["resets"][4:]
        np.testing.assert_allclose(got["tip"], want["tip"][4:], rtol=1e-9, atol=0)


def test_a_domain_past_a_ranks_ghost_cells_stops_every_rank_with_one_message(tmp_path):
    """Without ghost cells to cut by, a domain reaching into another rank's cells would
    lose its pieces there: every rank stops, naming the corner."""
    lines = _run(tmp_path, "domains past the ghosts", 2)
    assert all(line["error"] == "ConvergenceError" for line in lines), lines
    assert all("reaches past the cells this MPI rank holds" in x["message"] for x in lines)


def test_a_domain_across_another_ranks_cells_between_its_corners_stops_every_rank(tmp_path):
    """Its corners in cells this rank owns, a domain crosses cells of another rank
    that this rank does not hold: in serial it is cut whole, on 2 ranks every rank
    stops, naming the domain, where the cut would have dropped the middle part and
    spread the point's volume over the rest unnoticed."""
    (serial,) = _run(tmp_path, "domain across a rank", 1)
    assert serial["shares"] == pytest.approx(1.0, abs=1e-12)
    assert len(serial["cells"]) > 8  # it covers the strip from x = 1 to 7
    lines = _run(tmp_path, "domain across a rank", 2)
    assert all(line["error"] == "ConvergenceError" for line in lines), lines
    assert all("reaches past the cells this MPI rank holds" in x["message"] for x in lines)
    assert all("its corners [[1.0, 0.2], [1.0, 0.8], [7.0, 0.5]]" in x["message"] for x in lines)


def test_a_grid_without_ghost_cells_gets_them_for_the_ghost_penalty_and_a_fluid(tmp_path):
    """gmsh's ``model_to_mesh`` builds a grid without ghost cells, and the ghost penalty
    and a fluid's pressure by parts integrate over the facets between ranks. Until
    2026-12-05 such a grid was refused on 2 ranks (a user's gmsh dam break found it);
    now ``Simulation`` adds the shared-facet layer, every cell staying on its rank.
    A block whose top cuts the cells under the ghost penalty, its base held by a facet
    tag, and water sloshing in a tank (10 Newmark steps): on 2 ranks the serial
    iterations, ghost facets and mean motion (bound 1e-10 relative, round-off)."""
    (serial,) = _run(tmp_path, "no ghost layer", 1)
    assert serial["block"]["ghost facets"][0] > 0  # the penalty acts
    assert serial["water"]["by parts"]
    for result in _run(tmp_path, "no ghost layer", 2):
        assert "error" not in result, result
        assert result["water"]["ghosts"] > 0
        for case in ("block", "water"):
            got, want = result[case], serial[case]
            assert got["iterations"] == want["iterations"], case
            scale = np.max(np.abs(want["motion"]))
            np.testing.assert_allclose(got["motion"], want["motion"], rtol=0, atol=1e-10 * scale)
        assert result["block"]["ghost facets"][0] == serial["block"]["ghost facets"][0]
        assert result["block"]["ghost facets"][1] > 0  # some lie between the ranks
        assert result["block"]["rebuilt"] and result["block"]["kept owners"]


def test_boundary_points_act_on_one_rank_each_and_give_the_serial_answer(tmp_path, ranks=3):
    """Every rank holds every boundary point; each acts on the rank whose cell it reads.
    Cook u-p at 5 N as a PointTraction that follows the body (6 steps, points
    migrating), and the smooth strip footing, a PointDirichlet pushed 0.16 B down over
    10 steps (h = 0.2 B; q rises 4.5-fold as the soil yields). Measured against
    serial: the same iterations, tip and q to 5e-14 relative, also on 2 ranks; the
    traction's reported force is the whole load on every rank. And the squeezed block
    of ``scenes.platen_compression`` (standard MPM, 10 steps to half its length),
    whose platen points above the block's corner lie as near two occupied cells: they
    must take the same one on every partition (by index, 2 ranks once ended 0.5 %
    off the serial force). And a pin of penalty points beside a fixed base, whose
    share on the base's nodes moves to the base's reaction on the ranks that hold the
    pin's points: the three forces to 1e-10 of serial."""
    (serial,) = _run(tmp_path, "boundary points", 1)
    runs = _run(tmp_path, "boundary points", ranks)
    for result in runs:
        for scene, key in (("cook", "tip"), ("footing", "q"), ("platen", "force")):
            want, got = serial[scene], result[scene]
            assert got["iterations"] == want["iterations"], scene
            assert np.allclose(got[key], want[key], rtol=1e-10, atol=0), scene
        for name in ("top", "pin", "base"):
            assert np.allclose(result["pin"][name], serial["pin"][name], rtol=1e-10, atol=1e-6)
        assert result["cook"]["load"] == pytest.approx([0.0, 5.0], abs=1e-12)
    assert serial["footing"]["q"][-1] > 2 * serial["footing"]["q"][0]  # the soil yields
    assert runs[0]["cook"]["migrated"] > 0 and runs[0]["footing"]["migrated"] > 0


def test_a_wall_nodes_gap_is_the_same_on_every_rank_that_holds_it(tmp_path):
    """Each wall node looks for the body as far along the wall as its own facets
    reach; a rank that held only some of a shared node's facets gave it another
    reach, so the node took two gaps and the answer moved with the partition (a
    reviewer, 2026-12-07: 7 nodes of a disk over a graded floor on 2 ranks, 17 on 3).
    Every rank's gap at every node it holds is now the serial one, to round-off."""
    (serial,) = _run(tmp_path, "wall gaps", 1)
    at = {round(x, 12): k for k, x in enumerate(serial["x"])}
    for ranks in (2, 3):
        for result in _run(tmp_path, "wall gaps", ranks):
            rows = [at[round(x, 12)] for x in result["x"]]
            for mine, alone in zip(result["gaps"], serial["gaps"], strict=True):
                np.testing.assert_allclose(mine, np.asarray(alone)[rows], rtol=0, atol=1e-12)
    assert max(max(g) for g in serial["gaps"]) > 0.0  # the disk is clear of some nodes


def test_the_bodies_counted_on_three_ranks_are_the_serial_ones(tmp_path):
    """Only the nodes that ranks share travel (fe_mpm/bodies.py), and the bodies found
    are the serial ones: the same count, and the same cells together."""
    serial = _run(tmp_path, "bodies", 1)[0]
    ranks = _run(tmp_path, "bodies", 3)
    for key in [key for key in serial if key.endswith(("ghosts", "none"))]:
        for rank in ranks:  # with ghost cells, and with a rank that has none
            assert rank[key][0] == rank[key][1], key
        del serial[key]
    for key, alone in serial.items():
        assert all(rank[key]["count"] == alone["count"] for rank in ranks), key
        body_at = {tuple(c): b for c, b in zip(alone["cells"], alone["body"], strict=True)}
        pairs = {
            (body_at[tuple(c)], b)
            for rank in ranks
            for c, b in zip(rank[key]["cells"], rank[key]["body"], strict=True)
        }
        assert len(body_at) == sum(len(rank[key]["cells"]) for rank in ranks), key
        # One to one: each serial body is one distributed body, and no two share one.
        assert len(pairs) == alone["count"] == len({b for _, b in pairs}), key
    assert sorted(alone["count"] for alone in serial.values()) != [1] * len(serial)


def test_serial_meshes_run_independently_on_each_rank(tmp_path):
    lines = _run(tmp_path, "self", 2)
    assert isinstance(lines[0], float) and lines[0] == lines[1]  # the same serial answer


def _demo_json(name: str, ranks: int, *args: str) -> dict:
    """The JSON summary a demo prints as its last line, run on ``ranks`` ranks."""
    demo = Path(__file__).resolve().parent.parent / "demos" / name
    done = subprocess.run(
        [_mpiexec(), "-n", str(ranks), sys.executable, "-m", "mpi4py", str(demo), *args, "--json"],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ),
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    ("demo", "args", "key"),
    [
        ("elastic_column.py", ("--ny", "8", "--steps", "2"), "error"),
        ("sliding_block.py", ("--t-end", "0.5"), "slide_m"),
    ],
)
def test_demos_run_unchanged_on_two_ranks_and_print_the_serial_summary(demo, args, key):
    """Their measures sum or gather the points of every rank; rank 0 prints once."""
    serial, shared = _demo_json(demo, 1, *args), _demo_json(demo, 2, *args)
    assert shared["n_particles"] == serial["n_particles"]
    assert shared["check_passed"] and serial["check_passed"]
    # The column's stress error and the block's slide (a sum over every point).
    assert shared[key] == pytest.approx(serial[key], rel=1e-10, abs=0)


def test_water_in_nbva_sloshes_as_in_serial_on_two_ranks(tmp_path):
    """NB-VA water (its points take the volume changes averaged over the nodes, a sum
    over the ranks, and the starting pressure by parts), its surface tilted, sloshing
    for 10 steps: on two ranks the serial iterations, volume, mass centre and kinetic
    energy (measured: 2e-16, 3e-15 and 6e-12 relative; the bound is 1e-10)."""
    (serial,) = _run(tmp_path, "nbva slosh", 1)
    assert max(serial["iterations"]) > 1 and serial["kinetic"] > 0.0
    for got in _run(tmp_path, "nbva slosh", 2):
        assert got["iterations"] == serial["iterations"]
        for key in ("volume", "mass centre", "kinetic"):
            assert got[key] == pytest.approx(serial[key], rel=1e-10, abs=0), key


LONE_EXCEPTION = """
import sys
from mpi4py import MPI
from fe_mpm import parallel
parallel.abort_on_lone_exception(wait=2.0)
comm = MPI.COMM_WORLD
if sys.argv[1] == "lone" and comm.rank == 1:
    raise RuntimeError("rank 1 alone")
if sys.argv[1] == "every":
    raise RuntimeError(f"rank {comm.rank} too")
comm.barrier()
"""


@pytest.mark.parametrize("case", ["lone", "every"])
def test_an_exception_on_one_rank_alone_aborts_every_rank(tmp_path, case):
    """With petsc4py loaded, an uncaught exception on one rank left the others waiting
    in a collective call for ever, ``python -m mpi4py`` or not (a helper's 3-rank run,
    2026-12-06). ``parallel.abort_on_lone_exception`` aborts them once the stopped
    rank has waited 2 s here for the others; an exception every rank raises ends
    them all as before, without an abort."""
    script = tmp_path / "lone.py"
    script.write_text(LONE_EXCEPTION)
    done = subprocess.run(
        [_mpiexec(), "-n", "2", sys.executable, "-m", "mpi4py", str(script), case],
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ),
    )
    output = done.stdout + done.stderr
    assert done.returncode != 0, output
    assert ("aborting every rank" in output) == (case == "lone"), output


CAUGHT_AND_ENDED = """
import sys
import numpy as np
import fe_mpm
from fe_mpm.meshes import rectangle_mesh, cell_centroids
mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (8, 8))
block = np.flatnonzero(cell_centroids(mesh)[:, 0] < 0.5)
points = fe_mpm.seed(mesh, 3, cells=block, density=1000.0)
points.velocity[:, 0] = 20.0
sim = fe_mpm.Simulation(
    mesh, points, fe_mpm.NeoHookean(1e5, 0.3), dynamic=True, output_dir=sys.argv[1]
)
try:
    sim.run(0.1, 20, progress=False)
except fe_mpm.PointsOutsideError:
    print("caught", flush=True)
"""


def test_a_script_that_caught_an_error_ends_on_two_ranks_with_its_output_open(tmp_path):
    """A script that caught a run's PointsOutsideError and ended without
    ``sim.close()`` hung at exit on 2 ranks (a helper's, 4 times of 4): the grid's
    ADIOS2 files, closed by the garbage collector at each rank's own moment, waited
    on one rank while the other was in PETSc's finalisation. They are now closed at
    exit on every rank in turn."""
    script = tmp_path / "caught.py"
    script.write_text(CAUGHT_AND_ENDED)
    done = subprocess.run(
        [_mpiexec(), "-n", "2", sys.executable, "-m", "mpi4py", str(script), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ),
    )
    output = done.stdout + done.stderr
    assert done.returncode == 0 and done.stdout.count("caught") == 2, output  # (stderr warns)
    assert (tmp_path / "grid.bp").is_dir()
