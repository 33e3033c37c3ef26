"""Checks shared by the tests of the laws that return at the points."""

from __future__ import annotations

import numpy as np

from fe_mpm.verification import rates, taylor_remainders

#: The Taylor test's steps: small enough that no point changes its return's region.
TAYLOR_EPS = (2e-5, 1e-5, 5e-6, 2.5e-6)


def finite_difference_error(law, dF, history, tangent, h=1e-7):
    """max |central difference − tangent| per point (n,), and where neither difference
    left the point's region (the return is only piecewise smooth)."""
    g = dF.shape[1]
    error = np.zeros(len(dF))
    region = law.return_map(dF, history).region
    same = np.ones(len(dF), dtype=bool)
    for k, m in np.ndindex(g, g):
        E = np.zeros((g, g))
        E[k, m] = h
        up, down = law.return_map(dF + E, history), law.return_map(dF - E, history)
        same &= (up.region == region) & (down.region == region)
        fd = (up.tau - down.tau) / (2 * h)
        error = np.maximum(error, np.abs(fd - tangent[..., k, m]).max(axis=(1, 2)))
    return error, same


def assert_step_is_consistent(sim, rng, regions_seen: int) -> np.ndarray:
    """Taylor test of an assembled step of ``sim`` (a ``test_taylor._simulation``) at a
    random iterate: first- and second-order remainders, no point changing region
    between the evaluations, and at least ``regions_seen`` regions among the points,
    which it returns.

    With volumetric averaging (``u-nbva``) the averaged volume change θ is drawn
    from ±0.2, so that the points' volume changes span the regions of the cone
    (with Δu's ±0.02 alone they stay near zero)."""
    _, _, R, J, _ = sim.prepare_step(1.0)
    sim.w.x.array[:] = rng.uniform(-0.02, 0.02, sim.w.x.array.size)
    if sim.spec.volume_average:
        theta = sim.fields.Q[1]
        sim.w.x.array[theta] = rng.uniform(-0.2, 0.2, theta.size)
    regions = []

    def refresh():
        regions.append(sim.refresh_material().region.copy())

    d = rng.uniform(-1.0, 1.0, sim.w.x.array.size)
    r0, r1 = taylor_remainders(R, J, sim.w, d, TAYLOR_EPS, before_assembly=refresh)
    assert all(np.array_equal(regions[0], r) for r in regions)
    assert len(np.unique(regions[0])) >= regions_seen
    assert np.all(rates(TAYLOR_EPS, r0) > 0.9)
    assert np.all(rates(TAYLOR_EPS, r1) > 1.9), f"remainders {r1}"
    return regions[0]
