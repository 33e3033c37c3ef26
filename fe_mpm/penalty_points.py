"""The boundary points of :class:`~fe_mpm.boundary.PointDirichlet` conditions, all together."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fe_mpm.boundary import PointDirichlet
from fe_mpm.checks import check_range


class PenaltyPoints:
    """Positions, weights and penalties of every boundary point, concatenated.

    Args:
        conditions: The point conditions.
        gdim: Geometric dimension g.

    Attributes:
        x: Current positions (N, g), m, convected with the grid solution.
        x0: Initial positions (N, g), m.
        owner: Index of each point's condition (N,).
        weight: Boundary measure of each point (N,).
        stiffness: β on the constrained components, 0 on the free ones (N, g), Pa/m.
    """

    def __init__(self, conditions: Sequence[PointDirichlet], gdim: int):
        self.conditions = list(conditions)
        xs, weights, owners, stiffness = [], [], [], []
        for i, c in enumerate(self.conditions):
            x = np.asarray(c.x, dtype=np.float64)
            if x.ndim != 2 or x.shape[1] != gdim or x.shape[0] == 0:
                raise ValueError(f"PointDirichlet {c.name!r}: x must have shape (n, {gdim}) with "
                                 f"n ≥ 1, got {x.shape}")
            w = np.broadcast_to(np.asarray(c.weight, dtype=np.float64), (x.shape[0],))
            if not np.all(w > 0) or not np.all(np.isfinite(w)):
                raise ValueError(f"PointDirichlet {c.name!r}: every weight must be > 0")
            check_range(f"PointDirichlet {c.name!r}", "penalty", c.penalty, lo=0.0, lo_open=True)
            if np.asarray(c.at(0.0)).shape != (gdim,):
                raise ValueError(f"PointDirichlet {c.name!r}: value(t) must have {gdim} components")
            mask = np.zeros(gdim)
            for comp in (range(gdim) if c.components is None else c.components):
                check_range(f"PointDirichlet {c.name!r}", "components", comp, lo=0, hi=gdim - 1)
                mask[int(comp)] = 1.0
            xs.append(x)
            weights.append(w)
            owners.append(np.full(x.shape[0], i))
            stiffness.append(np.tile(c.penalty * mask, (x.shape[0], 1)))
        self.x0 = np.vstack(xs)
        self.x = self.x0.copy()
        self.weight = np.concatenate(weights)
        self.owner = np.concatenate(owners)
        self.stiffness = np.vstack(stiffness)

    def __len__(self) -> int:
        return self.x.shape[0]

    def targets(self, t: float) -> np.ndarray:
        """Where the points should be at time ``t``: ``x₀ + value(t)`` (N, g)."""
        shifts = np.array([c.at(t) for c in self.conditions])
        return self.x0 + shifts[self.owner]

    def forces(self, mismatch: np.ndarray, active: np.ndarray) -> dict[str, np.ndarray]:
        """Force of each condition on the body, ``−Σ_b w_b β P_b (x_b − x_b^target)`` (g,).

        Args:
            mismatch: End-of-step gap of the active points (n_active, g), m.
            active: Boolean mask of the points that took part in the step (N,).
        """
        per_point = -(self.weight[active, None] * self.stiffness[active]) * mismatch
        return {c.name: per_point[self.owner[active] == i].sum(axis=0)
                for i, c in enumerate(self.conditions)}
