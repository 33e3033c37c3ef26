"""Constitutive laws of the material points.

A law maps the total deformation gradient ``F`` (``g x g``; plane strain in 2D,
with ``F_33 = 1``) and the point's :class:`PointState` to the Kirchhoff stress
``τ = J σ`` (Pa, same shape as ``F``), in UFL, so that the residual and its
consistent tangent come from one expression (``ufl.derivative``). Laws with
internal variables list them in ``history`` and give their values at t_{n+1}
through ``updated_history``. :mod:`.protocol` states the contract:
:class:`~.protocol.Law` (``kirchhoff``, ``mu``, ``bulk_modulus``, ``density``,
``history``, ``updated_history``), :class:`~.protocol.MixedLaw` for the u-p
formulations (``kirchhoff_deviatoric``: the pressure is a field), and
:class:`~.protocol.PointwiseLaw` for laws integrated in principal space
(:class:`MohrCoulomb`, :class:`DruckerPrager`, :class:`ModifiedDruckerPrager`,
:class:`MatsuokaNakai`, :class:`SmoothCapDruckerPrager`, :class:`HenckyJ2`), whose
``return_map(dF, history)`` runs at the points (compiled) and whose UFL stress is the
linearisation at the current Newton iterate (:mod:`.linearised`).
"""

from fe_mpm.materials.drucker_prager import (
    DruckerPrager,
    ModifiedDruckerPrager,
    SmoothCapDruckerPrager,
)
from fe_mpm.materials.elastic import NeoHookean, embed_3d, in_plane
from fe_mpm.materials.fluid import NewtonianFluid
from fe_mpm.materials.hencky_j2 import HenckyJ2
from fe_mpm.materials.j2 import J2Plasticity
from fe_mpm.materials.linearised import Linearisation, ReturnMapResult
from fe_mpm.materials.matsuoka_nakai import MatsuokaNakai
from fe_mpm.materials.mohr_coulomb import MohrCoulomb
from fe_mpm.materials.protocol import Law, MixedLaw, PointwiseLaw
from fe_mpm.materials.state import HistoryField, PointState
from fe_mpm.materials.zones import MaterialZones

__all__ = [
    "DruckerPrager",
    "HenckyJ2",
    "HistoryField",
    "J2Plasticity",
    "Law",
    "Linearisation",
    "MaterialZones",
    "MatsuokaNakai",
    "MixedLaw",
    "ModifiedDruckerPrager",
    "MohrCoulomb",
    "NeoHookean",
    "NewtonianFluid",
    "PointState",
    "PointwiseLaw",
    "ReturnMapResult",
    "SmoothCapDruckerPrager",
    "embed_3d",
    "in_plane",
]
