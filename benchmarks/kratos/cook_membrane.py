"""Cook's membrane with Kratos MPM (KratosMultiphysics 10.4.4), for side-by-side timing.

Runs in Kratos's own venv (``benchmarks/versus_kratos.py --install`` makes it), not in
fe-mpm's, and imports nothing of fe-mpm::

    .kratos-venv/bin/python benchmarks/kratos/cook_membrane.py --n 64 --nu 0.499

Set-up (the same scene as ``fe_mpm.scenes.cook_membrane``; the input files are written
here, Kratos's Cook test was read only to learn the format):
  * trapezoid (0,0)-(48,44)-(48,60)-(0,44), plane strain, thickness 1;
  * background grid = body mesh: n x n quads on the unit square, each split along
    the lower-left -> upper-right diagonal, mapped with x = 48 xi,
    y = 44 xi + eta (44 - 28 xi);
  * one material point per triangle (MATERIAL_POINTS_PER_ELEMENT = 1 -> centroid);
  * left edge grid nodes fixed (conforming Dirichlet), right edge: grid line-load
    conditions with LINE_LOAD = (0, 1/16) -> total force 1;
  * Neo-Hookean, E = 70, nu given, static solver, one load step,
    Eigen sparse LU (LinearSolversApplication.sparse_lu).

Kratos's own printing goes to stdout; the last line is a JSON record with ``u_A_y`` (the
grid node at A), ``newton_iterations`` and ``seconds_in_kratos`` (``MpmAnalysis.Run``).
"""

import argparse
import json
import os
import sys
import tempfile
import time

# single-threaded unless the caller explicitly asks otherwise
os.environ.setdefault("OMP_NUM_THREADS", "1")

LX, Y_BR, Y_TL, Y_TR = 48.0, 44.0, 44.0, 60.0
TRACTION = 1.0 / 16.0


def mapped(xi: float, eta: float) -> tuple[float, float]:
    """The unit square's point (ξ, η) on the trapezoid."""
    x = LX * xi
    y_bottom = Y_BR * xi
    y_top = Y_TL + (Y_TR - Y_TL) * xi
    return x, y_bottom + eta * (y_top - y_bottom)


def build_mesh(n: int):
    """Node coordinates (1-based ids), triangles, left nodes, right nodes and segments, A's id."""

    def nid(i, j):  # i along xi, j along eta
        return j * (n + 1) + i + 1

    coords = {}
    for j in range(n + 1):
        for i in range(n + 1):
            coords[nid(i, j)] = mapped(i / n, j / n)
    tris = []
    for j in range(n):
        for i in range(n):
            ll, lr, ur, ul = nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)
            tris.append((ll, lr, ur))  # counter-clockwise
            tris.append((ll, ur, ul))
    left = [nid(0, j) for j in range(n + 1)]
    right = [nid(n, j) for j in range(n + 1)]
    right_segments = [(right[k], right[k + 1]) for k in range(n)]
    return coords, tris, left, right, right_segments, nid(n, n)


def _nodes_block(coords):
    """The mdpa block of the nodes."""
    lines = ["Begin Nodes"]
    lines += [f"  {k} {x:.16g} {y:.16g} 0.0" for k, (x, y) in coords.items()]
    lines.append("End Nodes\n")
    return lines


def _smp(name, nodes=(), elements=(), conditions=()):
    """An mdpa sub-model part."""
    lines = [f"Begin SubModelPart {name}", "  Begin SubModelPartNodes"]
    lines += [f"    {k}" for k in nodes]
    lines += ["  End SubModelPartNodes", "  Begin SubModelPartElements"]
    lines += [f"    {k}" for k in elements]
    lines += ["  End SubModelPartElements", "  Begin SubModelPartConditions"]
    lines += [f"    {k}" for k in conditions]
    lines += ["  End SubModelPartConditions", "End SubModelPart\n"]
    return lines


