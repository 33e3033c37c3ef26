"""The PETSc options of fe-mpm's solvers: Newton's, and the linear solvers by name.

:class:`~fe_mpm.newton.NewtonSolver` starts from :data:`NEWTON_OPTIONS` and one
entry of :data:`LINEAR_SOLVERS`; ``Simulation(petsc_options=...)`` overrides any
of them. The mass system of the initial acceleration (:mod:`fe_mpm.dynamics`)
takes the same linear solver.
"""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np

from fe_mpm._dolfinx import dolfinx

#: Full Newton (no line search); quadratic convergence is checked, not hoped for.
#: SNES's own tests are replaced by :class:`ForceTest` (see there): ``snes_rtol``
#: is its tolerance relative to the forces in play, ``snes_atol`` an absolute floor
#: (N), and ``snes_max_it`` the iteration limit. ``snes_stol`` is not used: a small
#: update says nothing about the residual when the tangent is singular.
NEWTON_OPTIONS = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-10,
    "snes_atol": 0.0,
    "snes_max_it": 25,
    "snes_divergence_tolerance": "unlimited",
}

#: MUMPS LU. PCREDISTRIBUTE drops the constrained rows (Dirichlet and the pinned
#: dofs of empty cells) before MUMPS sees the matrix, so empty grid costs no
#: factorisation time.
_DIRECT = {
    "ksp_type": "preonly",
    "pc_type": "redistribute",
    "redistribute_ksp_type": "preonly",
    "redistribute_pc_type": "lu",
    "redistribute_pc_factor_mat_solver_type": "mumps",
}

#: Krylov options shared by the iterative set-ups. The tolerance is tight enough
#: that Newton's history matches the direct solver's; ``ksp_rtol = 1e-6`` is about
#: 30 % faster with the same Newton iterations on the scaling benchmark's block.
_KRYLOV = {"ksp_rtol": 1e-12, "ksp_atol": 1e-14, "ksp_max_it": 1000, "ksp_gmres_restart": 200}

#: The linear solvers of ``Simulation(linear_solver=...)``, by name and by whether
#: the unknown is mixed (u, p). ``petsc_options`` still override any entry.
#:
#: - ``"direct"``: MUMPS LU behind PCREDISTRIBUTE (the default).
#: - ``"iterative"``: GMRES with smoothed-aggregation AMG (GAMG) given the rigid
#:   body modes for u; for u-p a Schur-complement field split, GAMG on the
#:   displacement block and Jacobi on PETSc's ``selfp`` Schur approximation.
LINEAR_SOLVERS = {
    ("direct", False): _DIRECT,
    ("direct", True): _DIRECT,
    ("iterative", False): {
        "ksp_type": "gmres",
        **_KRYLOV,
        "pc_type": "gamg",
    },
    ("iterative", True): {
        "ksp_type": "fgmres",
        **_KRYLOV,
        "pc_type": "fieldsplit",
        "pc_fieldsplit_type": "schur",
        "pc_fieldsplit_schur_fact_type": "full",
        "pc_fieldsplit_schur_precondition": "selfp",
        "fieldsplit_u_ksp_type": "preonly",
        "fieldsplit_u_pc_type": "gamg",
        "fieldsplit_p_ksp_type": "preonly",
        "fieldsplit_p_pc_type": "jacobi",
    },
}


def with_petsc_options(prefix: str, options: dict, act, read: set[str] | None = None) -> None:
    """Call ``act()`` with ``options`` under ``prefix`` in PETSc's database, then restore it.

    ``act`` is e.g. ``ksp.setFromOptions``, or a solve: PETSc reads some options only
    when a solve sets its preconditioner up (a field split's inner solvers, MUMPS's
    ICNTL), so solves run under the options too. Putting the database back as it was
    afterwards (each name removed, or given back the value it held before, e.g. from
    the command line) means that no solver ever sees another's options. A key may
    start with ``-``, as on PETSc's command line. The keys that PETSc read while
    ``act()`` ran are added to ``read`` (without their ``-``), if given.
    """
    opts = PETSc.Options()
    # Full names throughout: PETSc's prefixPush applies to setting a value but not to
    # clearing one, so options set under a pushed prefix could not be removed.
    names_of = {key: f"{prefix}{key.lstrip('-')}" for key in options}
    names = {names_of[key]: value for key, value in options.items()}
    before = {name: opts.getString(name) for name in names if opts.hasName(name)}
    try:
        for name, value in names.items():
            opts[name] = value
        act()
    finally:
        if read is not None:
            read.update(key.lstrip("-") for key in options if opts.used(names_of[key]))
        for name in names:
            if name in before:
                opts[name] = before[name]
            else:
                opts.delValue(name)


def rigid_body_modes(V: dolfinx.fem.FunctionSpace, order: np.ndarray) -> PETSc.NullSpace:
    """Translations and rotations of a blocked displacement space, as a PETSc null space.

    Distributed like the matrix: each rank gives the entries of its owned rows.

    Args:
        V: A vector P1/P2 space (block size = geometric dimension 2 or 3).
        order: Which of V's owned dofs each of this rank's entries holds (e.g.
            their order among the owned rows of a mixed unknown).
    """
    g = V.dofmap.index_map_bs
    owned = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:owned, :g]  # one row per owned node
    modes = [np.zeros((owned, g)) for _ in range(3 if g == 2 else 6)]
    for c in range(g):
        modes[c][:, c] = 1.0
    if g == 2:
        modes[2][:, 0], modes[2][:, 1] = -x[:, 1], x[:, 0]
    else:
        for k, (i, j) in enumerate(((0, 1), (1, 2), (2, 0)), start=3):
            modes[k][:, i], modes[k][:, j] = -x[:, j], x[:, i]
    comm = V.mesh.comm
    vectors = []
    for m in modes:
        column = m.reshape(-1)[order]
        v = PETSc.Vec().createWithArray(column.copy(), size=(column.size, PETSc.DECIDE), comm=comm)
        vectors.append(v)
    # GAMG wants them orthonormal over all ranks: Gram-Schmidt with global dot products.
    for i, v in enumerate(vectors):
        for w in vectors[:i]:
            v.axpy(-v.dot(w), w)
        v.scale(1.0 / v.norm())
    return PETSc.NullSpace().create(vectors=vectors, comm=comm)
