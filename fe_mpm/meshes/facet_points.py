"""Boundary points on tagged facets (their quadrature points), for loads that follow the body."""

from __future__ import annotations

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_indices, check_int


def facet_points(
    mesh: dolfinx.mesh.Mesh,
    facets: np.ndarray,
    degree: int = 1,
    subdivisions: int = 1,
    corners: bool = False,
) -> tuple[np.ndarray, ...]:
    """Quadrature points of straight facets and their weights.

    With ``degree=1``, one point per facet at its midpoint, weighted by its length
    (or area): ``Σ_b w_b t·δu(x_b)`` then integrates a constant traction against a
    P1 test function exactly, what :class:`~fe_mpm.boundary.PointTraction` needs to
    reproduce a grid traction on those facets. A P2 test function needs
    ``degree=2``: the midpoint rule would put the whole load of a facet on its
    middle node (a quadratic vertex function vanishes there), and the edge is then
    loaded unevenly. Degree 2 takes the two Gauss points of each
    edge (2D) or the three points ``(2/3, 1/6, 1/6)`` of each triangle (3D), each
    with an equal share of the facet's measure.

    Boundary points are held by every rank (see :class:`~fe_mpm.boundary.PointTraction`),
    so on a distributed mesh this is collective: each rank contributes the facets
    it owns and every rank gets the points of all of them, in rank order.

    Args:
        mesh: Affine simplex mesh.
        facets: Local facet indices, e.g. ``facet_tags.find(tag)``, shape (m,); ghost
            facets are left to the rank that owns them.
        degree: 1 or 2, the degree of the displacement the points load.
        corners: Also return the corners of the facet piece each point stands for:
            a :class:`~fe_mpm.boundary.PointPressure` given them follows its face by
            where those corners move, not by the ΔF of one cell.
        subdivisions: Each facet is cut into this many equal pieces along each of
            its edges (k pieces of an edge, k² triangles of a triangle), each with
            the rule of ``degree``: more points where the face will slide along the
            grid's facets, as a stretching face does. Each point loads the nodes of
            the cell it lies in, so one point per facet gives the nodes uneven
            shares once the points have moved along the face: beside the face of a
            unit plate (E = 1 MPa, ν = 0.3) pulled by a ``PointTraction`` of 30 kPa in 8
            steps, σ_xx was 9.0 % off with one, 0.33 % with 8 and 0.03 % with 32 points
            per facet (gmsh cells of 0.1 m, point domains; ``docs/user_scenes.md``).

    Returns:
        ``(x, weight)``: the points (m q, g) in m, facet by facet, and their weights
        (m q,) in m (2D) or m² (3D), with q = 1 or the rule's points per facet; with
        ``corners``, also each point's piece's corners (m q, g, g) in m.
    """
    if degree not in (1, 2):
        raise ValueError(f"facet_points: degree must be 1 or 2, got {degree!r}")
    check_int("facet_points", "subdivisions", subdivisions, lo=1)
    want_corners = bool(corners)
    g = mesh.geometry.dim
    fdim = mesh.topology.dim - 1
    # Facets found with dolfinx.mesh.locate_entities exist before their connectivity.
    mesh.topology.create_connectivity(fdim, fdim + 1)
    index_map = mesh.topology.index_map(fdim)
    size = index_map.size_local + index_map.num_ghosts
    # Every rank refuses together: one alone would leave the others in the gather below.
    facets = parallel.check_together(
        mesh.comm,
        check_indices,
        "facet_points",
        "facets",
        facets,
        size,
        kinds=(TypeError, ValueError),
    )
    if mesh.comm.size > 1:
        facets = facets[facets < mesh.topology.index_map(fdim).size_local]
    nodes = dolfinx.mesh.entities_to_geometry(mesh, fdim, facets)
    corners = mesh.geometry.x[nodes][:, :, :g]  # (m, fdim + 1, g)
    edges = corners[:, 1:] - corners[:, :1]
    if fdim == 1:
        weight = np.linalg.norm(edges[:, 0], axis=1)
    else:
        weight = 0.5 * np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1)
    if degree == 1 and subdivisions == 1:
        x, weight = _from_every_rank(mesh.comm, corners.mean(axis=1), weight)  # to the bit
        return (x, weight, parallel.gathered(mesh.comm, corners)) if want_corners else (x, weight)
    if degree == 1:
        rule = np.full((1, fdim + 1), 1.0 / (fdim + 1))
    elif fdim == 1:
        a = 0.5 / np.sqrt(3.0)
        rule = np.array([[0.5 + a, 0.5 - a], [0.5 - a, 0.5 + a]])
    else:
        rule = np.full((3, 3), 1.0 / 6.0) + 0.5 * np.eye(3)
    pieces = _equal_pieces(fdim, int(subdivisions))  # (pieces, fdim + 1, fdim + 1)
    bary = np.einsum("qv,pvw->pqw", rule, pieces).reshape(-1, fdim + 1)
    x = np.einsum("qv,mvg->mqg", bary, corners).reshape(-1, g)
    x, weight = _from_every_rank(mesh.comm, x, np.repeat(weight / len(bary), len(bary)))
    if not want_corners:
        return x, weight
    # Each piece's corners, once for every point of the rule on it (points: piece-major).
    pieces_at = np.einsum("pvw,mwg->mpvg", pieces, corners)
    per_point = np.repeat(pieces_at, len(rule), axis=1).reshape(-1, fdim + 1, g)
    return x, weight, parallel.gathered(mesh.comm, per_point)


def _equal_pieces(fdim: int, k: int) -> np.ndarray:
    """A reference facet cut into equal pieces: k segments, or k² triangles.

    Returns each piece's vertices in the facet's barycentric coordinates, shape
    (pieces, fdim + 1, fdim + 1).
    """
    if fdim == 1:
        ends = np.arange(k + 1) / k
        return np.stack(
            [
                np.column_stack([1 - ends[:-1], ends[:-1]]),
                np.column_stack([1 - ends[1:], ends[1:]]),
            ],
            axis=1,
        )
    lattice = []  # (i, j): the point i/k along the first edge, j/k along the second
    for i in range(k):
        for j in range(k - i):
            lattice.append([(i, j), (i + 1, j), (i, j + 1)])
            if i + j < k - 1:
                lattice.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
    ij = np.array(lattice, dtype=float) / k  # (pieces, 3, 2)
    return np.concatenate([1.0 - ij.sum(axis=2, keepdims=True), ij], axis=2)


def _from_every_rank(comm, x: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points and weights of all ranks, in rank order, on every rank."""
    return parallel.gathered(comm, x), parallel.gathered(comm, weight)