def write_inputs(workdir, n, nu, formulation, rtol=1e-4, atol=1e-9, max_it=20):
    """Write the grid and body mdpa, the materials and the project parameters; return both."""
    coords, tris, left, right, segs, node_a = build_mesh(n)
    header = [
        "Begin ModelPartData",
        "End ModelPartData\n",
        "Begin Properties 0",
        "End Properties\n",
    ]

    # --- background grid -------------------------------------------------
    g = list(header) + _nodes_block(coords)
    g.append("Begin Elements Element2D3N")
    g += [f"  {e + 1} 0 {a} {b} {c}" for e, (a, b, c) in enumerate(tris)]
    g.append("End Elements\n")
    g.append("Begin Conditions MPMGridLineLoadCondition2D2N")
    g += [f"  {c + 1} 0 {a} {b}" for c, (a, b) in enumerate(segs)]
    g.append("End Conditions\n")
    g += _smp("Grid", nodes=coords.keys(), elements=range(1, len(tris) + 1))
    g += _smp("Fixed_disp", nodes=left)
    g += _smp("Traction", nodes=right, conditions=range(1, len(segs) + 1))
    with open(os.path.join(workdir, "cook_Grid.mdpa"), "w") as f:
        f.write("\n".join(g))

    # --- body (initial material domain, same triangulation) ---------------
    body_elem = "MPMUpdatedLagrangianUP2D3N" if formulation == "up" else "MPMUpdatedLagrangian2D3N"
    b = list(header) + _nodes_block(coords)
    b.append(f"Begin Elements {body_elem}")
    b += [f"  {e + 1} 0 {p} {q} {r}" for e, (p, q, r) in enumerate(tris)]
    b.append("End Elements\n")
    b += _smp("Membrane", nodes=coords.keys(), elements=range(1, len(tris) + 1))
    with open(os.path.join(workdir, "cook_Body.mdpa"), "w") as f:
        f.write("\n".join(b))

    # --- materials ----------------------------------------------------------
    law = (
        "HyperElasticNeoHookeanPlaneStrainUP2DLaw"
        if formulation == "up"
        else "HyperElasticNeoHookeanPlaneStrain2DLaw"
    )
    materials = {
        "properties": [
            {
                "model_part_name": "Initial_MPM_Material.Membrane",
                "properties_id": 1,
                "Material": {
                    "constitutive_law": {"name": law},
                    "Variables": {
                        "THICKNESS": 1.0,
                        "MATERIAL_POINTS_PER_ELEMENT": 1,
                        "DENSITY": 1.0,
                        "YOUNG_MODULUS": 70.0,
                        "POISSON_RATIO": nu,
                    },
                    "Tables": {},
                },
            }
        ]
    }
    mat_file = os.path.join(workdir, "cook_materials.json")
    with open(mat_file, "w") as f:
        json.dump(materials, f, indent=2)

    # --- project parameters -------------------------------------------------
    params = {
        "problem_data": {
            "problem_name": "cook_membrane",
            "parallel_type": "OpenMP",
            "echo_level": 0,
            "start_time": 0.0,
            "end_time": 1.0,
        },
        "solver_settings": {
            "solver_type": "Static",
            "model_part_name": "MPM_Material",
            "domain_size": 2,
            "echo_level": 1,
            "analysis_type": "non_linear",
            "time_stepping": {"time_step": 1.0},
            "model_import_settings": {
                "input_type": "mdpa",
                "input_filename": os.path.join(workdir, "cook_Body"),
            },
            "grid_model_import_settings": {
                "input_type": "mdpa",
                "input_filename": os.path.join(workdir, "cook_Grid"),
            },
            "material_import_settings": {"materials_filename": mat_file},
            "compute_reactions": True,
            "convergence_criterion": "residual_criterion",
            "displacement_relative_tolerance": 1e-4,
            "displacement_absolute_tolerance": 1e-9,
            "residual_relative_tolerance": rtol,
            "residual_absolute_tolerance": atol,
            "max_iteration": max_it,
            "pressure_dofs": formulation == "up",
            "stabilization": "ppp",
            "linear_solver_settings": {"solver_type": "LinearSolversApplication.sparse_lu"},
        },
        "processes": {
            "constraints_process_list": [
                {
                    "python_module": "assign_vector_variable_process",
                    "kratos_module": "KratosMultiphysics",
                    "process_name": "AssignVectorVariableProcess",
                    "Parameters": {
                        "model_part_name": "Background_Grid.Fixed_disp",
                        "variable_name": "DISPLACEMENT",
                        "constrained": [True, True, True],
                        "value": [0.0, 0.0, 0.0],
                        "interval": [0.0, "End"],
                    },
                }
            ],
            "loads_process_list": [
                {
                    "python_module": "assign_vector_by_direction_to_condition_process",
                    "kratos_module": "KratosMultiphysics",
                    "process_name": "AssignVectorByDirectionToConditionProcess",
                    "Parameters": {
                        "model_part_name": "Background_Grid.Traction",
                        "variable_name": "LINE_LOAD",
                        "modulus": TRACTION,
                        "direction": [0.0, 1.0, 0.0],
                        "interval": [0.0, "End"],
                    },
                }
            ],
            "list_other_processes": [],
        },
        "output_processes": {},
        "analysis_stage": "KratosMultiphysics.MPMApplication.mpm_analysis",
    }
    with open(os.path.join(workdir, "ProjectParameters.json"), "w") as f:
        json.dump(params, f, indent=2)
    return params, node_a


