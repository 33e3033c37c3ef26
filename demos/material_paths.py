# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # One material point on Mast's stress paths: simple shear and biaxial compression
#
# Mast (2013, §3.8) checks his sand laws with a mixed-control material driver
# (after Alawaji et al. 1992): a single point, no grid, some strains driven and
# some stresses held. From a hydrostatic start p₀ = −150 kPa (compression
# negative, as in Mast; E = 75 MPa, ν = 0.33):
#
# - **simple shear**: γ₁₂ driven, ε₃₃ = 0, σ₁₁ = σ₂₂ = p₀ held;
# - **biaxial compression**: ε₂₂ driven, σ₁₁ = σ₃₃ = p₀ held.
#
# Mast's dense sand (the modified Drucker–Prager law with Table 3.5's column i)
# softens after a peak and ends at a critical state: no further change of stress
# or volume. This demo illustrates how to:
#
# - drive a law of `fe_mpm.materials` through a path with
#   `fe_mpm.material_driver.mixed_control` (Newton on the free strains, with the
#   law's own consistent tangent),
# - read its history (λ, Mast's plastic measure) and plot the curves Mast plots
#   (Figs. 3.8–3.11), and
# - check each law against what must hold on its path (below).
#
# Laws: `dp-modified` (Mast §3.6.3–3.6.4), `mn-dp` (Matsuoka–Nakai yield with the
# Drucker–Prager potential, §3.7, Mast's recommendation), `mn` (Matsuoka–Nakai's own
# potential, attached at the stress), `dp` (the traditional cone, §3.6.1,
# cohesionless, φ = 30°, ψ = 5°), `dp-cap` (the cone with Mast's smooth cap, §3.6.2,
# φ = 30°, μ = 1 kPa, the flow's slope that of ψ = 5°), `j2` (`HenckyJ2`, Mast §3.5,
# σ_Y = 100 kPa, isotropic hardening k = 1 MPa, kinematic H = 10 MPa). The first
# three share Table 3.5's evolving angles.
#
# Usage: `python demos/material_paths.py --law dp-modified --path shear --json`.

# +
import time

START = time.perf_counter()

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import plotting
from fe_mpm.material_driver import MaterialDriver, mixed_control
from fe_mpm.materials.drucker_prager import MAST_TABLE_3_5, cone_slope

LAWS = ("dp-modified", "mn-dp", "mn", "dp", "dp-cap", "j2")
SANDS = ("dp-modified", "mn-dp", "mn")  # the laws with Mast's evolving angles
E, NU, P0 = 75e6, 0.33, -150e3  # Pa, Mast §3.8
YIELD_STRESS, HARDENING, KINEMATIC = 100e3, 1e6, 10e6  # the J2 law's (Pa)
PHI, PSI = 30.0, 5.0  # the traditional cone's angles (degrees)


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="A material point on Mast's stress paths")
    p.add_argument("--law", choices=LAWS, default="dp-modified", help="constitutive law")
    p.add_argument("--path", choices=("shear", "biaxial"), default="shear", help="stress path")
    p.add_argument(
        "--sand",
        choices=tuple(MAST_TABLE_3_5),
        default="dense",
        help="Mast's Table 3.5 column (dp-modified, mn-dp, mn)",
    )
    p.add_argument(
        "--strain",
        type=float,
        default=None,
        help="final driven strain: γ₁₂ (shear, default 0.8) or the "
        "compressive ε₂₂ (biaxial, default 0.5)",
    )
    p.add_argument("--steps", type=int, default=400, help="driven increments")
    p.add_argument(
        "--output",
        type=Path,
        default=Path("material_paths_output"),
        help="folder for the CSV file and the plot",
    )
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    args = p.parse_args(argv)
    if args.steps < 10:
        p.error(f"--steps must be at least 10, got {args.steps}")
    if args.strain is not None and not 0.0 < args.strain <= 2.0:
        p.error(f"--strain must lie in (0, 2], got {args.strain}")
    return args


