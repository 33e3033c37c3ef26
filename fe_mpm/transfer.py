"""Point → grid transfer: sums of point values on the nodes of a P1 space.

Every function takes the points' cells and their barycentric coordinates there
(``Tracker.barycentric``), which are the P1 shape functions ``N_I(x_p)`` of the
cell's vertices in the order of the space's local dofs. Nodal sums are taken with
``np.bincount``, one pass per value column.
"""

from __future__ import annotations

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx


def nodal_shares(
    space: dolfinx.fem.FunctionSpace, cells: np.ndarray, bary: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, int]:
    """Each point's ``N_I(x_p) w_p`` with its node I, for ``np.bincount``.

    Args:
        space: A P1 space (its local dofs follow the cell's vertices).
        cells: The points' cells (n,).
        bary: Their barycentric coordinates there (n, g + 1).
        weights: A weight per point (n,), e.g. its mass.

    Returns:
        ``(nodes, shares, n)``: node and share of every (point, vertex) pair, both
        flat ``(n_points * (g + 1),)``, and the number of nodes (owned and ghost).
    """
    nodes = space.dofmap.list[cells].ravel()
    shares = (bary * weights[:, None]).ravel()
    return nodes, shares, space.dofmap.index_map.size_local + space.dofmap.index_map.num_ghosts


def summed_over_ranks(
    space: dolfinx.fem.FunctionSpace | dolfinx.common.IndexMap, nodal: np.ndarray
) -> np.ndarray:
    """Nodal sums (nodes,) or (nodes, k) of this rank's points, completed with the other ranks'.

    A node on a rank boundary gets points from the cells of both ranks: the owner adds
    the ghosts' partial sums (a reverse scatter) and sends the total back (a forward
    one). ``space`` is a scalar space (block size 1) or the nodes' index map (e.g. the
    geometry's). On one rank the sums are returned unchanged.
    """
    index_map = getattr(getattr(space, "dofmap", None), "index_map", space)
    if index_map.comm.size == 1:
        return nodal
    k = 1 if nodal.ndim == 1 else nodal.shape[1]
    vector = dolfinx.la.vector(index_map, bs=k)
    vector.array[:] = nodal.ravel()
    vector.scatter_reverse(dolfinx.la.InsertMode.add)
    vector.scatter_forward()
    return vector.array.reshape(nodal.shape).copy()


def touched_nodes(space: dolfinx.fem.FunctionSpace, cells: np.ndarray) -> np.ndarray:
    """Which nodes of a P1 space (owned and ghost) some rank's ``cells`` touch, (nodes,) bool."""
    index_map = space.dofmap.index_map
    uses = np.bincount(
        space.dofmap.list[cells].ravel(), minlength=index_map.size_local + index_map.num_ghosts
    )
    return summed_over_ranks(index_map, uses.astype(np.float64)) > 0


