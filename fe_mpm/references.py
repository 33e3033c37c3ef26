"""Published reference values used by the demos and asserted by the tests.

Cook's membrane, vertical displacement of point A = (48, 60) (m), structured
n x n meshes cut lower-left to upper-right, one material point per triangle,
one static load step. Source: Kratos MPM 10.4.4 runs (``HyperElasticNeoHookean
PlaneStrain2DLaw`` for U, the UP law with PPP for UP+PPP) and Iaconeta (2019)
Table 5.1, as collected in shared/notes/cook_membrane_anchor.md.
"""

#: Kratos MPM 10.4.4, irreducible (U) formulation: {nu: {n: u_A_y}}.
COOK_KRATOS_U = {
    0.33: {2: 0.0890, 4: 0.1416, 8: 0.2184, 16: 0.2787, 32: 0.3060, 64: 0.3158},
    0.499: {2: 0.0724, 4: 0.0746, 8: 0.0782, 16: 0.0887, 32: 0.1170, 64: 0.1699, 128: 0.2254},
}

#: Kratos MPM 10.4.4, mixed UP with PPP stabilisation: {nu: {n: u_A_y}}.
COOK_KRATOS_UP_PPP = {
    0.33: {2: 0.1165, 4: 0.1942, 8: 0.2659, 16: 0.3018, 32: 0.3147, 64: 0.3190},
    0.499: {2: 0.1270, 4: 0.1921, 8: 0.2412, 16: 0.2638, 32: 0.2719, 64: 0.2748, 128: 0.2758},
}

#: Converged reference values quoted by the thesis (compressible, quasi-incompressible).
COOK_CONVERGED = {0.33: 0.323, 0.499: 0.275}


def cook_reference(formulation: str, nu: float, n: int) -> float | None:
    """The Kratos value for this Cook case, or None if there is none."""
    table = COOK_KRATOS_U if formulation == "u" else COOK_KRATOS_UP_PPP
    return table.get(nu, {}).get(n)
