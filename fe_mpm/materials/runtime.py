"""A law's parameters as run-time constants of the compiled forms.

A Python float in a UFL expression is written into the generated C code, so a
law with a new Young's modulus is a new form for FFCx: every (E, ν) of a
parameter sweep paid seconds of compilation. :func:`with_runtime_parameters`
gives the forms a view of the law whose numeric parameters are
:class:`dolfinx.fem.Constant` instead; FFCx then compiles one kernel per law
and formulation, and a later run with other numbers finds it in the cache.

The view binds the law's own properties and methods (``mu``, ``kirchhoff``,
``updated_history``, ...) to itself, so the UFL they build reads the
constants. Only the UFL side goes through it: the numpy return maps and the
checks keep the law itself, whose parameters are floats.
"""

from __future__ import annotations

import dataclasses
import inspect
import types

import dolfinx.fem
import numpy as np

from fe_mpm.materials.elastic import is_builtin


class RuntimeParameters:
    """A view of a dataclass law whose float fields are :class:`dolfinx.fem.Constant`.

    Args:
        law: The law (a dataclass; its float fields become constants).
        mesh: The grid the forms are built on.

    Attributes:
        constants: Field name -> constant (value in the field's unit).
    """

    def __init__(self, law, mesh):
        constants = {
            f.name: dolfinx.fem.Constant(mesh, np.float64(getattr(law, f.name)))
            for f in dataclasses.fields(law)
            if isinstance(getattr(law, f.name), float)
        }
        object.__setattr__(self, "_law", law)
        object.__setattr__(self, "constants", constants)

    def __getattr__(self, name: str):
        if name in self.constants:
            return self.constants[name]
        member = inspect.getattr_static(type(self._law), name, None)
        if isinstance(member, property):
            return member.fget(self)
        if inspect.isfunction(member):
            return types.MethodType(member, self)
        return getattr(self._law, name)

    def __setattr__(self, name: str, value) -> None:
        raise AttributeError(
            f"{type(self._law).__name__}: the law's view in the forms is read-only"
        )

    def __repr__(self) -> str:
        return f"RuntimeParameters({self._law!r})"


def with_runtime_parameters(law, mesh):
    """The law as the forms should see it: its float parameters as constants.

    A law that is not a dataclass, or whose class a user wrote (a subclass of one of
    fe-mpm's laws too), is returned as it is, and its numbers are compiled into the
    forms: the view binds the law's methods to itself, so a user's ``super()``
    call in them failed ("super(type, obj): obj must be an instance or subtype of
    type", found 2026-12-07).
    """
    in_forms = getattr(law, "in_forms", None)
    if in_forms is not None:  # several laws (fe_mpm.materials.zones): each its own view
        return in_forms(lambda one: with_runtime_parameters(one, mesh))
    if not dataclasses.is_dataclass(law) or isinstance(law, type) or not is_builtin(law):
        return law
    return RuntimeParameters(law, mesh)
