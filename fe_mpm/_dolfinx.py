"""Import DOLFINx the way every install route needs, and check its version.

The PyPI wheel ``dolfinx-solver-real`` must be imported (``import
dolfinx_solver``) before dolfinx, petsc4py or mpi4py so that its bundled PETSc
and MPI libraries are the ones loaded. A conda or Spack install has no such
module, which is fine. Every fe_mpm module imports dolfinx through here.
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
            raise RuntimeError(f"the compiled form has {ufcx.num_constants} constants, "
                               f"its UFL form {len(ordered)}")
        self._constants = {f"c{i}": constants[c]._cpp_object for i, c in enumerate(ordered)}
        self._compiled = compiled
        self._pointer = compiled.module.ffi.cast("uintptr_t",
                                                 compiled.module.ffi.addressof(ufcx))
        self._spaces = [V._cpp_object for V in spaces]
        self._mesh = mesh._cpp_object
        self._create = form_cpp_creator(compiled.dtype)

    def __call__(self, subdomains: dict) -> dolfinx.fem.Form:
        """The form over ``subdomains``: integral type -> [(subdomain id, entities)]."""
        ordered = {kind: sorted(pairs, key=lambda pair: pair[0])
                   for kind, pairs in subdomains.items()}
        form = self._create(self._pointer, self._spaces, self._coefficients, self._constants,
                            ordered, [], self._mesh)
        return dolfinx.fem.Form(form, self._compiled.ufcx_form, self._compiled.code)
