"""Published reference values used by the demos and asserted by the tests.

Cook's membrane, vertical displacement of point A = (48, 60) (m), structured
n x n meshes cut lower-left to upper-right, one material point per triangle,
one static load step. Source: Kratos MPM 10.4.4 runs (``HyperElasticNeoHookean
PlaneStrain2DLaw`` for U, the UP law with PPP for UP+PPP) and Iaconeta (2019)
Table 5.1, as collected in shared/notes/cook_membrane_anchor.md.

Granular column collapse: the empirical laws of Lube et al. (2005), as Iaconeta
(2019) quotes them in Eqs. 6.1–6.3 and Table 6.5.
"""

import math

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

#: Iaconeta (2019) Table 5.1, mixed UP without stabilisation: {nu: {n: u_A_y}}. The
#: quasi-incompressible column is listed under 0.499 as in the table; like the thesis's
#: U column it does not match ν = 0.499 exactly (it lies closer to ν ≈ 0.4999).
COOK_THESIS_UP_NOSTAB = {
    0.33: {2: 0.1013, 4: 0.1718, 8: 0.2511, 16: 0.2952, 32: 0.3119, 64: 0.3176},
    0.499: {2: 0.0788, 4: 0.1157, 8: 0.1821, 16: 0.2356, 32: 0.2606, 64: 0.2702},
}

#: Small-strain Taylor-Hood FEM on n = 128 and its extrapolated limit, ν = 0.499
#: (shared/notes/benchmark_refs.md): 0.2775 at n = 128, ~0.278 in the limit.
COOK_FINE_FEM_0499 = 0.2775


#: Finite-strain limit of u_A,y for the Neo-Hookean Cook problem: the mean of two
#: extrapolations (geometric Richardson, last three structured grids) of fe-mpm runs,
#: UP+PPP with one point per triangle (n = 32, 64, 128) and P2/P1 with three (n = 8, 16,
#: 32; Taylor–Hood FEM with a degree-2 rule). They give 0.32140 and 0.32144 at ν = 0.33,
#: 0.27635 and 0.27623 at ν = 0.499, so errors below about 2e-4 are not resolved
#: (benchmarks/cook_pareto.py prints both).
COOK_FINITE_STRAIN_LIMIT = {0.33: 0.32142, 0.499: 0.27629}


def cook_reference(formulation: str, nu: float, n: int) -> tuple[str, float] | None:
    """The published value for this Cook case, as (source, u_A_y), or None."""
    tables = {
        "u": ("Kratos MPM U", COOK_KRATOS_U),
        "up": ("Kratos MPM UP+PPP", COOK_KRATOS_UP_PPP),
        "up-nostab": ("thesis UP no stab", COOK_THESIS_UP_NOSTAB),
    }
    if formulation not in tables:
        return None
    source, table = tables[formulation]
    value = table.get(nu, {}).get(n)
    return None if value is None else (source, value)


def lube_runout(d_i: float, aspect: float) -> float:
    """Empirical run-out d∞ (m) of Lube et al. (2005), thesis Eqs. 6.1–6.2.

    ``d_i (1 + 1.6 a)`` below a = 1.8, else ``d_i (1 + 2.2 a^{2/3})``. The laws
    hold below 1.8 and above 2.8; in the transition between them this returns the
    second.
    """
    return d_i * (1 + 1.6 * aspect if aspect < 1.8 else 1 + 2.2 * aspect ** (2 / 3))


def lube_height(d_i: float, aspect: float) -> float:
    """Empirical final height h∞ (m) at the wall: ``a d_i`` up to a = 1.15, else ``d_i a^{2/5}``.

    The thesis prints the exponent 2/3 in Eq. 6.3, but its Table 6.5 (and Lube
    et al.) follow 2/5.
    """
    return aspect * d_i if aspect <= 1.15 else d_i * aspect**0.4


def lube_time(d_i: float, aspect: float, g: float = 9.81) -> float:
    """Empirical duration t∞ = 3.3 √(h_i / g) (s) of the collapse, h_i = a d_i."""
    return 3.3 * math.sqrt(aspect * d_i / g)
