"""The demos run as users run them, and keep their command-line contract."""

import math

import meshio
import numpy as np
import pytest
from demo_runner import check_line, run_demo
from demo_runner import last_json as _last_json

from fe_mpm.references import COOK_KRATOS_U

pytestmark = pytest.mark.demo


def test_cook_membrane_json_contract(tmp_path):
    stdout = run_demo(
        "cook_membrane.py",
        "--n",
        "8",
        "--nu",
        "0.499",
        "--json",
        "--output",
        str(tmp_path / "out"),
        cwd=tmp_path,
    )
    summary = _last_json(stdout)
    for key in ("tip_displacement_y", "newton_iterations", "wall_time_s", "n_particles"):
        assert key in summary
    assert summary["n_particles"] == 2 * 8 * 8
    assert abs(summary["tip_displacement_y"] / COOK_KRATOS_U[0.499][8] - 1) < 0.005
    assert 2 <= summary["newton_iterations"] <= 5
    assert summary["check_passed"] and summary["check_error"] < 0.005
    assert check_line(stdout).startswith("check: u_A,y = 0.0781")
    assert "vs Kratos MPM U 0.0782 (n = 8, ν = 0.499)" in stdout


def test_cook_membrane_writes_paraview_series(tmp_path):
    out = tmp_path / "out"
    stdout = run_demo(
        "cook_membrane.py",
        "--n",
        "4",
        "--steps",
        "3",
        "--output",
        str(out),
        "--quiet",
        cwd=tmp_path,
    )
    assert "u_A = " in stdout and "Newton iterations per step: [" in stdout
    assert check_line(stdout).endswith("tolerance: PASS")  # Kratos's n = 4, over 3 steps
    pvd = (out / "particles.pvd").read_text()
    files = [line.split('file="')[1].split('"')[0] for line in pvd.splitlines() if "file=" in line]
    assert len(files) == 4  # t = 0 and three steps
    first = meshio.read(out / files[0])
    assert np.abs(first.point_data["displacement"]).max() == 0.0
    last = meshio.read(out / files[-1])
    assert last.points.shape == (2 * 4 * 4, 3)
    for field in ("displacement", "stress", "pressure", "deformation_gradient", "volume"):
        assert np.all(np.isfinite(last.point_data[field]))
    assert np.abs(last.point_data["displacement"]).max() > 0.05
    assert (out / "grid.bp").is_dir()
    curve = np.loadtxt(out / "load_deflection.csv", delimiter=",", skiprows=1)
    assert curve.shape == (4, 2) and np.all(np.diff(curve[:, 1]) > 0)
    assert (out / "load_deflection.png").stat().st_size > 1000


def test_demos_run_without_matplotlib(tmp_path):
    """Plots are an extra: without matplotlib a demo still writes its CSV files, says
    which plot it left out, and exits 0."""
    shadow = tmp_path / "shadow" / "matplotlib"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text('raise ImportError("no matplotlib here")\n')
    out = tmp_path / "out"
    stdout = run_demo(
        "cook_membrane.py",
        "--n",
        "4",
        "--steps",
        "3",
        "--output",
        str(out),
        cwd=tmp_path,
        env={"PYTHONPATH": str(shadow.parent)},
    )
    assert "matplotlib is not installed, so no plot: pip install 'fe-mpm[plots]'" in stdout
    assert (out / "load_deflection.csv").exists()
    assert not (out / "load_deflection.png").exists()


def test_elastic_column_json_contract(tmp_path):
    static = _last_json(run_demo("elastic_column.py", "--ny", "16", "--json", cwd=tmp_path))
    for key in ("error", "wall_time_s", "steps", "n_particles"):
        assert key in static
    assert abs(static["error"] - 1.035e-2) < 1e-4  # first order in h: 2.07e-2 at ny = 8
    assert static["check_passed"] and static["check_tolerance"] == pytest.approx(0.35 / 16)
    dynamic = _last_json(
        run_demo(
            "elastic_column.py", "--ny", "16", "--dynamic", "--steps", "80", "--json", cwd=tmp_path
        )
    )
    assert dynamic["steps"] == 80 and dynamic["error"] < 0.15
    assert dynamic["check_passed"]
    # Five steps a period, as the usage line once gave: its largest deviation (1.19
    # static tops at ny = 32) is past first order in the step, so only boundedness is
    # checked there (until 2026-12-07 the first-order tolerance, 1.03, failed it).
    coarse = _last_json(
        run_demo(
            "elastic_column.py", "--ny", "16", "--dynamic", "--steps", "10", "--json", cwd=tmp_path
        )
    )
    assert 1.0 < coarse["error"] < coarse["check_tolerance"] == 2.1