args = parse_args()
final_strain = args.strain or (0.8 if args.path == "shear" else 0.5)
if args.law == "dp-modified":
    law = fe_mpm.ModifiedDruckerPrager(E, NU, **MAST_TABLE_3_5[args.sand])
elif args.law in ("mn-dp", "mn"):
    potential = "drucker-prager" if args.law == "mn-dp" else "matsuoka-nakai"
    law = fe_mpm.MatsuokaNakai(E, NU, **MAST_TABLE_3_5[args.sand], potential=potential)
elif args.law == "dp":
    law = fe_mpm.DruckerPrager(E, NU, cohesion=0.0, friction_angle=PHI, dilatancy_angle=PSI)
elif args.law == "dp-cap":
    law = fe_mpm.SmoothCapDruckerPrager(
        E, NU, PHI, deviatoric_strength=1e3, associativity=cone_slope(PSI) / cone_slope(PHI)
    )
else:
    law = fe_mpm.HenckyJ2(E, NU, YIELD_STRESS, hardening=HARDENING, kinematic_hardening=KINEMATIC)


def plastic_measure(history: dict) -> float:
    """Mast's λ = Σ ‖dev Δεᵖ‖; the J2 and cone laws carry α = √(2/3) λ."""
    if "plastic_shear" in history:
        return float(history["plastic_shear"][0])
    return float(history["plastic_strain"][0]) / math.sqrt(2.0 / 3.0)


# -

# ## The hydrostatic start
#
# From the stress-free state, the three normal stresses are brought to p₀ in five
# increments (a hydrostatic path is elastic for every law here).

# +
driver = MaterialDriver(law, n=1, gdim=3)
F = np.eye(3)
diagonal = [(0, 0), (1, 1), (2, 2)]
for fraction in np.linspace(0.0, 1.0, 6)[1:]:
    F, _ = mixed_control(driver, F, diagonal, {ij: fraction * P0 for ij in diagonal})
    driver.step(F[None])
F_start, J_start = F.copy(), np.linalg.det(F)


def elastic_volume_strain() -> float:
    """ε_vᵉ = ½ ln det bᵉ: every law here is Hencky-elastic on bᵉ."""
    return 0.5 * math.log(np.linalg.det(driver.history["be"][0]))


elastic_start = elastic_volume_strain()
# -

# ## The path
#
# Each increment prescribes the driven entry of F and solves for the free ones:
# shear drives F₁₂ = γ F₂₂⁰ and frees F₁₁, F₂₂ (F₃₃ stays: ε₃₃ = 0); biaxial
# drives F₂₂ = F₂₂⁰ exp(−ε) and frees F₁₁, F₃₃. The strains reported are Hencky's,
# from the hydrostatic start: ε_v = ln(J/J₀).

# +
if args.path == "shear":
    free, held, driven = [(0, 0), (1, 1)], {(0, 0): P0, (1, 1): P0}, (0, 1)
else:
    free, held, driven = [(0, 0), (2, 2)], {(0, 0): P0, (2, 2): P0}, (1, 1)
rows = []
try:
    for strain in np.linspace(0.0, final_strain, args.steps + 1)[1:]:
        target = F.copy()
        if args.path == "shear":
            target[0, 1] = strain * F_start[1, 1]
        else:
            target[1, 1] = F_start[1, 1] * math.exp(-strain)
        F, result = mixed_control(driver, target, free, held)
        driver.step(F[None])
        sigma = result["sigma"]
        p = np.trace(sigma) / 3.0
        s = sigma - p * np.eye(3)
        rows.append(
            {
                "strain": strain if args.path == "shear" else -strain,
                "lambda": plastic_measure(driver.history),
                "p": p,
                "q": math.sqrt(1.5) * float(np.linalg.norm(s)),
                "eps_v": math.log(np.linalg.det(F) / J_start),
                "eps_v_plastic": math.log(np.linalg.det(F) / J_start)
                - (elastic_volume_strain() - elastic_start),
                "sigma_12" if args.path == "shear" else "sigma_22": sigma[driven],
                "sigma_33": sigma[2, 2],
                "tau": result["tau"],
            }
        )
