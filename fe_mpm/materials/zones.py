r"""A body of several materials: each point follows the law of its zone.

A layered soil, a clay crust on sand or an elastic footing on a Mohr–Coulomb
ground is one body on one grid, its points following different laws. Give
:class:`~fe_mpm.Simulation` a list of laws and seed each zone's points with the
index of its law (``seed(..., material=k)``, kept by :func:`~fe_mpm.merge`);
the simulation builds a :class:`MaterialZones` from them, which is itself a law:

.. math::  \tau = \sum_k \chi_k \, \tau_k(F, \text{state}_k),
   \qquad \chi_k = 1 \text{ at the points of law } k, \ 0 \text{ elsewhere}.

The label travels with the points as an internal variable, ``"material"``, so it
reaches every quadrature slot, every piece of a point domain, every rank a point
migrates to, the checkpoints and the ParaView output, and it is never updated.
Since a slot's label is its point's, the sum has one non-zero term at every slot
and the consistent tangent is the point's own law's. Laws whose return map runs
in numpy (:class:`~fe_mpm.materials.protocol.PointwiseLaw`) return at their own
points only (:class:`PointwiseZones`).

What the laws share: an internal variable that two laws keep under one name (``be``
of two Mohr–Coulomb soils) is one field; each law updates it at its own points.
Where a single number stands for the body (the ghost penalty's shear modulus, a
rigid wall's default penalty) the zones give the one that errs on the safe side,
and say which (:attr:`MaterialZones.mu`; :func:`~fe_mpm.materials.elastic.young_modulus`
takes the stiffest law's).
PPP scales each cell by its own points' shear moduli (:meth:`point_shear_moduli`).

Not in zones: a fluid (:class:`~fe_mpm.NewtonianFluid` keeps no shape, and its
points take their volume from the pressure after a step), and a name kept by a law
written in UFL and by a pointwise one (the return map's history would overwrite the
UFL law's update).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import ufl

from fe_mpm.materials.linearised import ReturnMapResult
from fe_mpm.materials.protocol import Law, MixedLaw, PointwiseLaw, missing_members
from fe_mpm.materials.state import HistoryField, PointState

#: The internal variable that holds each point's law, an index into the list of laws.
MATERIAL = "material"


def indicator(label: ufl.core.expr.Expr, k: int) -> ufl.core.expr.Expr:
    """χ_k: 1 at the points labelled ``k`` (the ``"material"`` slot field), 0 elsewhere."""
    return ufl.conditional(ufl.lt(abs(label - k), 0.5), 1.0, 0.0)


class MaterialZones:
    """Several laws as one: a point labelled k follows ``laws[k]``.

    Build it with :func:`material_zones`, which picks :class:`PointwiseZones` where
    a law's return map runs in numpy. :class:`~fe_mpm.Simulation` does so for a list
    of laws.

    Args:
        laws: Two or more laws (:class:`~fe_mpm.materials.protocol.Law`).

    Raises:
        TypeError: An entry is not a law.
        ValueError: Fewer than two laws, a fluid among them, two laws keeping one
            internal variable in different shapes, or one named ``"material"``.
    """

    def __init__(self, laws: Sequence):
        laws = tuple(laws)
        _check_laws(laws)
        self.laws = laws
        # The laws whose numbers are floats; the forms' view holds constants in laws.
        self._numeric = laws

    @classmethod
    def _view(cls, laws: tuple, numeric: tuple) -> MaterialZones:
        """The same zones over other views of the laws (the forms' constants), unchecked."""
        zones = object.__new__(cls)
        zones.laws, zones._numeric = laws, numeric
        return zones

    # -- the numbers that stand for the body ------------------------------------
    @property
    def mu(self) -> float:
        """The smallest shear modulus μ of the laws (Pa).

        It scales the ghost penalty, which then ties no cell harder than its softest
        material would (PPP takes each cell's own, :meth:`point_shear_moduli`).
        """
        return min(float(law.mu) for law in self._numeric)

    @property
    def bulk_modulus(self) -> float:
        """The largest bulk modulus K of the laws (Pa)."""
        return max(float(law.bulk_modulus) for law in self._numeric)

    @property
    def density(self) -> None:
        """None: each zone's density is its law's (or its points'), see :meth:`densities`."""
        return None

    @property
    def keeps_shape(self) -> bool:
        """True: no fluid is in a zone."""
        return True

    # -- per point ------------------------------------------------------------------
    def labels(self, history: dict[str, np.ndarray]) -> np.ndarray:
        """Each point's law (n,) from its ``"material"`` internal variable."""
        return np.rint(history[MATERIAL]).astype(np.int64)

    def point_shear_moduli(self, history: dict[str, np.ndarray]) -> np.ndarray:
        """The shear modulus μ (Pa) of each point's law, shape (n,)."""
        mu = np.array([float(law.mu) for law in self._numeric])
        return mu[self.labels(history)]

    def point_bulk_moduli(self, history: dict[str, np.ndarray]) -> np.ndarray:
        """The bulk modulus K (Pa) of each point's law, shape (n,)."""
        K = np.array([float(law.bulk_modulus) for law in self._numeric])
        return K[self.labels(history)]

    def densities(self) -> list[float | None]:
        """Each law's density ρ₀ (kg/m³), None where the points give it."""
        return [law.density for law in self._numeric]

    # -- the law ----------------------------------------------------------------
    @property
    def history(self) -> dict[str, HistoryField]:
        """Every law's internal variables, and ``"material"``, the point's law."""
        fields = {
            MATERIAL: HistoryField(
                (), 0.0, "the point's law: its index in the simulation's list of laws"
            )
        }
        for law in self.laws:
            fields.update(law.history)
        return fields

    def zones(self, state: PointState) -> list[tuple[ufl.core.expr.Expr, object, PointState]]:
        """(χ_k, law k, its state) for every law, χ_k being 1 at its points and 0 elsewhere."""
        if state is None or MATERIAL not in state.history:
            raise ValueError(
                "MaterialZones: the laws need the points' state, whose 'material' "
                "says which law each point follows"
            )
        label = state.history[MATERIAL]
        out = []
        for k, law in enumerate(self.laws):
            chi = indicator(label, k)
            own = {name: state.history[name] for name in law.history}
            sub = PointState(
                state.dF, own, state.linearisation, state.mean_stress, state.step_length
            )
            out.append((chi, law, sub))
        return out

    def kirchhoff(self, F: ufl.core.expr.Expr, state: PointState) -> ufl.core.expr.Expr:
        """Σ_k χ_k τ_k (Pa), shape of ``F``: each point's own law's Kirchhoff stress."""
        return sum(chi * law.kirchhoff(F, sub) for chi, law, sub in self.zones(state))

    def kirchhoff_deviatoric(self, F: ufl.core.expr.Expr, state: PointState):
        """Σ_k χ_k dev τ_k (Pa), shape of ``F``, for the u-p forms."""
        return sum(chi * law.kirchhoff_deviatoric(F, sub) for chi, law, sub in self.zones(state))

    def updated_history(self, F: ufl.core.expr.Expr, state: PointState) -> dict:
        """Each law's update at its points; elsewhere a variable keeps its value."""
        zones = self.zones(state)
        updates = [law.updated_history(F, sub) for _, law, sub in zones]
        out = {}
        # In the history's order, not a set's: the compiled form must not vary from
        # one run (or rank) to the next with Python's hash seed.
        for name in [name for name in self.history if any(name in u for u in updates)]:
            kept = state.history[name]
            out[name] = sum(
                chi * (update[name] if name in update else kept)
                for (chi, _, _), update in zip(zones, updates, strict=True)
            )
        return out

    def check_formulation(self, pressure: bool) -> None:
        """Every law can run in the formulation (the u-p forms need their deviator)."""
        for k, law in enumerate(self.laws):
            if pressure and not isinstance(law, MixedLaw):
                raise ValueError(
                    f"Simulation: material {k} ({type(law).__name__}) has no deviatoric "
                    "response (kirchhoff_deviatoric), which the u-p formulations need"
                )
            check = getattr(law, "check_formulation", None)
            if check is not None:
                check(pressure)

    def in_forms(self, view) -> MaterialZones:
        """The zones over ``view(law)`` of each law (the forms' run-time constants)."""
        return type(self)._view(tuple(view(law) for law in self._numeric), self._numeric)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({list(self.laws)!r})"


class PointwiseZones(MaterialZones):
    """Zones of which some laws return in numpy: each returns at its own points.

    The zones' return map calls each pointwise law on its points and leaves the other
    points' stress and tangent 0 (their χ is 0 in the linearised stress, and their law
    is in UFL). In u-p, where any law returns at the field's pressure, every pointwise
    law does (:meth:`return_at_pressure`).
    """

    @property
    def pressure_dependent(self) -> bool:
        """Whether any law returns at the field's pressure in u-p."""
        return any(getattr(law, "pressure_dependent", False) for law in self._pointwise)

    @property
    def _pointwise(self) -> list:
        return [law for law in self._numeric if isinstance(law, PointwiseLaw)]

    def _returned_names(self) -> list[str]:
        names = {MATERIAL}
        for law in self._pointwise:
            names.update(law.history)
        return sorted(names)

    def _split(self, history: dict[str, np.ndarray]):
        """(rows, law) for each pointwise law with points here."""
        labels = self.labels(history)
        for k, law in enumerate(self._numeric):
            rows = np.flatnonzero(labels == k)
            if rows.size and isinstance(law, PointwiseLaw):
                yield rows, law

    def _at_own_points(self, history: dict[str, np.ndarray], call) -> tuple[dict, np.ndarray, list]:
        """Each pointwise law's return at its own points, and what they share.

        Args:
            history: The internal variables at t_n, by name, ``"material"`` included.
            call: ``call(law, rows, own)`` returns law's result at the points ``rows``
                (k,), ``own`` being their history in that law's variables.

        Returns:
            The updated history (the others' values kept), the return's region of
            each point (0 where none), and the (rows, result) of each law.
        """
        n = len(history[MATERIAL])
        updated = {name: np.array(history[name], copy=True) for name in self._returned_names()}
        region = np.zeros(n, dtype=np.int8)
        parts = []
        for rows, law in self._split(history):
            result = call(law, rows, {name: history[name][rows] for name in law.history})
            for name, value in result.history.items():
                updated[name][rows] = value
            if result.region is not None:
                region[rows] = result.region
            parts.append((rows, result))
        return updated, region, parts

    def return_map(self, dF: np.ndarray, history: dict[str, np.ndarray]) -> ReturnMapResult:
        """Each pointwise law's return at its own points; 0 stress at the others'.

        Args:
            dF: Deformation gradient increments (n, g, g).
            history: The internal variables at t_n, by name, ``"material"`` included.
        """
        n, g = dF.shape[0], dF.shape[1]
        updated, region, parts = self._at_own_points(
            history, lambda law, rows, own: law.return_map(dF[rows], own)
        )
        tau = np.zeros((n, 3, 3))
        for rows, result in parts:
            tau[rows] = result.tau

        def derivative() -> np.ndarray:
            D = np.zeros((n, 3, 3, g, g))
            for rows, result in parts:
                D[rows] = result.tangent
            return D

        return ReturnMapResult(tau, derivative, updated, region)

    def return_at_pressure(self, dF: np.ndarray, mean_stress: np.ndarray, history: dict):
        """Each pointwise law's return at the field's mean stress (n,), at its own points."""
        from fe_mpm.materials.mixed_return import MixedReturnResult

        n, g = dF.shape[0], dF.shape[1]
        updated, region, parts = self._at_own_points(
            history,
            lambda law, rows, own: law.return_at_pressure(dF[rows], mean_stress[rows], own),
        )
        deviator, volumetric = np.zeros((n, 3, 3)), np.zeros(n)
        for rows, result in parts:
            deviator[rows], volumetric[rows] = result.deviator, result.volumetric

        def derivative():
            blocks = (
                np.zeros((n, 3, 3, g, g)),
                np.zeros((n, 3, 3)),
                np.zeros((n, g, g)),
                np.zeros(n),
            )
            for rows, result in parts:
                for block, value in zip(blocks, result.tangent, strict=True):
                    block[rows] = value
            return blocks

        return MixedReturnResult(deviator, volumetric, derivative, updated, region)


def laws_of(material) -> tuple:
    """The laws of ``material``: a :class:`MaterialZones`' own, or the law alone."""
    return tuple(getattr(material, "laws", (material,)))


def point_lame_moduli(material, history: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Lamé's λ = K − ⅔μ and μ (Pa) of each of ``n`` points' law, shape (n, 2).

    ``material`` is one law with ``bulk_modulus`` and ``mu``, or :class:`MaterialZones`
    (each point its own law's, by the ``"material"`` labels in ``history``).
    """
    if isinstance(material, MaterialZones):
        K, mu = material.point_bulk_moduli(history), material.point_shear_moduli(history)
    else:
        K = np.full(n, float(material.bulk_modulus))
        mu = np.full(n, float(material.mu))
    return np.column_stack([K - 2.0 * mu / 3.0, mu])


def material_zones(laws: Sequence) -> MaterialZones:
    """The zones of ``laws``: :class:`PointwiseZones` if any law's return runs in numpy."""
    laws = tuple(laws)  # checked by the zones it builds
    if any(isinstance(law, PointwiseLaw) for law in laws):
        return PointwiseZones(laws)
    return MaterialZones(laws)


def _check_laws(laws: tuple) -> None:
    if len(laws) < 2:
        raise ValueError(f"MaterialZones: give two or more laws, got {len(laws)}")
    for k, law in enumerate(laws):
        missing = missing_members(law, Law)
        if missing:
            raise TypeError(
                f"Simulation: material {k} ({type(law).__name__}) is not a law: it lacks "
                f"{', '.join(missing)} (fe_mpm.materials.protocol.Law says what a law provides)"
            )
        if not getattr(law, "keeps_shape", True):
            raise ValueError(
                f"Simulation: material {k} ({type(law).__name__}) keeps no shape (a "
                "fluid); a fluid cannot share a simulation with other laws yet"
            )
    shapes: dict[str, tuple] = {}
    initial: dict[str, np.ndarray] = {}
    kinds: dict[str, bool] = {}
    for k, law in enumerate(laws):
        pointwise = isinstance(law, PointwiseLaw)
        for name, field in law.history.items():
            if name == MATERIAL:
                raise ValueError(
                    f"Simulation: material {k} ({type(law).__name__}) keeps an internal "
                    f"variable named {MATERIAL!r}, the name that says which law a point follows"
                )
            first = initial.setdefault(name, np.broadcast_to(field.initial, field.shape))
            if shapes.setdefault(name, field.shape) != field.shape:
                raise ValueError(
                    f"Simulation: materials keep {name!r} in different shapes "
                    f"({shapes[name]} and {field.shape}, material {k}); one name is one field"
                )
            if not np.array_equal(first, np.broadcast_to(field.initial, field.shape)):
                raise ValueError(
                    f"Simulation: materials start {name!r} at different values (material "
                    f"{k}); one name is one field, with one starting value"
                )
            if kinds.setdefault(name, pointwise) != pointwise:
                raise ValueError(
                    f"Simulation: {name!r} is kept by a law written in UFL and by one whose "
                    f"return map runs at the points (material {k}); they cannot share it"
                )