def test_sliding_block_json_contract(tmp_path):
    out = _last_json(
        run_demo("sliding_block.py", "--dt", "0.02", "--t-end", "0.4", "--json", cwd=tmp_path)
    )
    for key in ("error", "wall_time_s", "steps", "n_particles"):
        assert key in out
    assert out["steps"] == 20 and out["error"] < 1e-10 and out["check_passed"]


def test_rolling_disk_rolls_on_a_frictional_wall(tmp_path):
    """R = 0.2 m on h = R/10 (the demo's coarse check, 15 %; measured −11.7 %): the disk
    rolls, neither glued to the grid (−100 %) nor sliding (+50 %), and spins at about
    v / R over the second half of the run (measured mean ωR/v = 0.988; at the last
    instant 0.87, as the contact sticks and slips). A disk that slips (μ = 0.2) fails:
    mean 0.723, though it comes within 2.1 % of the rolling distance."""
    out = _last_json(run_demo("rolling_disk.py", "--h", "0.02", "--json", cwd=tmp_path))
    assert out["check_passed"] and abs(out["relative_error"]) <= 0.15
    assert 0.95 < out["spin_ratio_mean"] <= 1.02
    args = ("--h", "0.02", "--friction", "0.2", "--json")
    slipping = _last_json(run_demo("rolling_disk.py", *args, cwd=tmp_path, fails=True))
    assert slipping["spin_ratio_mean"] < 0.8 and abs(slipping["relative_error"]) < 0.05


def test_the_cantilever_near_incompressibility_swings_with_averaging_and_locks_without(
    tmp_path,
):
    """Mast's beam at ν = 0.49 (Table 6.4), one period in 50 steps on h = H/8: with
    node-based volumetric averaging the amplitude and period are within the demo's 5 %
    of beam theory (measured 0.983 and 0.985); the plain displacement form locks, both
    22 % short (0.782, 0.784), and the demo's check fails."""
    args = ("--nu", "0.49", "--steps", "50", "--no-output", "--json")
    averaged = _last_json(
        run_demo("locking_beam.py", "--formulation", "u-nbva", *args, cwd=tmp_path)
    )
    (run,) = averaged["runs"]
    assert averaged["check_passed"]
    assert abs(run["amplitude_ratio"] - 1) <= 0.05 and abs(run["period_ratio"] - 1) <= 0.05
    plain = run_demo("locking_beam.py", "--formulation", "u", *args, cwd=tmp_path, fails=True)
    (run,) = _last_json(plain)["runs"]
    assert run["amplitude_ratio"] < 0.85 and run["period_ratio"] < 0.85


def test_the_taylor_bar_hits_its_wall_with_the_momentum_it_loses(tmp_path):
    """The first 10 µs of the copper rod's impact on a coarse grid (h = 1.6 mm, 20
    steps; 3D, J2, u-p, a frictionless rigid wall). The wall's
    reported push, summed by Newmark's trapezoidal rule, is the momentum the rod lost
    (measured: equal to 1e-14; 15 % of its momentum is gone by then); the demo's
    check is not made before 80 µs and says so."""
    out = _last_json(
        run_demo(
            "taylor_bar.py",
            *("--h", "1.6e-3", "--steps", "20", "--t-end", "10e-6", "--no-output", "--json"),
            cwd=tmp_path,
        )
    )
    rod = 8930.0 * math.pi * 3.2e-3**2 * 32.4e-3 * 227.0  # its momentum at impact (N s)
    assert out["momentum_lost_Ns"] > 0.1 * rod
    assert out["impulse_Ns"] == pytest.approx(out["momentum_lost_Ns"], rel=1e-9)
    assert out["check_passed"] is None and out["steps"] == 20  # null: not checked
    # The contract: L/L₀ and R/R₀ at the end, and their history.
    assert len(out["history"]) == 20 and out["history"][-1][1] == out["final_length_ratio"]
    assert 0.9 < out["final_length_ratio"] < 1.0 < out["final_radius_ratio"]