except RuntimeError as err:
    sys.exit(f"material_paths.py: {err} at {args.path} strain {strain:.4g}")
curves = {k: np.array([r[k] for r in rows]) for k in rows[0] if k != "tau"}
stress_key = "sigma_12" if args.path == "shear" else "sigma_22"
print(f"Material paths: {args.law} ({type(law).__name__}), {args.path}, {args.steps} increments")
print(
    f"  end: λ = {curves['lambda'][-1]:.4g}, p = {curves['p'][-1] / 1e3:.2f} kPa, "
    f"q = {curves['q'][-1] / 1e3:.2f} kPa, ε_v = {curves['eps_v'][-1]:.4g}, "
    f"{stress_key} = {curves[stress_key][-1] / 1e3:.2f} kPa"
)
# -

# ## Curves
#
# The histories against λ, as in Mast's Figs. 3.8–3.11: the driven stress, p–q,
# the volumetric strain, and σ₃₃.

# +
args.output.mkdir(parents=True, exist_ok=True)
# Another sand than Mast's dense one (whose peak the check asks for) names its files.
sand = f"_{args.sand.replace(' ', '_')}" if args.law in SANDS and args.sand != "dense" else ""
with open(args.output / f"{args.law}{sand}_{args.path}.csv", "w", newline="") as f:
    writer = csv.writer(f)
    writer.writerow(list(curves))
    writer.writerows(zip(*curves.values(), strict=True))
plt = plotting.pyplot()
if plt is not None:
    fig, ax = plt.subplots(2, 2, figsize=(9, 7))
    lam = curves["lambda"]
    ax[0, 0].plot(curves["strain"], curves[stress_key] / 1e3)
    ax[0, 0].set(xlabel="driven strain", ylabel=f"{stress_key} (kPa)")
    ax[0, 1].plot(-curves["p"] / 1e3, curves["q"] / 1e3)
    ax[0, 1].set(xlabel="−p (kPa)", ylabel="q (kPa)")
    ax[1, 0].plot(lam, curves["eps_v"])
    ax[1, 0].set(xlabel="λ", ylabel="ε_v (dilation > 0)")
    ax[1, 1].plot(lam, curves["sigma_33"] / 1e3)
    ax[1, 1].set(xlabel="λ", ylabel="σ₃₃ (kPa)")
    fig.suptitle(f"{args.law}, {args.path} (p₀ = {P0 / 1e3:g} kPa)")
    fig.tight_layout()
    fig.savefig(args.output / f"{args.law}{sand}_{args.path}.png", dpi=120)
# -

# ## Check against what must hold
#
# - `dp-modified`, `mn-dp`, `mn` (Mast §3.8): the driven stress peaks and softens (peak ≥ 1.2 × the
#   end value), and the critical state is reached: by λ = 0.5 the volumetric strain
#   rate dε_v/dλ is below 1e-3 of its peak, and the stress has stopped changing
#   (the last 10 % of the path moves it by less than 1e-3). On the biaxial path the
#   dense sand first contracts (ε_v < 0), then dilates; the contraction ends by
#   ε₂₂ ≈ 0.005, so it takes increments finer than that (200 over the default 0.5
#   show it; with 100 the first increment steps over it, and the check fails).
# - `dp` and `dp-cap`, perfectly plastic: the plastic volume grows as the dilatancy says,
#   dε_vᵖ/dλ = 3ϱ_G (Mast Eq. 3.89), with ε_vᵖ = ln(J/J₀) less the elastic
#   ½ ln det bᵉ (the total rate differs by the elastic part: the held Cauchy stress
#   is a growing Kirchhoff stress τ = Jσ as the sand dilates). On the biaxial path (a
#   triaxial compression, σ₁₁ = σ₃₃) the cohesionless cone, matched to Mohr-Coulomb's
#   compression meridian, stops at σ₂₂/σ₁₁ = (1 + sin φ)/(1 − sin φ).
# - `j2`: the Kirchhoff stress lies on the moved and grown surface,
#   ‖dev τ − β‖ = √(2/3)(σ_Y + k α) with the back stress β, and the flow is
#   isochoric: the volume follows the Hencky pressure alone, K ln J = tr τ/3.

