"""What a constitutive law sees at the material points in one step."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import ufl

from fe_mpm.materials.spectral import embedded_3d

#: The values of :attr:`HistoryField.convected`.
CONVECTIONS = ("", "left", "left isochoric")


@dataclass(frozen=True)
class HistoryField:
    """One internal variable carried by every material point.

    Attributes:
        shape: Value shape per point, e.g. ``()`` or ``(3, 3)``.
        initial: Value of a virgin point (broadcast to ``shape``).
        description: What it is, with units; it names the output field too.
        convected: How an elastic step carries it: ``""`` not at all (a scalar, a
            back stress), ``"left"`` as a left Cauchy–Green tensor, b ↦ ΔF b ΔFᵀ
            (3 x 3, ΔF embedded), ``"left isochoric"`` as its isochoric part,
            b̄ ↦ ΔF̄ b̄ ΔF̄ᵀ with ΔF̄ = det(ΔF)^(−1/3) ΔF. A point whose pieces took
            other increments than its own (:mod:`fe_mpm.domains`) carries its own
            value forward by its own increment where every piece stepped
            elastically, and takes the pieces' mean where one yielded
            (:func:`fe_mpm.domains.convected_mean`).
    """

    shape: tuple[int, ...]
    initial: float | np.ndarray
    description: str = ""
    convected: str = ""

    def __post_init__(self) -> None:
        if self.convected not in CONVECTIONS:
            raise ValueError(
                f"HistoryField: convected must be one of {sorted(CONVECTIONS)}, "
                f"got {self.convected!r}"
            )
        if self.convected and tuple(self.shape) != (3, 3):
            raise ValueError(f"HistoryField: a convected field is 3 x 3, got shape {self.shape}")

    def initial_values(self, n: int) -> np.ndarray:
        """Initial values for ``n`` points, shape ``(n, *shape)``."""
        return np.broadcast_to(np.asarray(self.initial, dtype=np.float64), (n, *self.shape)).copy()

    def counterpart_in(self, carried: dict) -> str | None:
        """The name of the other convected elastic tensor among ``carried``, or None.

        fe-mpm's laws name theirs :data:`ELASTIC_TENSORS`: ``be`` (bᵉ) and
        ``be_bar`` (b̄ᵉ); a convected field of this one's kind has the other.
        """
        if not self.convected:
            return None
        other = next((n for c, n in ELASTIC_TENSORS.items() if c != self.convected), None)
        return other if other in carried else None

    def elastic_values(self, F: np.ndarray, carried: dict | None = None) -> np.ndarray:
        """Values for points deformed by ``F`` (n, g, g) that lack this field.

        A convected elastic tensor is converted from the other one the points carry
        (:meth:`counterpart_in`): ``b̄ᵉ = det(bᵉ)^(−1/3) bᵉ``, or ``bᵉ = J^(2/3) b̄ᵉ``
        with J = det F (plastic flow keeps the volume); without one it is the
        deformation taken as elastic, ``bᵉ = F Fᵀ`` (``"left"``) or
        ``b̄ᵉ = J^(−2/3) F Fᵀ`` (``"left isochoric"``), embedded in 3D as plane
        strain. The other fields take their initial values. At F = I and without a
        counterpart this is :meth:`initial_values`, to the bit.
        """
        if not self.convected:
            return self.initial_values(F.shape[0])
        F3 = embedded_3d(F)
        J = np.linalg.det(F3)[:, None, None]
        other = self.counterpart_in(carried or {})
        if other is not None:
            b = np.array(carried[other], dtype=np.float64)
            if self.convected == "left isochoric":  # from bᵉ
                return b * np.linalg.det(b)[:, None, None] ** (-1.0 / 3.0)
            return b * J ** (2.0 / 3.0)  # from b̄ᵉ
        b = F3 @ np.swapaxes(F3, 1, 2)
        if self.convected == "left isochoric":
            b *= J ** (-2.0 / 3.0)
        return b


#: The history names of fe-mpm's convected elastic tensors, by their convection.
ELASTIC_TENSORS = {"left": "be", "left isochoric": "be_bar"}


@dataclass
class PointState:
    """The state of the points in a step, as UFL expressions at the points.

    Attributes:
        dF: Deformation gradient increment ΔF of the step (g x g), so that
            ``F = ΔF F_n``.
        history: The material's internal variables at t_n, one slot field per
            :class:`HistoryField` of the material, by name.
        linearisation: For laws whose return map runs in numpy (``return_map``),
            the slot fields of its linearisation at the current Newton iterate
            (:class:`~fe_mpm.materials.linearised.Linearisation`, or
            :class:`~fe_mpm.materials.linearised.MixedLinearisation` for a
            pressure-dependent law in the u-p forms); else None.
        mean_stress: In the u-p forms, the Kirchhoff mean stress −J p of the pressure
            field at the points (Pa); else None.
        step_length: The step's length Δt (s), a constant, for rate-dependent laws
            (:class:`~fe_mpm.materials.fluid.NewtonianFluid`); None where there is
            no step (a material driver at rest).
    """

    dF: ufl.core.expr.Expr
    history: dict[str, ufl.Coefficient] = field(default_factory=dict)
    linearisation: object | None = None
    mean_stress: ufl.core.expr.Expr | None = None
    step_length: ufl.core.expr.Expr | None = None