def test_sliding_block_on_a_frictional_wall_writes_its_forces(tmp_path):
    """μ = 0.1: the slide is g (sin θ − μ cos θ) t²/2 to 2e-3 (the demo's check), and
    the wall's CSV has a row per step whose friction is μ times its push once sliding."""
    out = _last_json(
        run_demo(
            "sliding_block.py",
            "--friction",
            "0.1",
            "--t-end",
            "0.5",
            "--json",
            "--output",
            str(tmp_path / "out"),
            cwd=tmp_path,
        )
    )
    assert out["check_passed"] and out["friction"] == 0.1 and out["steps"] == 50
    rows = np.genfromtxt(tmp_path / "out" / "walls.csv", delimiter=",", names=True, dtype=None)
    assert rows.size == 50
    np.testing.assert_allclose(rows["tangential"][10:], 0.1 * rows["normal"][10:], rtol=1e-9)


def test_tension_test_json_contract_and_plastic_output_and_two_runs_agree(tmp_path):
    """J2, u-p, 10 load steps, run twice: the summary (but for the wall-clock time) and
    every field of the last ParaView frame agree to the last bit (no unordered sets,
    no thread races, no choices that depend on time)."""
    runs, frames = [], []
    for k in range(2):
        out = tmp_path / f"out{k}"
        stdout = run_demo(
            "tension_plate.py",
            "--formulation",
            "up",
            "--steps",
            "10",
            "--json",
            "--output",
            str(out),
            cwd=tmp_path,
        )
        runs.append(_last_json(stdout))
        frames.append(meshio.read(sorted(out.glob("particles_*.vtu"))[-1]).point_data)
    summary = runs[0]
    for key in ("limit_load", "analytical_limit_load", "newton_iterations_max", "wall_time_s"):
        assert key in summary
    assert abs(summary["limit_load"] / summary["analytical_limit_load"] - 1) < 0.01
    assert summary["check_passed"]
    assert frames[0]["plastic_strain"].max() > 0.005
    assert (tmp_path / "out0" / "force_displacement.png").exists()
    for run in runs:
        del run["wall_time_s"]
    assert runs[0] == runs[1]
    assert set(frames[0]) == set(frames[1]) and "stress" in frames[0]
    for name, values in frames[0].items():
        assert np.array_equal(values, frames[1][name]), name


def test_strip_footing_contract_and_u_versus_up_stress(tmp_path):
    """Coarse footing (h = 0.2 near it), 10 steps to s/B = 0.1, u and u-p (Tresca).

    Measured: u locks (q/c_u 8.50 at s/B = 0.1) and its vertical stress under the
    footing scatters from −58 c_u to +41 c_u (tension under a footing that pushes
    down), oscillation 9.6 c_u; u-p gives q/c_u 5.40, σ_yy in [−5.3, −2.0] c_u,
    oscillation 0.30 c_u. The demo's own check against 2 + π (the mean q/c_u over
    0.1 ≤ s/B ≤ 0.15, here the last step alone; from 5 % below to 15 % above)
    passes u-p (+5.0 %) and fails u (+65 %): the u run exits 1.
    """
    common = ("--steps", "10", "--settlement", "0.1", "--h", "0.2", "--h-far", "0.5", "--json")
    runs = {}
    for formulation in ("u", "up"):
        out = tmp_path / formulation
        stdout = run_demo(
            "strip_footing.py",
            "--formulation",
            formulation,
            *common,
            "--output",
            str(out),
            cwd=tmp_path,
            fails=formulation == "u",
        )
        runs[formulation] = _last_json(stdout)
        for key in ("settlement_over_B", "q_over_cu", "wall_time_s", "n_particles"):
            assert key in runs[formulation]
        assert (out / "load_settlement.csv").exists() and (out / "load_settlement.png").exists()
    u, up = runs["u"], runs["up"]
    assert u["q_over_cu"][-1] > 1.3 * up["q_over_cu"][-1]  # u overestimates the capacity
    assert u["sigma_yy_over_cu_range"][1] > 0.0  # u: out-of-range (tensile) σ_yy
    assert up["sigma_yy_over_cu_range"][1] < 0.0  # u-p: compressive everywhere under it
    assert up["stress_oscillation"] < 0.1 * u["stress_oscillation"]
    assert 1.0 < up["q_over_cu"][-1] / (2 + np.pi) < 1.2  # coarse grid: 1.05 measured
    assert up["check_passed"] and not u["check_passed"] and u["check_error"] > 0.15