# +
lam, eps_v = curves["lambda"], curves["eps_v"]
d_lambda = np.diff(lam)
flowing = d_lambda > 1e-12
rate = np.diff(eps_v)[flowing] / d_lambda[flowing]
lam_mid = 0.5 * (lam[1:] + lam[:-1])[flowing]
last = slice(int(0.9 * len(rows)), None)
checks: dict[str, tuple[float, float, str]] = {}  # name -> (value, bound, relation)
if args.law in SANDS:
    driven_stress = np.abs(curves[stress_key] - (P0 if args.path == "biaxial" else 0.0))
    at_half = np.abs(rate[lam_mid >= 0.5])
    tail = curves[stress_key][last]
    checks["peak / end of the driven stress"] = (driven_stress.max() / driven_stress[-1], 1.2, ">=")
    checks["|dε_v/dλ| beyond λ = 0.5 / its peak"] = (
        at_half.max() / np.abs(rate).max() if at_half.size else math.inf,
        1e-3,
        "<",
    )
    checks["change of the driven stress over the last 10 %"] = (
        np.ptp(tail) / abs(tail[-1]),
        1e-3,
        "<",
    )
    if args.path == "biaxial":
        checks["least ε_v (contraction)"] = (eps_v.min(), 0.0, "<")
        checks["ε_v at the end (dilation)"] = (eps_v[-1], 0.0, ">")
elif args.law in ("dp", "dp-cap"):
    expected = 3.0 * cone_slope(PSI)
    plastic = curves["eps_v_plastic"]
    plastic_rate = np.diff(plastic)[flowing] / d_lambda[flowing]
    checks["max |dε_vᵖ/dλ − 3ϱ_G| / 3ϱ_G"] = (
        np.abs(plastic_rate - expected).max() / expected,
        1e-6,
        "<",
    )
    if args.path == "biaxial" and args.law == "dp":
        k = (1 + math.sin(math.radians(PHI))) / (1 - math.sin(math.radians(PHI)))
        checks["|σ₂₂/σ₁₁ − k| / k at the end"] = (
            abs(curves["sigma_22"][-1] / P0 - k) / k,
            1e-9,
            "<",
        )
else:
    tau = rows[-1]["tau"]
    history = {k: v[:1] for k, v in driver.history.items()}
    checks["|‖dev τ − β‖ − √(2/3)(σ_Y + kα)| / σ_Y"] = (
        abs(float(law.yield_function(tau[None], history)[0])) / YIELD_STRESS,
        1e-9,
        "<",
    )
    pressure = law.bulk_modulus * math.log(np.linalg.det(F))
    checks["|K ln J − tr τ/3| / σ_Y"] = (
        abs(pressure - np.trace(tau) / 3.0) / YIELD_STRESS,
        1e-9,
        "<",
    )
compare = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal}
passed = all(bool(compare[rel](value, bound)) for value, bound, rel in checks.values())
for name, (value, bound, rel) in checks.items():
    ok = bool(compare[rel](value, bound))
    print(f"  {name}: {value:.3g} {rel} {bound:g}: {'ok' if ok else 'off'}")
wall = time.perf_counter() - START
print(f"  wall time {wall:.1f} s")
print(
    f"check: {args.law} on the {args.path} path, {len(checks)} conditions of Mast §3.8 "
    f"and the law's closed forms: {'PASS' if passed else 'FAIL'}"
)
if args.json:
    print(
        json.dumps(
            {
                "law": args.law,
                "path": args.path,
                "lambda": curves["lambda"].tolist(),
                "p": curves["p"].tolist(),
                "q": curves["q"].tolist(),
                "eps_v": curves["eps_v"].tolist(),
                stress_key: curves[stress_key].tolist(),
                "strain": curves["strain"].tolist(),
                "checks": {k: float(v[0]) for k, v in checks.items()},
                "check_passed": passed,
                "wall_time_s": wall,
            }
        )
    )
if passed is False:
    sys.exit(f"material_paths.py: {args.law} on the {args.path} path failed its check")
# -
