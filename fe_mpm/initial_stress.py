r"""A body that starts stressed: the geostatic state, and the elastic strain that carries it.

A soil layer at rest under gravity carries a vertical stress
:math:`\sigma_v = -\rho g d` at depth :math:`d` and a horizontal stress
:math:`\sigma_h = K_0 \sigma_v`, with :math:`K_0 = \nu/(1-\nu)` for an elastic layer
that was never strained sideways (Mast 2013, §7.4; Jaky's :math:`1 - \sin\varphi`
for a normally consolidated sand). Released unstressed, the same layer first falls
onto its own stiffness and rings; started from that state it stays where it is.

fe-mpm's Hencky laws (:class:`~fe_mpm.MohrCoulomb`, the Drucker–Prager family,
:class:`~fe_mpm.HenckyJ2`) keep the elastic left Cauchy–Green tensor
:math:`b^e` and compute the stress from it alone,
:math:`\tau = K\,\mathrm{tr}\,\varepsilon^e\,I + 2G\,\mathrm{dev}\,\varepsilon^e`
with :math:`\varepsilon^e = \tfrac12 \ln b^e`. A stress at rest is therefore an
elastic strain the points carry while :math:`F = I`, i.e. a plastic
deformation :math:`F^p = (F^e)^{-1}` of the stress-free body:

.. math::

    \varepsilon^e = \frac{\mathrm{tr}\,\tau_0}{9K} I + \frac{\mathrm{dev}\,\tau_0}{2G},
    \qquad b^e = \exp(2\varepsilon^e).

In the u-p forms the pressure is the grid field of
:math:`p = -K(J-1)` with :math:`J = \det F`, so a mean stress at rest also needs
:math:`\det F_0 = J_0 = 1 + \mathrm{tr}\,\sigma_0/(3K)`: the points start with
:math:`F_0 = J_0^{1/g} I` (their volumes stay as given: they are the current ones)
and :math:`\tau_0 = J_0 \sigma_0`.
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fe_mpm import parallel
from fe_mpm.checks import check_range
from fe_mpm.errors import warn
from fe_mpm.materials.spectral import deviator, from_principal, spectral_decomposition
from fe_mpm.materials.zones import MATERIAL, laws_of
from fe_mpm.particles import MaterialPoints


def geostatic_stress(
    points: MaterialPoints,
    surface: float,
    gravity: float,
    K0: float | npt.ArrayLike,
    density: float | None = None,
    layers: Sequence[tuple[float, float]] | None = None,
    comm: MPI.Comm | None = None,
) -> np.ndarray:
    r"""The stress at rest of level ground: σ_v = −g ∫ ρ dz over the depth above, σ_h = K₀ σ_v.

    The vertical is the last coordinate (y in 2D, z in 3D); the other two
    directions, the out-of-plane one of plane strain included, carry
    :math:`K_0 \sigma_v`. Without ``layers`` each point takes its own density
    :math:`m_p/V_p` (or ``density``) for the whole depth above it, which is exact for
    ground of one density; points of different densities get a warning. With
    ``layers`` σ_v sums the layers above each point, σ_v = −g Σ ρ_i t_i.

    Args:
        points: The points (positions in m, masses in kg, volumes in m³ or m²).
        surface: Height of the ground's free surface (m), one number: level ground; no
            point may lie above it. A body whose top lies well below it somewhere (a
            slope's toe) is warned about: its face starts out of balance.
        gravity: Magnitude g > 0 of gravity (m/s²), acting along −z (−y in 2D).
        K0: Ratio K₀ ≥ 0 of horizontal to vertical stress at rest: one, or each
            point's (n,) (a layer's own, e.g. by ``points.material``).
        density: The ground's density ρ (kg/m³), > 0. None takes each point's own,
            which points seeded without a density do not have yet: the law's is
            given to them when the Simulation starts, after this is called (until
            2026-12-06 such points gave a stress of ρ = 1 kg/m³ without a word, and
            the layer sank as if unstressed; found by a helper typing the docs'
            example with the density on the law).
        layers: Layered ground, ``[(thickness, density), ...]`` from the surface down
            (m, kg/m³, each > 0); every point must lie within them. Not with
            ``density``.
        comm: The communicator over which the points are spread (the grid's,
            ``mesh.comm``), for the warning below; then every rank of it calls this
            function. None (the default) communicates nothing and warns only in a
            serial run (under ``mpiexec`` one rank's points cannot tell where the top is).

    Returns:
        Cauchy stresses (Pa), shape ``(n, 3, 3)``, compression negative.

    It warns where the surface lies more than a point spacing above the highest point
    (of every rank's, with ``comm``).

    Raises:
        ValueError: ``gravity`` ≤ 0, ``K0`` < 0 or not one per point, ``surface`` not
            finite, a point above it or below the layers, ``density`` or a layer's
            thickness or density ≤ 0, both ``density`` and ``layers``, or no density
            to take.
    """
    if np.ndim(gravity) > 0 and np.size(gravity) > 1:
        raise TypeError(
            f"geostatic_stress: gravity is the magnitude g > 0 (m/s²), acting along −y "
            f"(−z in 3D), not the body-force vector; got {gravity!r}"
        )
    if not (np.isfinite(gravity) and gravity > 0.0):
        raise ValueError(f"geostatic_stress: gravity must be > 0 (m/s²), got {gravity!r}")
    K0 = np.asarray(K0, dtype=float)
    if K0.ndim > 1 or (K0.ndim == 1 and K0.size != len(points)):
        raise ValueError(
            f"geostatic_stress: K0 must be one number or one per point ({len(points)}), "
            f"got shape {K0.shape}"
        )
    bad = ~(np.isfinite(K0) & (K0 >= 0.0))
    if np.any(bad):
        first = float(np.ravel(K0)[np.flatnonzero(np.ravel(bad))[0]])
        raise ValueError(f"geostatic_stress: K0 must be a finite number >= 0, got {first:g}")
    if callable(surface) or np.ndim(surface) != 0:
        given = "a function" if callable(surface) else f"an array of shape {np.shape(surface)}"
        raise TypeError(
            f"geostatic_stress: surface is the one height (m) of level ground, got {given}: "
            "ground whose top is not level (a slope, an embankment) has no stress at rest "
            "of this closed form; ramp its gravity instead (Simulation(..., "
            "body_force_scale=lambda t: min(t, 1.0)), docs/user_scenes.md)"
        )
    if not np.isfinite(surface):
        raise ValueError(f"geostatic_stress: surface must be a finite height (m), got {surface!r}")
    depth = surface - points.x[:, -1]
    _warn_gap_below(points, surface, depth, comm)  # before a rank may raise alone
    if len(depth) and depth.min() < -1e-12 * max(1.0, abs(surface)):
        p = int(np.argmin(depth))
        raise ValueError(
            f"geostatic_stress: point {p} lies {-depth[p]:.3g} m above the surface "
            f"{surface:g} m; surface must be >= every point's height"
        )
    depth = np.maximum(depth, 0.0)
    if layers is not None:
        if density is not None:
            raise ValueError("geostatic_stress: give density or layers, not both")
        overburden = _layered_overburden(depth, layers)  # ∫ ρ dz above, kg/m²
    else:
        overburden = _own_density(points, density) * depth
    vertical = -gravity * overburden
    stress = np.zeros((len(points), 3, 3))
    g = points.gdim
    for axis in range(3):
        stress[:, axis, axis] = vertical if axis == g - 1 else K0 * vertical
    return stress


def _warn_gap_below(
    points: MaterialPoints, surface: float, depth: np.ndarray, comm: MPI.Comm | None
) -> None:
    """Warn where the surface lies more than a point spacing above the highest point.

    The stress then assumes ground above the body that it does not have: unless a load
    stands for it (a surcharge), the top starts far out of balance. A new user's
    ``surface=2.0`` for a layer 1 m deep was taken without a word (2026-12-07).
    Collective over ``comm``; with None, serial runs only.
    """
    if comm is None:
        if MPI.COMM_WORLD.size > 1:
            return
        comm = MPI.COMM_SELF
    gap = parallel.smallest(comm, float(depth.min(initial=np.inf)))
    spacing = parallel.largest(
        comm, float(np.median(points.volume)) ** (1.0 / points.gdim) if len(points) else 0.0
    )
    if np.isfinite(gap) and gap > max(spacing, 1e-12 * max(1.0, abs(surface))):
        warn(
            f"geostatic_stress: the highest point lies {gap:.3g} m below the surface "
            f"{surface:g} m, more than the points' spacing ({spacing:.3g} m): the stress "
            "assumes ground above them that the body does not have, so unless a load "
            "stands for it (a surcharge) the top starts out of balance. Give the height "
            "of the body's own top."
        )
    elif np.isfinite(gap):
        _warn_top_not_level(points, surface, comm)


#: Columns of this many of the largest point spacing across, whose tops
#: :func:`_warn_top_not_level` compares with the surface (warned from twice that
#: below it); at most this many columns (else it is not checked).
TOP_COLUMN_SPACINGS, MOST_TOP_COLUMNS = 2.0, 1_000_000


def _warn_top_not_level(points: MaterialPoints, surface: float, comm: MPI.Comm) -> None:
    """Warn where the body's top lies well below the surface somewhere (collective).

    The highest point of each vertical column of the body is compared with the
    surface: a slope's toe lies far below its crest, and the level-ground stress then
    puts a traction on the slope's face. Found 2026-12-07 by a helper's strength
    reduction (Griffiths and Lane's 2:1 slope, H = 10 m): started at rest with
    ``surface=10``, its face moved 3.6 mm in one step at rest, half the whole
    settlement under gravity, without a word. The columns are as wide as
    :data:`TOP_COLUMN_SPACINGS` of the largest point spacing, so that each holds a
    point of the top row where the cells are coarsest: sized by the median, the strip
    footing's graded grid warned of level ground (a reviewer, 2026-12-07).
    """
    g = points.gdim
    own = points.volume ** (1.0 / g) if len(points) else np.zeros(0)
    spacing = parallel.largest(comm, float(own.max(initial=0.0)))
    across = points.x[:, :-1]
    low = -parallel.largest(comm, -across.min(axis=0, initial=np.inf))
    high = parallel.largest(comm, across.max(axis=0, initial=-np.inf))
    width = TOP_COLUMN_SPACINGS * spacing
    if not (np.all(np.isfinite(low)) and width > 0.0):
        return
    counts = np.maximum(1, np.ceil((np.asarray(high) - low) / width)).astype(np.int64)
    if np.prod(counts) > MOST_TOP_COLUMNS:
        return
    column = np.clip(((across - low) / width).astype(np.int64), 0, counts - 1)
    top = np.full(int(np.prod(counts)), -np.inf)
    np.maximum.at(top, np.ravel_multi_index(column.T, counts), points.x[:, -1])
    top = parallel.largest(comm, top)
    drop = np.where(np.isfinite(top), surface - top, -np.inf)
    worst = int(np.argmax(drop))
    if drop[worst] <= 2.0 * width:
        return
    where = low + (np.array(np.unravel_index(worst, counts)) + 0.5) * width
    at = ", ".join(f"{'xy'[k]} = {where[k]:.3g}" for k in range(g - 1))
    warn(
        f"geostatic_stress: the body's top is not level: near {at} m its highest point "
        f"lies {drop[worst]:.3g} m below the surface {surface:g} m. The stress at rest of "
        "level ground then puts a traction on the body's sloping or stepped face, which "
        "starts out of balance and moves in the first step; ramp such a body's gravity "
        "instead (body_force_scale), or start it from a stress of your own."
    )


def _own_density(points: MaterialPoints, density: float | None) -> np.ndarray | float:
    """``density``, or each point's own m_p/V_p, warned where they differ."""
    if density is not None:
        return check_range("geostatic_stress", "density", density, lo=0.0, lo_open=True)
    if not points.density_given:
        raise ValueError(
            "geostatic_stress: the points were seeded without a density (the law's "
            "reaches them only when the Simulation starts): pass density=ρ (kg/m³), or "
            "seed them with seed(..., density=ρ)"
        )
    rho = points.mass / points.volume
    if len(rho) and np.ptp(rho) > 1e-9 * np.max(rho):
        # Found 2026-12-06 by a helper: 1600 over 2000 kg/m³ put the lower layer's
        # σ_v up to 24 % off, and its first step moved it, without a word.
        warn(
            f"geostatic_stress: the points' densities differ ({np.min(rho):.6g} to "
            f"{np.max(rho):.6g} kg/m³), and each point takes its own for the whole "
            "depth above it, which is right for one density only: for layered ground "
            "pass layers=[(thickness, density), ...] from the surface down"
        )
    return rho


def _layered_overburden(depth: np.ndarray, layers: Sequence[tuple[float, float]]) -> np.ndarray:
    """∫ ρ dz from the surface down to each ``depth`` (n,) through ``layers``, kg/m²."""
    table = np.asarray(layers, dtype=float)
    if table.ndim != 2 or table.shape[1] != 2 or table.shape[0] == 0:
        raise ValueError(
            "geostatic_stress: layers must be [(thickness, density), ...] from the "
            f"surface down, got {layers!r}"
        )
    for k, (thickness, rho) in enumerate(table):
        check_range("geostatic_stress", f"layers[{k}] thickness", thickness, lo=0.0, lo_open=True)
        check_range("geostatic_stress", f"layers[{k}] density", rho, lo=0.0, lo_open=True)
    bottoms = np.cumsum(table[:, 0])
    if len(depth) and depth.max() > bottoms[-1] * (1.0 + 1e-12):
        raise ValueError(
            f"geostatic_stress: a point lies {depth.max():.6g} m below the surface, below "
            f"the layers' {bottoms[-1]:.6g} m; add a layer down to it"
        )
    tops = bottoms - table[:, 0]
    within = np.clip(depth[:, None], tops[None, :], bottoms[None, :]) - tops[None, :]
    return within @ table[:, 1]


def elastic_left_cauchy_green(
    kirchhoff: npt.ArrayLike, bulk_modulus: float | np.ndarray, shear_modulus: float | np.ndarray
) -> np.ndarray:
    """bᵉ = exp(2εᵉ) whose Hencky stress is ``kirchhoff``, shape ``(n, 3, 3)``.

    Args:
        kirchhoff: Symmetric Kirchhoff stresses τ (Pa), shape ``(n, 3, 3)``.
        bulk_modulus: K (Pa), one or each point's (n,).
        shear_modulus: G (Pa), one or each point's (n,).
    """
    tau = np.asarray(kirchhoff, dtype=np.float64)
    mean = np.trace(tau, axis1=1, axis2=2) / 3.0
    K = np.asarray(bulk_modulus, dtype=np.float64)
    G = np.asarray(shear_modulus, dtype=np.float64)[..., None, None]
    strain = (mean / (3.0 * K))[:, None, None] * np.eye(3) + deviator(tau) / (2.0 * G)
    values, vectors = spectral_decomposition(strain)
    return from_principal(np.exp(2.0 * values), vectors)


def start_stressed(
    points: MaterialPoints, law, stress: npt.ArrayLike, pressure_field: bool
) -> None:
    """Give the points the elastic state that carries ``stress`` at rest, in place.

    Sets ``points.history["be"]``, ``points.stress`` and, for a pressure field,
    ``points.F`` (see the module's docstring).

    Args:
        points: The points, still undeformed (``F = I``).
        law: A Hencky law: its history has ``"be"``; it has ``bulk_modulus`` and ``mu``.
        stress: Cauchy stresses (Pa), shape ``(n, 3, 3)``, symmetric; in 2D
            (plane strain) with no in-plane/out-of-plane shear.
        pressure_field: Whether the formulation has the pressure as a grid field (u-p).

    Raises:
        ValueError: The law keeps no ``be``, the points are deformed, or the
            stress has the wrong shape, is not finite, or is not symmetric.
    """
    n, g = len(points), points.gdim
    sigma = np.asarray(stress, dtype=np.float64)
    if sigma.shape != (n, 3, 3):
        raise ValueError(
            f"Simulation: initial_stress must have shape ({n}, 3, 3) for this rank's "
            f"{n} points, got {sigma.shape}"
        )
    bad = ~np.isfinite(sigma).all(axis=(1, 2))
    bad |= np.abs(sigma - sigma.transpose(0, 2, 1)).max(axis=(1, 2), initial=0.0) > 1e-12 * (
        1.0 + np.abs(sigma).max(axis=(1, 2), initial=0.0)
    )
    if g == 2:
        bad |= np.abs(sigma[:, :2, 2]).max(axis=1, initial=0.0) > 0.0
    if bad.any():
        p = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"Simulation: initial_stress of point {p} must be finite and symmetric"
            + (" with no shear between the plane and its normal (plane strain)" if g == 2 else "")
            + f", got {sigma[p].tolist()}"
        )
    if not np.allclose(points.F, np.eye(g), rtol=0.0, atol=1e-14):
        raise ValueError(
            "Simulation: initial_stress needs undeformed points (F = I); these carry "
            "a deformation already"
        )
    for one in laws_of(law):  # several laws: each must keep be
        kept = getattr(one, "history", {}).get("be")
        if kept is None or kept.shape != (3, 3):
            raise ValueError(
                "Simulation: initial_stress needs a law that keeps the elastic left "
                "Cauchy-Green tensor 'be' (MohrCoulomb, the Drucker-Prager family, "
                f"HenckyJ2); {type(one).__name__} does not"
            )
    if hasattr(law, "point_bulk_moduli"):  # several laws: each point's own moduli
        labels = {MATERIAL: points.material}
        K, G = law.point_bulk_moduli(labels), law.point_shear_moduli(labels)
    else:
        K, G = np.full(n, float(law.bulk_modulus)), np.full(n, float(law.mu))
    J0 = 1.0 + np.trace(sigma, axis1=1, axis2=2) / (3.0 * K) if pressure_field else np.ones(n)
    if J0.min(initial=1.0) <= 0.0:
        p = int(np.argmin(J0))
        raise ValueError(
            f"Simulation: initial_stress compresses point {p} past J = 0 at its law's "
            f"bulk modulus {K[p]:g} Pa"
        )
    points.history["be"] = elastic_left_cauchy_green(J0[:, None, None] * sigma, K, G)
    points.stress[:] = sigma
    if pressure_field:
        points.F[:] = J0[:, None, None] ** (1.0 / g) * np.eye(g)