def _coarse_footing_to_2B(tmp_path, steps: int) -> dict:
    """u-p on the coarse grid (h = 0.2 B) to s/B = 2 in ``steps`` steps: the demo's JSON."""
    return _last_json(
        run_demo(
            "strip_footing.py",
            "--formulation",
            "up",
            "--steps",
            str(steps),
            "--settlement",
            "2.0",
            "--h",
            "0.2",
            "--h-far",
            "0.5",
            "--no-output",
            "--json",
            cwd=tmp_path,
        )
    )


def _window_means(out: dict, centres) -> np.ndarray:
    s, q = np.array(out["settlement_over_B"]), np.array(out["q_over_cu"])
    return np.array([q[(s > c - 0.1) & (s <= c + 0.1)].mean() for c in centres])


@pytest.mark.slow
def test_strip_footing_reaches_2B_with_quadratic_newton(tmp_path):
    """u-p on the coarse grid (h = 0.2 B), 100 steps of 20 mm to s/B = 2.

    Kratos MPM breaks down before the Prandtl plateau on this scene. Here every
    step converges with the last Newton iteration shrinking ‖R‖ at least a
    thousandfold (quadratic convergence, not a linear crawl), and q/c_u keeps
    rising, window by window, with no asymptote (the thesis's "gradually
    increases"). Single steps jitter by ±10 % as points cross cells, so windows
    of 0.2 B are compared.
    """
    out = _coarse_footing_to_2B(tmp_path, 100)
    s = np.array(out["settlement_over_B"])
    assert s[-1] == pytest.approx(2.0)
    for norms in out["residual_norms"]:
        assert norms[-1] < 1e-3 * norms[-2] or norms[-1] < 1e-10 * norms[0]
    windows = _window_means(out, (0.3, 0.8, 1.3, 1.9))
    assert np.all(np.diff(windows) > 0), windows
    assert windows[0] > 2 + np.pi


@pytest.mark.slow
def test_column_collapse_runout_a3(tmp_path):
    """a = 3 on a coarse grid (h = 0.015 m, 3 points per cell, Δt = 2.5 ms, α_R = 1.5).

    The thesis's own results for a = 3 (Tables 6.2–6.4, three grids, damped)
    lie above Lube et al.'s laws by 5.2–12.2 % in run-out, 2.9–6.4 % in height
    and 7.5–16.6 % in duration. Each quantity here must be within the thesis's
    largest error. Measured: −10.2 %, −4.0 %, +9.0 % (at h = 0.01 m the run-out
    error shrinks to −4.9 %). The duration is the time the front comes within one
    cell of d∞ (``t_inf_cell``): within 1 % of d∞ (``t_inf``) the creeping front
    makes it hinge on round-off. Three runs whose E differed by 1e-12 gave
    run-out −10.3, −10.7, −10.3 %, height −3.7 % each, ``t_inf`` +22.2, +9.9,
    +21.7 % and ``t_inf_cell`` −1.1, −4.3, −1.1 %.
    """
    stdout = run_demo(
        "column_collapse.py",
        "--aspect",
        "3",
        "--h",
        "0.015",
        "--points-per-cell",
        "3",
        "--dt",
        "2.5e-3",
        "--damping",
        "1.5",
        "--output",
        str(tmp_path / "out"),
        "--json",
        cwd=tmp_path,
    )
    out = _last_json(stdout)
    for key in ("runout", "final_height", "t_inf", "wall_time_s"):
        assert key in out
    errors = out["relative_errors"]
    assert abs(errors["runout"]) < 0.122
    assert abs(errors["final_height"]) < 0.064
    assert abs(errors["t_inf_cell"]) < 0.166
    assert out["check_passed"]
    assert (tmp_path / "out" / "collapse.png").exists()
    assert (tmp_path / "out" / "front.csv").exists()


def test_frictional_footing_in_up_unlocks_what_u_locks(tmp_path):
    """The c-φ footing (φ = ψ = 20°, E/c = 1000) on h = 0.2 B, 10 steps to s/B = 0.1:
    the plateau over 0.06 ≤ s/B ≤ 0.1 against Prandtl's N_c = 14.835. Measured: u-p
    +16.2 % and u +38.5 % here; on the demo's h = 0.1 B, u-p +7.4 % and u +24.2 %. So u-p
    within 20 % of N_c, and u at least 15 % of N_c above u-p (the locking)."""
    up, u = (
        _last_json(
            run_demo(
                "strip_footing_frictional.py",
                "--h",
                "0.2",
                "--formulation",
                formulation,
                "--json",
                cwd=tmp_path,
            )
        )
        for formulation in ("up", "u")
    )
    assert up["N_c"] == pytest.approx(14.8347, abs=1e-4)
    assert len(up["settlement_over_B"]) == len(up["q_over_c"]) >= 10
    assert abs(up["check_error"]) < 0.20
    assert u["check_error"] - up["check_error"] > 0.15


