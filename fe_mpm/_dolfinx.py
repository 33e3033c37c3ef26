"""Import DOLFINx the way every install route needs, check its version, and adapt its internals.

The PyPI wheel ``dolfinx-solver-real`` must be imported (``import
dolfinx_solver``) before dolfinx, petsc4py or mpi4py so that its bundled PETSc
and MPI libraries are the ones loaded. A conda or Spack install has no such
module, which is fine. Every fe_mpm module imports dolfinx through here.

fe-mpm packs the coefficients of its material-point kernels itself
(:mod:`fe_mpm.packing`), which needs a few things DOLFINx keeps private: a form's
integrals with their entities, the compiled kernels' coefficient order, and
tabulating an expression with given coefficients. They are all below
(:class:`FormFactory`, :func:`form_integrals`, :func:`original_coefficient_positions`,
:func:`expression_kernel`, :func:`tabulate_expression`), so a DOLFINx upgrade
touches this file alone.
"""

from __future__ import annotations

try:  # the wheel route; absent on conda/Spack installs
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

try:
    import dolfinx
except ImportError as err:  # pragma: no cover - depends on the machine
    raise ImportError(
        "fe-mpm needs DOLFINx 0.11. Install it with `pip install fe-mpm[wheel]` "
        "(PyPI wheel dolfinx-solver-real), or from conda-forge "
        "(`conda install -c conda-forge fenics-dolfinx=0.11`) or Spack."
    ) from err

import numpy as np  # noqa: E402 - after the wheel's libraries are loaded

REQUIRED = (0, 11)


def _major_minor(version: str) -> tuple[int, int]:
    parts = version.split(".")
    return int(parts[0]), int(parts[1])


if _major_minor(dolfinx.__version__) != REQUIRED:  # pragma: no cover
    raise ImportError(
        f"fe-mpm needs DOLFINx 0.11.x but found dolfinx {dolfinx.__version__} at "
        f"{dolfinx.__file__}. Install `fe-mpm[wheel]` or a 0.11 conda/Spack build."
    )


class FormFactory:
    """DOLFINx forms of one compiled form over integration entities that change.

    ``dolfinx.fem.create_form`` walks the UFL form on every call to match its
    coefficients and constants with their data (about 2.5 ms for a step's forms,
    5 % of a short dynamic run that binds three forms per step). The match does not
    change between steps, so it is made once here and each call only passes the new
    entities to the same C++ constructor.

    Args:
        compiled: The form compiled by ``dolfinx.fem.compile_form``.
        spaces: The function spaces of its arguments, in argument order.
        mesh: The mesh it is integrated over.
        coefficients: UFL coefficient -> the ``Function`` with its data.
        constants: UFL constant -> the ``Constant`` with its value.
    """

    def __init__(self, compiled, spaces, mesh, coefficients: dict, constants: dict):
        import ufl
        from dolfinx.fem.forms import form_cpp_creator

        ufcx = compiled.ufcx_form
        original = ufl.algorithms.extract_coefficients(compiled.ufl_form)
        self._coefficients = {
            f"w{i}": coefficients[original[ufcx.original_coefficient_positions[i]]]._cpp_object
            for i in range(ufcx.num_coefficients)
        }
        ordered = ufl.algorithms.analysis.extract_constants(compiled.ufl_form)
        if len(ordered) != ufcx.num_constants:  # pragma: no cover - a DOLFINx change
            raise RuntimeError(
                f"the compiled form has {ufcx.num_constants} constants, its UFL form {len(ordered)}"
            )
        self._constants = {f"c{i}": constants[c]._cpp_object for i, c in enumerate(ordered)}
        self._compiled = compiled
        self._pointer = compiled.module.ffi.cast("uintptr_t", compiled.module.ffi.addressof(ufcx))
        self._spaces = [V._cpp_object for V in spaces]
        self._mesh = mesh._cpp_object
        self._create = form_cpp_creator(compiled.dtype)

    def __call__(self, subdomains: dict) -> dolfinx.fem.Form:
        """The form over ``subdomains``: integral type -> [(subdomain id, entities)]."""
        ordered = {
            kind: sorted(pairs, key=lambda pair: pair[0]) for kind, pairs in subdomains.items()
        }
        form = self._create(
            self._pointer,
            self._spaces,
            self._coefficients,
            self._constants,
            ordered,
            [],
            self._mesh,
        )
        return dolfinx.fem.Form(form, self._compiled.ufcx_form, self._compiled.code)


def form_integrals(
    form: dolfinx.fem.Form,
) -> list[tuple[dolfinx.fem.IntegralType, int, int, np.ndarray]]:
    """Every integral of ``form``: (type, index, subdomain id, its entities).

    The entities are cells (n,) for cell integrals and (cell, local facet) pairs
    (n, 2) for exterior facets, in the order DOLFINx's kernels run over them.
    """
    cpp = form._cpp_object
    integrals = []
    for kind in cpp.integral_types:
        ids = _integral_ids(form.ufcx_form, kind)
        for i in range(cpp.num_integrals(kind, 0)):
            integrals.append((kind, i, ids[i], np.asarray(cpp.domains(kind, i))))
    return integrals


def _integral_ids(ufcx_form, integral_type) -> list[int]:
    """Subdomain ids of a compiled form's integrals of one type, in DOLFINx's order."""
    t = {
        dolfinx.fem.IntegralType.cell: 0,
        dolfinx.fem.IntegralType.exterior_facet: 1,
        dolfinx.fem.IntegralType.interior_facet: 2,
    }[integral_type]
    offsets = ufcx_form.form_integral_offsets
    return [ufcx_form.form_integral_ids[j] for j in range(offsets[t], offsets[t + 1])]


def original_coefficient_positions(ufcx_object) -> list[int]:
    """Where each coefficient of a compiled kernel sits among the UFL object's.

    In the kernel's order; the kernel is a form's or an expression's.
    """
    return [
        ufcx_object.original_coefficient_positions[i] for i in range(ufcx_object.num_coefficients)
    ]


def expression_kernel(expression: dolfinx.fem.Expression):
    """The compiled (UFCx) kernel of a DOLFINx expression."""
    return expression._ufcx_expression


def tabulate_expression(
    expression: dolfinx.fem.Expression,
    coefficients: np.ndarray,
    mesh: dolfinx.mesh.Mesh,
    entities: np.ndarray,
    values: np.ndarray,
) -> None:
    """Evaluate ``expression`` on ``entities`` with the packed ``coefficients``.

    Args:
        expression: The expression.
        coefficients: Its coefficients packed per entity (entities, width).
        mesh: The mesh.
        entities: The cells to evaluate on (n,), repeats allowed.
        values: Filled with the values, (n, points, value shape...).
    """
    cpp = expression._cpp_object
    constants = dolfinx.cpp.fem.pack_constants(cpp)
    dolfinx.cpp.fem.tabulate_expression(
        values, cpp, constants, coefficients, mesh._cpp_object, entities
    )


def matrix_with_pattern_of(forms: list[dolfinx.fem.Form]):
    """A PETSc matrix whose sparsity holds the entries of every bilinear form in ``forms``.

    The forms share their argument spaces (e.g. cell integrals and interior-facet
    integrals of one unknown).
    """
    pattern = dolfinx.fem.create_sparsity_pattern(forms[0])
    for form in forms[1:]:
        dolfinx.fem.build_sparsity_pattern(pattern, form)
    pattern.finalize()
    return dolfinx.cpp.la.petsc.create_matrix(forms[0].mesh.comm, pattern, None)
