"""What the J2 return map costs: assembly time per Newton iteration, J2 against Neo-Hookean.

The J2 return map is UFL inside the residual and Jacobian kernels, so its cost
shows up in assembly, not as a separate phase. This times the tension-test scene
(one step into the plastic range) with J2 and with a Neo-Hookean law of the same
E and ν, and prints medians of ``--repeat`` runs after JIT.

Usage: ``./run python benchmarks/return_map_cost.py [--h 0.0005] [--repeat 5]``. Not a test.
"""

import argparse
import statistics

import numpy as np

import fe_mpm
from fe_mpm import meshes


def one_step(material, formulation: str, h: float) -> dict:
    """Assembly and whole-step seconds of one step to 3x the yield displacement."""
    scene = meshes.tension_specimen(0.01, 0.02, h)
    points = fe_mpm.seed(scene.mesh, per_cell=3)
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        material,
        formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.TENSION_BOTTOM),
            fe_mpm.Dirichlet(meshes.TENSION_TOP, value=lambda t: np.array([0.0, 6e-5 * t])),
        ],
    )
    report = sim.step(1.0)
    sim.close()
    tm = sim.timings
    calls = report.newton_iterations + 1
    return {
        "assembly per iteration": tm["assembly"] / calls,
        "newton": tm["newton"],
        "iterations": report.newton_iterations,
        "points": len(points),
    }


def main() -> None:
    """Print the table."""
    p = argparse.ArgumentParser()
    p.add_argument("--h", type=float, default=0.0005)
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    laws = {
        "Neo-Hookean": fe_mpm.NeoHookean(200e9, 0.3),
        "J2": fe_mpm.J2Plasticity(200e9, 0.3, 250e6),
    }
    for formulation in ("u", "up"):
        rows = {}
        for name, law in laws.items():
            one_step(law, formulation, args.h)  # JIT
            runs = [one_step(law, formulation, args.h) for _ in range(args.repeat)]
            rows[name] = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        nh, j2 = rows["Neo-Hookean"], rows["J2"]
        extra = j2["assembly per iteration"] - nh["assembly per iteration"]
        share = extra * (j2["iterations"] + 1) / j2["newton"]
        print(
            f"{formulation:>3}: {j2['points']:.0f} points; assembly per iteration "
            f"Neo-Hookean {nh['assembly per iteration'] * 1e3:.2f} ms, J2 "
            f"{j2['assembly per iteration'] * 1e3:.2f} ms; J2 step {j2['newton']:.3f} s in "
            f"{j2['iterations']:.0f} iterations; return map ≈ {share:.0%} of the step"
        )


if __name__ == "__main__":
    main()