def test_slope_under_rising_gravity_fails_near_the_slip_circle(tmp_path):
    """The slope of the user-scenes issue on its own gmsh grid (h = 1 m here, 0.5 m in
    the demo), gravity ramped to 1.2 g in 12 steps. Every accepted step is in
    equilibrium (‖R‖ ≤ 1e-10 S; base reaction = weight to 1e-8) and the knee of the
    crest's movement lies within 25 % of the slip circle's 0.83 g. Measured: the
    knee at 1.00 g (0.90 g with h = 0.5); the crest's rate over its elastic rate is
    2.15 at 0.9 g and 3.86 at 1.0 g, far from the threshold of 3, so the knee does not
    hinge on round-off."""
    out = _last_json(run_demo("slope_gravity.py", "--h", "1.0", "--json", cwd=tmp_path))
    assert out["steps"] == 12 and abs(out["reached"] - 1.2) < 1e-12
    assert out["worst_relative_residual"] <= 1e-10
    assert out["reaction_balance"] < 1e-8
    assert abs(out["knee"] / out["bishop"] - 1.0) < 0.25
    assert out["check_passed"]


def test_slope_in_up_fails_nearer_the_slip_circle_than_u(tmp_path):
    """The slope with `--formulation up`: Mohr-Coulomb (φ = 20°, ψ = 0) returns at the
    pressure field's mean stress. Equilibrium as above, and the knee within 10 % of the
    slip circle's 0.83 g, which the locking u form misses on this grid (1.00 g,
    +20 %, the test above). Measured: the knee at 0.90 g on h = 1 m (crest rate over
    its elastic rate 2.29 at 0.8 g, 5.43 at 0.9 g) and at 0.85 g on h = 0.5 m (u: 0.90
    g), where u-p stops at 0.96 g, past the knee, on the imbalance re-binning leaves.
    The ramp stops at 1.0 g, past the knee (9 s; to the demo's 1.2 g, 35 s: Newton
    cuts steps beyond 1.0 g, 25 accepted for 12 asked), so the test, not the demo,
    checks the knee."""
    out = _last_json(
        run_demo(
            "slope_gravity.py",
            *("--h", "1.0", "--formulation", "up", "--g-max", "1.0", "--steps", "10"),
            "--json",
            cwd=tmp_path,
        )
    )
    assert out["formulation"] == "up"
    assert abs(out["reached"] - 1.0) < 1e-12
    # No step was cut up to 1.0 g, past the knee.
    assert all(abs(f - 0.1 * (i + 1)) < 1e-9 for i, f in enumerate(out["load_factor"]))
    assert len(out["load_factor"]) == 10
    assert out["worst_relative_residual"] <= 1e-10
    assert out["reaction_balance"] < 1e-8
    assert abs(out["knee"] / out["bishop"] - 1.0) < 0.1
    assert out["check_passed"]


def test_slope_with_the_plane_strain_drucker_prager_cone_fails_near_the_slip_circle(tmp_path):
    """The same slope with `--law drucker-prager` (the cone through Mohr-Coulomb's
    plane-strain limit): measured, the knee at 0.90 g on h = 1 m and on h = 0.5 m
    (Mohr-Coulomb: 1.00 g and 0.90 g); the default outer cone does not fail by 1.2 g."""
    out = _last_json(
        run_demo(
            "slope_gravity.py", "--h", "1.0", "--law", "drucker-prager", "--json", cwd=tmp_path
        )
    )
    assert out["steps"] == 12 and out["worst_relative_residual"] <= 1e-10
    assert abs(out["knee"] / out["bishop"] - 1.0) < 0.25
    assert out["check_passed"]


