"""The boundary points of every PointDirichlet and PointTraction, all together."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fe_mpm.boundary import PointDirichlet, PointTraction
from fe_mpm.checks import check_range


class BoundaryPoints:
    """Positions, weights, penalties and tractions of every boundary point, concatenated.

    Args:
        conditions: The point conditions (prescribed displacements and tractions).
        gdim: Geometric dimension g.

    Attributes:
        x: Current positions (N, g), m, convected with the grid solution.
        x0: Initial positions (N, g), m.
        owner: Index of each point's condition (N,).
        weight: Boundary measure of each point (N,).
        stiffness: β on the constrained components, 0 on the free ones and on
            traction points (N, g), Pa/m.
        loaded: Whether each point carries a traction (N,), bool; the others are
            penalty points.
    """

    def __init__(self, conditions: Sequence[PointDirichlet | PointTraction], gdim: int):
        self.conditions = list(conditions)
        xs, weights, owners, stiffness = [], [], [], []
        for i, c in enumerate(self.conditions):
            kind = type(c).__name__
            x = np.asarray(c.x, dtype=np.float64)
            if x.ndim != 2 or x.shape[1] != gdim or x.shape[0] == 0:
                raise ValueError(f"{kind} {c.name!r}: x must have shape (n, {gdim}) with "
                                 f"n ≥ 1, got {x.shape}")
            w = np.broadcast_to(np.asarray(c.weight, dtype=np.float64), (x.shape[0],))
            if not np.all(w > 0) or not np.all(np.isfinite(w)):
                raise ValueError(f"{kind} {c.name!r}: every weight must be > 0")
            if np.asarray(c.at(0.0)).shape != (gdim,):
                raise ValueError(f"{kind} {c.name!r}: value must have {gdim} components")
            xs.append(x)
            weights.append(w)
            owners.append(np.full(x.shape[0], i))
            if isinstance(c, PointTraction):
                stiffness.append(np.zeros((x.shape[0], gdim)))
                continue
            check_range(f"PointDirichlet {c.name!r}", "penalty", c.penalty, lo=0.0, lo_open=True)
            mask = np.zeros(gdim)
            for comp in (range(gdim) if c.components is None else c.components):
                check_range(f"PointDirichlet {c.name!r}", "components", comp, lo=0, hi=gdim - 1)
                mask[int(comp)] = 1.0
            stiffness.append(np.tile(c.penalty * mask, (x.shape[0], 1)))
        self.x0 = np.vstack(xs)
        self.x = self.x0.copy()
        self.weight = np.concatenate(weights)
        self.owner = np.concatenate(owners)
        self.stiffness = np.vstack(stiffness)
        self.loaded = np.array([isinstance(c, PointTraction) for c in self.conditions])[self.owner]

    def __len__(self) -> int:
        return self.x.shape[0]

    def _values(self, t: float) -> np.ndarray:
        """Each point's condition value at time ``t`` (N, g): a displacement or a traction."""
        return np.array([c.at(t) for c in self.conditions])[self.owner]

    def targets(self, t: float) -> np.ndarray:
        """Where the points should be at time ``t`` (N, g).

        ``x₀ + value(t)`` for a prescribed displacement; traction points have no
        target and stay where they are.
        """
        return np.where(self.loaded[:, None], self.x, self.x0 + self._values(t))

    def tractions(self, t: float) -> np.ndarray:
        """Traction at each point at time ``t`` (N, g), Pa; zero on penalty points."""
        return np.where(self.loaded[:, None], self._values(t), 0.0)

    def forces(self, mismatch: np.ndarray, active: np.ndarray, t: float) -> dict[str, np.ndarray]:
        """Force of each condition on the body (g,).

        ``−Σ_b w_b β P_b (x_b − x_b^target)`` for a prescribed displacement,
        ``Σ_b w_b t_b`` for a traction.

        Args:
            mismatch: End-of-step gap of the active points (n_active, g), m.
            active: Boolean mask of the points that took part in the step (N,).
            t: Time at the end of the step.
        """
        per_point = self.weight[active, None] * (
            self.tractions(t)[active] - self.stiffness[active] * mismatch)
        return {c.name: per_point[self.owner[active] == i].sum(axis=0)
                for i, c in enumerate(self.conditions)}