def mass_weighted_projection(
    space: dolfinx.fem.FunctionSpace,
    cells: np.ndarray,
    bary: np.ndarray,
    mass: np.ndarray,
    values: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``Σ_p N_I(x_p) m_p v_p / Σ_p N_I(x_p) m_p`` on the nodes of a P1 space.

    Args:
        space: A P1 space (its local dofs follow the cell's vertices).
        cells: The points' cells (n,).
        bary: Their barycentric coordinates there (n, g + 1).
        mass: The points' masses (n,) in kg.
        values: Per-point values, shape ``(n, k)``.

    Returns:
        Nodal values ``(nodes, k)`` (zero where no point reaches) and the nodal
        masses ``Σ_p N_I m_p`` ``(nodes,)``.
    """
    shares, nodal_mass = _shares_and_nodal_mass(space, cells, bary, mass)
    return _weighted_means(space, shares, nodal_mass, values), nodal_mass


def _shares_and_nodal_mass(
    space: dolfinx.fem.FunctionSpace, cells: np.ndarray, bary: np.ndarray, mass: np.ndarray
) -> tuple[tuple[np.ndarray, np.ndarray, int], np.ndarray]:
    """:func:`nodal_shares` of the masses, and the nodal masses ``Σ_p N_I m_p`` (nodes,)."""
    shares = nodal_shares(space, cells, bary, mass)
    nodes, weights, n = shares
    return shares, summed_over_ranks(space, np.bincount(nodes, weights=weights, minlength=n))


def _weighted_means(
    space: dolfinx.fem.FunctionSpace,
    shares: tuple[np.ndarray, np.ndarray, int],
    nodal_mass: np.ndarray,
    values: np.ndarray,
) -> np.ndarray:
    """``Σ_p N_I m_p v_p / Σ_p N_I m_p`` (nodes, k), zero where no point reaches.

    From :func:`nodal_shares`' output and the nodal masses, both computed once, so
    that each pass of :func:`consistent_projection` sums over the ranks once.
    """
    nodes, weights, n = shares
    repeated = np.repeat(values, space.dofmap.list.shape[1], axis=0)
    moment = np.stack(
        [
            np.bincount(nodes, weights=weights * repeated[:, c], minlength=n)
            for c in range(values.shape[1])
        ],
        axis=1,
    )
    moment = summed_over_ranks(space, moment)
    return np.divide(
        moment, nodal_mass[:, None], out=np.zeros_like(moment), where=nodal_mass[:, None] > 0
    )


def consistent_projection(
    space: dolfinx.fem.FunctionSpace,
    cells: np.ndarray,
    bary: np.ndarray,
    mass: np.ndarray,
    values: np.ndarray,
    passes: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The consistent-mass projection of point values, approximated in ``passes`` passes (FMPM).

    The field ``ṽ`` that interpolates the points' values best in the mass norm solves
    ``M ṽ = Σ_p N m_p v_p`` with the consistent mass ``M_IJ = Σ_p m_p N_I N_J``.
    Each pass adds the lumped projection of what the field still misses at the
    points (FMPM(k), k the passes: Nairn and Hammerquist 2021, revised in Nairn 2026,
    arXiv:2604.07307; a Jacobi iteration on ``M`` with the lumped mass):

        ṽ ← ṽ + M_L⁻¹ Σ_p N m_p (v_p − ṽ(x_p)),   starting from ṽ = 0,

    so one pass is :func:`mass_weighted_projection` and more passes approach the
    consistent projection, which reproduces any P1 field exactly. A mode the
    points barely see (``M`` near-singular, one point per cell) grows at most
    linearly with the passes, where the exact solve would amplify it without bound
    (on the rolling disk's grid the exact solve stopped Newton in step 53).

    The arguments and what is returned are :func:`mass_weighted_projection`'s, with
    ``passes`` the number of passes, ≥ 1.
    """
    if passes < 1:
        raise ValueError(f"consistent_projection: passes must be ≥ 1, got {passes}")
    shares, nodal_mass = _shares_and_nodal_mass(space, cells, bary, mass)
    nodal = _weighted_means(space, shares, nodal_mass, values)
    vertices = space.dofmap.list[cells]
    for _ in range(passes - 1):
        missed = values - np.einsum("pv,pvc->pc", bary, nodal[vertices])
        nodal += _weighted_means(space, shares, nodal_mass, missed)
    return nodal, nodal_mass


def nodal_sum_norm(
    space: dolfinx.fem.FunctionSpace, cells: np.ndarray, bary: np.ndarray, weights: np.ndarray
) -> float:
    """``‖Σ_p N_I(x_p) w_p‖``: the norm of the weights gathered on the nodes.

    With the points' volumes on the pressure nodes, the scale of the pressure rows
    in Newton's test (m³; m² in 2D).
    """
    nodes, shares, n = nodal_shares(space, cells, bary, weights)
    sums = summed_over_ranks(space, np.bincount(nodes, weights=shares, minlength=n))
    owned = sums[: space.dofmap.index_map.size_local]  # each node once
    return float(np.sqrt(parallel.total(space.mesh.comm, float(owned @ owned))))


def second_moments(vertices: np.ndarray, x: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """``C_p = Σ_I N_I(x_p) (x_I − x_p)⊗(x_I − x_p)`` of every point, (n, g, g) in m².

    Args:
        vertices: The vertices of each point's cell (n, g + 1, g) in m.
        x: The points' positions (n, g) in m.
        bary: Their barycentric coordinates (n, g + 1).
    """
    r = vertices - x[:, None, :]
    return np.einsum("pv,pvi,pvj->pij", bary, r, r)