@pytest.mark.parametrize("law, path", [("dp-modified", "shear"), ("mn-dp", "biaxial")])
def test_material_paths_json_contract_and_masts_critical_state(tmp_path, law, path):
    """Mast §3.8: the dense sand peaks, softens and reaches a critical state (and on
    the biaxial path contracts, then dilates); the JSON carries the curves as
    equal-length lists; the plot is written. (The laws' closed forms on these paths
    are in tests/test_drucker_prager.py and tests/test_matsuoka_nakai.py.)"""
    out = tmp_path / "out"
    stdout = run_demo(
        "material_paths.py",
        "--law",
        law,
        "--path",
        path,
        "--steps",
        "200",
        "--output",
        str(out),
        "--json",
        cwd=tmp_path,
    )
    summary = _last_json(stdout)
    stress = "sigma_12" if path == "shear" else "sigma_22"
    lengths = {len(summary[k]) for k in ("lambda", "p", "q", "eps_v", stress, "strain")}
    assert lengths == {200}
    assert summary["check_passed"] and summary["lambda"][-1] > 0.5
    assert np.all(np.diff(summary["lambda"]) >= 0.0)
    assert (out / f"{law}_{path}.png").stat().st_size > 1000
    assert summary["checks"]["peak / end of the driven stress"] > 1.2
    if path == "biaxial":
        assert summary["checks"]["least ε_v (contraction)"] < 0.0


def test_material_paths_loose_sand_does_not_soften(tmp_path):
    """Negative control: Mast's loose sand (Table 3.5, iii) has no peak, so the
    dense sand's check fails and the demo exits 1."""
    stdout = run_demo(
        "material_paths.py",
        "--sand",
        "loose",
        "--steps",
        "100",
        "--output",
        str(tmp_path),
        "--json",
        cwd=tmp_path,
        fails=True,
    )
    summary = _last_json(stdout)
    assert not summary["check_passed"]
    assert summary["checks"]["peak / end of the driven stress"] < 1.01


def test_thick_cylinder_follows_hills_plastic_expansion_to_near_its_limit_pressure(tmp_path):
    """J2, u-p, ν = 0.4999, pressure on the inner arc (``fe_mpm.Pressure``) raised to
    0.95 p_lim in 10 steps: every step's u(a) within 1 % of Hill's closed form
    (measured 0.74 %, the u form 65 %), the reaction on y = 0 equal to p a to
    round-off, and the pressure–expansion curve written."""
    out = tmp_path / "out"
    stdout = run_demo(
        "thick_cylinder.py", "--steps", "10", "--json", "--output", str(out), cwd=tmp_path
    )
    summary = _last_json(stdout)
    assert summary["check_passed"] is True
    assert summary["largest_relative_error"] < 0.01
    assert summary["reaction_balance"] < 1e-9
    assert summary["last_pressure"] == pytest.approx(0.95 * summary["limit_pressure"])
    curve = np.loadtxt(out / "pressure_expansion.csv", delimiter=",", skiprows=1)
    assert curve.shape == (10, 3) and np.all(np.diff(curve[:, 1]) > 0)


def test_cavity_expansion_follows_gibson_and_andersons_pressuremeter_curve(tmp_path):
    """A cavity in Tresca clay (G/c_u = 100) expanded by a PointPressure towards 1.5
    times its radius, on cells of a₀/10 in 10 steps: every step's pressure within 2 %
    of the reference's at the measured radius (measured 0.60 %; 0.42 % on a₀/20, the
    demo's default), and the cavity's growth a − a₀ within 2 % of the reference's for
    the last pressure (measured +0.6 %; −11.7 % until 2026-12-06, when the pressure's
    points on the face moved into the cells beyond it loaded the filled cells behind
    the face instead of the face itself). The same pressure on the grid's facets
    (``fe_mpm.Pressure``) stays where the face was and is 24 % off; standard MPM stops
    in step 11."""
    out = tmp_path / "out"
    args = ("--h", "0.1", "--steps", "10", "--json")
    summary = _last_json(run_demo("cavity_expansion.py", *args, "--output", str(out), cwd=tmp_path))
    assert summary["check_passed"] is True
    assert summary["largest_relative_error"] < 0.02
    assert abs(summary["expansion_error"]) < 0.02
    curve = np.loadtxt(out / "pressure_expansion.csv", delimiter=",", skiprows=1)
    assert curve.shape[1] == 3 and np.all(np.diff(curve[:, 1]) > 0)
    stdout = run_demo(
        "cavity_expansion.py", *args, "--load", "grid", "--no-output", cwd=tmp_path, fails=True
    )
    assert _last_json(stdout)["largest_relative_error"] > 0.1


