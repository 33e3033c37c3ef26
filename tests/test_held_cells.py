"""The fallback that retries a failed step without re-binning the points.

A held point lies outside the cell it is integrated in; P1 fields are linear in
each cell, so it reads that cell's field extended beyond the cell.
"""

import numpy as np

import fe_mpm
from fe_mpm.errors import ConvergenceError
from fe_mpm.meshes import cell_centroids, rectangle_mesh


def _block_sim(**options):
    mesh = rectangle_mesh((0, 0), (3, 3), (30, 30))
    c = cell_centroids(mesh)
    block = np.flatnonzero((c[:, 0] > 0.2) & (c[:, 0] < 0.8) & (c[:, 1] > 0.2) & (c[:, 1] < 0.8))
    points = fe_mpm.seed(mesh, per_cell=3, cells=block)
    return fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e4, 0.3), **options)


def test_held_points_read_their_old_cells_field_extended_exactly():
    """Shift every point by 0.37 of a cell, so most leave their cells, and hold them.

    A grid field that is linear in x must then give, at every point, the same Δu
    and ΔF as in the point's own cell: Δu(x_p) = a + B x_p and ΔF = I + B, to round-off.
    """
    sim = _block_sim()
    sim.step(0.5)  # an accepted step records the cells
    sim.points.x += np.array([0.037, 0.021])
    a, B = np.array([1e-3, -2e-3]), np.array([[2e-3, 5e-4], [-1e-3, 3e-3]])

    def point_values(rebin):
        forms, layout, *_ = sim.prepare_step(1.0, rebin=rebin)
        sim.w.interpolate(lambda x: a[:, None] + B @ x[:2])
        values = forms.update.evaluate(layout)
        return values[:, :2], values[:, 2:6].reshape(-1, 2, 2)

    du_held, dF_held = point_values(rebin=False)
    assert sim.tracking.held_points > 0.5 * len(sim.points)
    du_own, dF_own = point_values(rebin=True)
    assert sim.tracking.held_points == 0
    exact = a + sim.points.x @ B.T
    assert np.abs(du_held - exact).max() < 1e-14
    assert np.abs(du_own - exact).max() < 1e-14
    assert np.abs(dF_held - (np.eye(2) + B)).max() < 1e-13
    assert np.abs(dF_own - (np.eye(2) + B)).max() < 1e-13


def test_held_points_read_their_old_cells_field_not_their_new_cells():
    """The same shift, with a grid field that is only piecewise linear (the nodal
    interpolant of a smooth field): a held point must read the linear function of the
    cell it was in, extended to where it is now, which differs from its new cell's.
    The expected values come from that cell's three nodes alone."""
    sim = _block_sim()
    sim.step(0.5)
    old = sim.tracking._home[:, 1].copy()  # the cells of the accepted step
    sim.points.x += np.array([0.037, 0.021])
    forms, layout, *_ = sim.prepare_step(1.0, rebin=False)
    held = layout.cell != sim.tracker.locate(sim.points.x)
    assert held.sum() > 0.5 * len(sim.points) and np.array_equal(layout.cell, old)
    sim.w.interpolate(lambda x: np.stack([np.sin(3 * x[0]) * x[1], x[0] ** 2 - 2 * x[1] ** 2]))
    values = forms.update.evaluate(layout)
    V = sim.w.function_space
    coords, w = V.tabulate_dof_coordinates()[:, :2], sim.w.x.array.reshape(-1, 2)
    for p in np.flatnonzero(held)[::7]:
        dofs = V.dofmap.cell_dofs(old[p])
        # the linear function a + B x through the old cell's three nodal values
        A = np.column_stack([np.ones(3), coords[dofs]])
        coef = np.linalg.solve(A, w[dofs])  # rows: a, then Bᵀ
        du = coef[0] + sim.points.x[p] @ coef[1:]
        assert np.abs(values[p, :2] - du).max() < 1e-13
        assert np.abs(values[p, 2:6].reshape(2, 2) - (np.eye(2) + coef[1:].T)).max() < 1e-12


def _failing_once_after_rebinning(sim, at_step):
    """Make ``sim.step`` fail once in step ``at_step`` when it re-bins, as Newton may
    on a plastic body; return the list the failure times go to."""
    failed, step = [], sim.step

    def failing_once(t_new, rebin=True):
        if sim.step_number + 1 == at_step and rebin and not failed:
            failed.append(t_new)
            raise ConvergenceError("made to fail")
        return step(t_new, rebin)

    sim.step = failing_once
    return failed


def test_a_step_that_fails_after_rebinning_is_retried_with_held_points_before_it_is_cut():
    """A static, unloaded block whose points were moved by 0.37 of a cell: ``run``
    must retry the failed step with the points held, at the same step length."""
    sim = _block_sim()
    sim.step(0.5)
    sim.points.x += np.array([0.037, 0.021])
    failed = _failing_once_after_rebinning(sim, at_step=2)
    reports = sim.run(1.5, 2, progress=False)
    assert failed == [1.0]
    assert [r.t for r in reports] == [1.0, 1.5]  # not cut
    assert reports[0].held_points > 0.5 * len(sim.points)
    assert reports[1].held_points == 0  # re-binned again


def test_the_fallback_is_off_when_asked_and_in_dynamic_runs():
    for options in ({"fallback_hold_cells": False}, {"dynamic": True}):
        sim = _block_sim(min_step=0.1, **options)
        sim.step(0.5)
        sim.points.x += np.array([0.037, 0.021])
        failed = _failing_once_after_rebinning(sim, at_step=2)
        reports = sim.run(1.5, 2, progress=False)
        assert failed == [1.0]
        assert [r.t for r in reports] == [0.75, 1.0, 1.5]  # cut, then grown back
        assert all(r.held_points == 0 for r in reports)
