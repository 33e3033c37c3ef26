"""Constitutive laws of the material points.

A law maps the total deformation gradient ``F`` (``g x g``; plane strain in 2D,
with ``F_33 = 1``) and the point's :class:`PointState` to the Kirchhoff stress
``τ = J σ`` (Pa, same shape as ``F``), in UFL, so that the residual and its
consistent tangent come from one expression (``ufl.derivative``). Laws with
internal variables list them in ``history`` and give their values at t_{n+1}
through ``updated_history``. Every law has:

- ``kirchhoff(F, state)`` (u form) and ``kirchhoff_deviatoric(F, state)`` (u-p
  form, where the pressure is a field);
- ``mu``, ``bulk_modulus`` (Pa) and ``density`` (kg/m³);
- ``history`` (name → :class:`HistoryField`) and ``updated_history(F, state)``.
"""

from fe_mpm.materials.elastic import NeoHookean, embed_3d, in_plane
from fe_mpm.materials.j2 import J2Plasticity
from fe_mpm.materials.state import HistoryField, PointState

__all__ = ["HistoryField", "J2Plasticity", "NeoHookean", "PointState", "embed_3d", "in_plane"]