def test_hertz_contact_half_width_and_the_walls_pressure_distribution(tmp_path):
    """A cylinder pressed on a smooth rigid plane (R = 1 m, b = 0.15 R by Hertz) on
    cells of 0.0075 R at the contact, 5 load steps: the wall's push balances the load
    to 1e-9 (measured 2e-15), and the half-width read from the nodal forces' second
    moment is within 2 % of Hertz's (measured +0.85 %; +3.0 % before each node's
    reach along the wall was its own facets', below). The CSV of the wall's
    distribution holds the nodes in contact, whose pressures times their shares of
    the plane add up to the push.

    A helper's graded contacts (2026-12-07): every node looked for the body as far
    along the wall as the wall's mean facet, 2.7 to 7 cells at the contact, and took
    the lowest point of the cylinder well beyond it: b/R = 0.1 on cells of b/10 came
    out +10.3 % wide; now +1.2 %. With point domains a node that no point reached
    pushed with gap 0 where the body was clear of the wall: b/R = 0.05 on cells of
    b/20 read b four times Hertz's; now +1.1 %. On cells of b/5 (b/R = 0.05) the
    check fails (+14 %)."""
    out = tmp_path / "out"
    args = ("--h-contact", "0.0075", "--json")
    summary = _last_json(run_demo("hertz_contact.py", *args, "--output", str(out), cwd=tmp_path))
    assert summary["check_passed"] is True
    assert summary["push_over_load"] == pytest.approx(1.0, abs=1e-9)
    assert 0.0 < summary["half_width_error"] < 0.02
    rows = np.genfromtxt(out / "contact_pressure.csv", delimiter=",", names=True, dtype=None)
    assert len(rows) == summary["nodes_in_contact"]
    push = np.sum(rows["pressure"] * rows["area"])
    assert push == pytest.approx(summary["push_over_load"] * 0.5 * np.pi * 0.15**2 * 1e6 / 3.64)

    def error(*options, fails=False):
        stdout = run_demo(
            "hertz_contact.py", *options, "--json", "--no-output", cwd=tmp_path, fails=fails
        )
        return _last_json(stdout)["half_width_error"]

    assert abs(error("--contact", "0.1", "--h-contact", "0.01")) < 0.03
    assert abs(error("--contact", "0.05", "--h-contact", "0.0025", "--point-domains")) < 0.03
    assert error("--contact", "0.05", "--h-contact", "0.01", fails=True) > 0.1


def test_a_demo_whose_result_is_off_its_reference_exits_non_zero(tmp_path):
    """Every demo ends by checking its headline result against its reference. The
    tension test in the irreducible form at ν = 0.4999 locks: its limit load
    overshoots (2/√3) σ_Y W by 3.6 % (measured), beyond the demo's 1 % tolerance, so
    the demo prints a FAIL line and exits 1 (the u-p form passes at 0.08 %)."""
    stdout = run_demo(
        "tension_plate.py",
        "--formulation",
        "u",
        "--steps",
        "10",
        "--no-output",
        "--json",
        cwd=tmp_path,
        fails=True,
    )
    line = check_line(stdout)
    assert line.startswith("check: limit load ") and "(u, ν = 0.4999)" in line
    assert "> 1 % tolerance: FAIL" in line
    summary = _last_json(stdout)
    assert not summary["check_passed"] and summary["relative_error"] > 0.03


def test_sand_column_contract_on_a_coarse_grid_cut_short(tmp_path):
    """Mast's sand column at a = 1 on a 2 cm grid for its first 0.1 s (36 points, 40
    steps of 2.5 ms, one of them cut in two; 10 s): the contract's keys, the column
    already falling and spreading (measured L = 0.058, H = 0.980), and the check not
    made on a run cut short while the sand still moves (Mast's bounds are on the
    deposit at rest). Below a = 1 Mast's height is a, and the check allows 2 %
    either side (until 2026-12-06 it asked for H_f = a exactly, which no run could
    meet: a = 0.5 on 5 mm cells with 12 points per cell ran out inside Mast's band
    and failed on its height, 0.500 to three digits); at a = 1, where his Table
    7.6 bounds H_f for a ≲ 1 and for a ≳ 1 alike, it spans both: from his fit's
    lower bound 0.820 to 1.02."""
    stdout = run_demo(
        "sand_column.py",
        *("--aspect", "1", "--h", "0.02", "--t-end", "0.1", "--json", "--no-output"),
        cwd=tmp_path,
    )
    out = _last_json(stdout)
    for key in ("L_f", "H_f", "points", "steps", "wall_time_s", "bed_push_last_steps"):
        assert key in out
    assert out["check_passed"] is None and "not checked (cut short" in check_line(stdout)
    assert out["steps"] >= 40 and 0.0 < out["L_f"] < 0.5 and 0.9 < out["H_f"] < 1.0
    assert out["H_f_bounds"] == pytest.approx([0.820, 1.02], rel=1e-12)