def main() -> None:
    """Write the inputs, run one static step, print the JSON record."""
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--nu", type=float, required=True)
    ap.add_argument("--formulation", choices=["up", "u"], default="up")
    ap.add_argument(
        "--workdir",
        default=None,
        help="folder for the generated files (default: a temporary folder, removed afterwards)",
    )
    ap.add_argument(
        "--rtol",
        type=float,
        default=1e-4,
        help="relative residual tolerance (Kratos Cook test: 1e-4)",
    )
    ap.add_argument(
        "--atol",
        type=float,
        default=1e-9,
        help="absolute residual tolerance (Kratos Cook test: 1e-9)",
    )
    ap.add_argument("--max-it", type=int, default=20)
    ap.add_argument(
        "--mp-info",
        action="store_true",
        help="also report the displacement of the material point nearest to A (untimed)",
    )
    args = ap.parse_args()

    tmp = None
    if args.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="kratos_cook_")
        workdir = tmp.name
    else:
        workdir = os.path.abspath(args.workdir)
        os.makedirs(workdir, exist_ok=True)

    params_dict, node_a = write_inputs(
        workdir, args.n, args.nu, args.formulation, args.rtol, args.atol, args.max_it
    )

    t_import = time.perf_counter()
    import KratosMultiphysics as KM
    import KratosMultiphysics.LinearSolversApplication  # noqa: F401
    import KratosMultiphysics.MPMApplication as KMPM
    from KratosMultiphysics.MPMApplication.mpm_analysis import MpmAnalysis

    t_import = time.perf_counter() - t_import

    record = {}

    class CookAnalysis(MpmAnalysis):
        def FinalizeSolutionStep(self):  # noqa: N802 (Kratos's name)
            # Grid values are those of the converged step here (the MPM solver
            # only resets grid nodal values in the Predict of the next step).
            grid = self.model.GetModelPart("Background_Grid")
            node = grid.GetNode(node_a)
            record["u_A_y"] = node.GetSolutionStepValue(KM.DISPLACEMENT_Y)
            record["u_A_x"] = node.GetSolutionStepValue(KM.DISPLACEMENT_X)
            record["newton_iterations"] = grid.ProcessInfo[KM.NL_ITERATION_NUMBER]
            super().FinalizeSolutionStep()

    model = KM.Model()
    parameters = KM.Parameters(json.dumps(params_dict))
    t0 = time.perf_counter()
    CookAnalysis(model, parameters).Run()
    t_kratos = time.perf_counter() - t0

    # Optional, outside the timed region: displacement of the material point
    # nearest to (the deformed position of) A.
    nearest_mp_u_y = None
    if args.mp_info:
        mp_mp = model.GetModelPart("MPM_Material")
        pi = mp_mp.ProcessInfo
        best = None
        for e in mp_mp.Elements:
            xg = e.CalculateOnIntegrationPoints(KMPM.MP_COORD, pi)[0]
            d = (xg[0] - 48.0 - record["u_A_x"]) ** 2 + (xg[1] - 60.0 - record["u_A_y"]) ** 2
            if best is None or d < best[0]:
                best = (d, e)
        if best is not None:
            nearest_mp_u_y = best[1].CalculateOnIntegrationPoints(KMPM.MP_DISPLACEMENT, pi)[0][1]

    out = {
        "n": args.n,
        "nu": args.nu,
        "formulation": args.formulation,
        "u_A_y": record.get("u_A_y"),
        "newton_iterations": record.get("newton_iterations"),
        "seconds_in_kratos": round(t_kratos, 4),
        "seconds_import": round(t_import, 4),
        "u_A_source": "grid node at (48,60)",
        "converged": (record.get("newton_iterations") or 0) < args.max_it,
        "nearest_mp_u_y": nearest_mp_u_y,
    }
    if tmp is not None:
        tmp.cleanup()
    sys.stdout.flush()
    sys.stderr.flush()
    print(json.dumps(out), flush=True)
    # Skip interpreter tear-down: Kratos prints "Deregistering ..." from its
    # destructors, which would otherwise come after the JSON line.
    os._exit(0)


if __name__ == "__main__":
    main()
