"""What a step reports: :class:`StepReport`, one per accepted step (``Simulation.history``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class StepReport:
    """What one step did.

    Attributes:
        step: Step number, from 1.
        t: Time at the end of the step (s, or pseudo-time in static runs).
        newton_iterations: Newton iterations of the step.
        residual_norms: ‖R‖ at each Newton iterate.
        markers: Position of every marker at ``t``, name -> array (g,).
        nslot: Slots per entity in the step (a cell with k points is ceil(k/nslot) entities).
        occupied_cells: Number of cells holding points.
        dt: Length of the step (s).
        reactions: Force each requested boundary exerts on the body, name -> (g,)
            (N, per unit thickness in 2D).
        held_points: Points integrated in their last step's cell instead of the
            one they are in (nonzero only in a step retried without re-binning).
        converged_reason: Why Newton stopped, e.g. ``"‖R‖ = 2.1e-13 of the force
            scale 1.962e+04"`` (see :class:`fe_mpm.newton.ForceTest`).
        force_scale: The forces in play at the last iterate, S = max(‖f_ext‖,
            ‖f_int‖) (N; N/m in 2D).
        relative_residual: The last ‖R‖ over ``force_scale``.
        lost_load: Share of each grid ``Traction``'s load that acts on nodes with
            no material, so it is lost (``"Traction 0"`` -> share in [0, 1]);
            only tractions that lose some.
    """

    step: int
    t: float
    newton_iterations: int
    residual_norms: list[float]
    markers: dict[str, np.ndarray] = field(default_factory=dict)
    nslot: int = 0
    occupied_cells: int = 0
    dt: float = 0.0
    reactions: dict[str, np.ndarray] = field(default_factory=dict)
    held_points: int = 0
    converged_reason: str = ""
    force_scale: float = 0.0
    relative_residual: float = 0.0
    lost_load: dict[str, float] = field(default_factory=dict)