def test_column_impact_contract_on_a_short_block_cut_short(tmp_path):
    """Mast's soil surge against a wall (§7.4) with a block 2 m long and high, for its
    first second (768 points, about 40 steps of up to 0.1 s; 40 s): the contract's
    keys, the soil's front reaching the face 1 m ahead after it has slumped across the
    gap (measured at t = 0.91–0.93 s), the bed carrying the soil's weight over the
    last second to 3 % (measured 0.994 from the geostatic start; 0.961 when it
    started unstressed and still settled), and the check not made on a run cut
    short."""
    stdout = run_demo(
        "column_impact.py",
        *("--height", "2", "--length", "2", "--t-end", "1.0", "--dt", "0.1"),
        *("--json", "--no-output"),
        cwd=tmp_path,
    )
    out = _last_json(stdout)
    for key in (
        "R_pk",
        "R_ss",
        "H_act",
        "face_force_peak_N",
        "R_pk_over_nominal_step",
        "points",
        "steps",
        "wall_time_s",
        "start",
    ):
        assert key in out
    assert out["check_passed"] is None and "not checked (cut short" in check_line(stdout)
    assert out["points"] == 768 and out["face_force_peak_N"] > 0.0 and out["H_act"] > 0.0
    assert 0.7 < out["t_pk"] <= 1.0
    assert out["bed_push_over_weight"] == pytest.approx(1.0, abs=0.03)


@pytest.mark.parametrize(
    "aspect, fronts, heights, formulation",
    [("2", 4, 3, "up"), ("1", 7, 2, "up"), ("2", 4, 3, "u-nbva")],
)
def test_dam_break_follows_martin_and_moyce_up_to_t_1_5(
    tmp_path, aspect, fronts, heights, formulation
):
    """The dam break of Mast §6.1.1 to T = 1.5: the front and the height at Martin &
    Moyce's tabulated times lie in the demo's bands. Measured (u-p without PPP, the
    fluid's points keeping the volume of their pressure): h₀ = 2 l₀ (81 steps) front
    −3.9, +8.0, +14.1, +14.6 %, height −1.2, −2.0, −1.0 % (2 s); h₀ = l₀ (114 steps)
    front +3.4, +8.3, +6.7, +6.2, +7.7, +8.0, +9.4 %, height −2.5, −3.9 % (2 s).
    With Mast's anti-locking, NB-VA (``u-nbva``, its fluid points keeping the averaged
    volume and its starting pressure by parts), h₀ = 2 l₀: front −3.9, +8.2, +14.6,
    +15.3 %, height −1.2, −2.0, −0.9 %, 3 Newton iterations a step; until 2026-12-05,
    with each point's own volume, a point was thrown out of the tank at T = 1.29."""
    stdout = run_demo(
        "dam_break.py",
        "--aspect",
        aspect,
        "--formulation",
        formulation,
        "--T-end",
        "1.5",
        "--json",
        "--no-output",
        cwd=tmp_path,
    )
    out = _last_json(stdout)
    assert out["check_passed"] and check_line(stdout).endswith(": PASS")
    assert len(out["front_relative_error"]) == fronts
    assert len(out["height_relative_error"]) == heights
    assert -0.10 <= min(out["front_relative_error"]) and max(out["front_relative_error"]) <= 0.25
    assert max(abs(e) for e in out["height_relative_error"]) <= 0.10
    assert out["newton_iterations_max"] <= 6
    for key in ("T", "front_Z", "height_H", "points", "steps", "wall_time_s"):
        assert key in out


def test_dam_break_cut_short_before_the_first_tabulated_time_is_not_checked(tmp_path):
    """A run that ends before Martin & Moyce's first time (T = 0.41) has nothing to
    compare: the demo says so and exits 0 (it raised on an empty error array)."""
    stdout = run_demo("dam_break.py", "--T-end", "0.3", "--json", "--no-output", cwd=tmp_path)
    out = _last_json(stdout)
    assert "before Martin & Moyce's first time: not checked" in check_line(stdout)
    assert out["check_passed"] is None and out["front_relative_error"] is None
