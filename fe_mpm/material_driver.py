"""Drive a constitutive law through prescribed deformation paths, with no grid or particles.

The law is the same UFL code the simulation assembles. It is evaluated at ``n``
independent states at once: the states are the quadrature points of a single
reference cell, which only hosts the evaluation (nothing is integrated). Use it
to check a law against closed forms: yield onset, hardening, return to the
yield surface, and the algorithmic tangent ``∂τ/∂ΔF``.

Example::

    driver = MaterialDriver(J2Plasticity(E=1e3, nu=0.3, yield_stress=1.0), n=5)
    for gamma in np.linspace(0, 0.01, 11)[1:]:
        tau = driver.step(F_total)   # (n, 3, 3) Kirchhoff stress
    driver.history["plastic_strain"]
"""

from __future__ import annotations

from mpi4py import MPI

import basix
import basix.ufl
import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_finite, check_int
from fe_mpm.materials import PointState, embed_3d
from fe_mpm.materials.protocol import Law, PointwiseLaw, missing_members


class MaterialDriver:
    """Strain-driven single-point driver for ``n`` independent material points.

    Args:
        material: A law of :mod:`fe_mpm.materials`.
        n: Number of independent points driven at once.
        gdim: 2 (plane strain, F is 2x2) or 3.
    """

    def __init__(self, material, n: int = 1, gdim: int = 3):
        missing = missing_members(material, Law)
        if missing:  # (as Simulation says it: a bare AttributeError until 2026-12-07)
            raise TypeError(
                f"MaterialDriver: material {type(material).__name__} is not a law: it lacks "
                f"{', '.join(missing)} (fe_mpm.materials.protocol.Law says what a law provides)"
            )
        n = check_int("MaterialDriver", "n", n, lo=1)
        gdim = check_int("MaterialDriver", "gdim", gdim)
        if gdim not in (2, 3):
            raise ValueError(f"MaterialDriver: gdim must be 2 (plane strain) or 3, got {gdim!r}")
        self.material, self.n, self.gdim = material, n, gdim
        g = gdim
        self.F = np.tile(np.eye(g), (n, 1, 1))
        self.history = {name: h.initial_values(n) for name, h in material.history.items()}
        # A pointwise law is its own numpy driver: no UFL to evaluate.
        self._pointwise = isinstance(material, PointwiseLaw)
        if self._pointwise:
            return
        cell = "triangle" if gdim == 2 else "tetrahedron"
        self.mesh = (
            dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
            if gdim == 2
            else dolfinx.mesh.create_unit_cube(MPI.COMM_SELF, 1, 1, 1)
        )
        centroid = basix.geometry(basix.CellType[cell]).mean(axis=0)
        points = np.tile(centroid, (n, 1))
        weights = np.full(n, 1.0 / n)
        self._points = points

        def function(shape, name):
            element = basix.ufl.quadrature_element(
                cell, value_shape=shape, scheme="custom", points=points, weights=weights
            )
            return dolfinx.fem.Function(dolfinx.fem.functionspace(self.mesh, element), name=name)

        self._dF = function((g, g), "dF")
        self._F_n = function((g, g), "F_n")
        self._hist = {name: function(h.shape, name) for name, h in material.history.items()}

        dF = ufl.variable(self._dF)
        state = PointState(dF, self._hist)
        F = dF * self._F_n
        tau = material.kirchhoff(F, state)
        tangent = ufl.diff(tau, dF)
        updated = material.updated_history(F, state)
        self._shapes = {name: ufl.shape(v) for name, v in updated.items()}
        values = [tangent[idx] for idx in np.ndindex(g, g, g, g)]
        for value in updated.values():
            shape = ufl.shape(value)
            values += [value[idx] for idx in np.ndindex(*shape)] if shape else [value]
        tau3 = material.kirchhoff(embed_3d(F), state)
        values += [tau3[i, j] for i in range(3) for j in range(3)]
        self._expression = dolfinx.fem.Expression(ufl.as_vector(values), points)
        self._cell = np.zeros(1, dtype=np.int32)

    def _pack(self, f: dolfinx.fem.Function, values: np.ndarray) -> None:
        """Write one value per state into the evaluation cell's quadrature dofs."""
        bs = f.function_space.dofmap.bs
        f.x.array.reshape(-1, bs)[f.function_space.dofmap.list[0]] = values.reshape(self.n, bs)

    def evaluate(self, F: np.ndarray) -> dict[str, np.ndarray]:
        """The law at total deformation gradients ``F`` (n, g, g), from the committed state.

        Returns:
            ``tau`` (n, 3, 3) Kirchhoff stress (Pa, σ_33 included in plane strain),
            ``tangent`` (n, g, g, g, g) = ∂τ_ij/∂ΔF_kl of the in-plane block,
            and the updated history by name; a pointwise law adds ``region``,
            its return region per state.
        """
        return self._evaluate(_checked_gradients(F, self.n, self.gdim))

    def _evaluate(self, F: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`evaluate` at ``F`` (n, g, g), already checked."""
        if self._pointwise:
            g = self.gdim
            result = self.material.return_map(F @ np.linalg.inv(self.F), self.history)
            return {
                "tangent": result.tangent[:, :g, :g],
                "tau": result.tau,
                "region": result.region,
                **result.history,
            }
        self._pack(self._dF, F @ np.linalg.inv(self.F))
        self._pack(self._F_n, self.F)
        for name, f in self._hist.items():
            self._pack(f, self.history[name])
        values = self._expression.eval(self.mesh, self._cell).reshape(self.n, -1)
        g = self.gdim
        k = g**4
        out = {"tangent": values[:, :k].reshape(self.n, g, g, g, g)}
        for name, shape in self._shapes.items():
            size = int(np.prod(shape)) if shape else 1
            out[name] = values[:, k : k + size].reshape(self.n, *shape)
            k += size
        out["tau"] = values[:, k : k + 9].reshape(self.n, 3, 3)
        return out

    def step(self, F: np.ndarray) -> np.ndarray:
        """Go to total deformation gradients ``F`` (n, g, g) and commit; returns τ (n, 3, 3)."""
        F = _checked_gradients(F, self.n, self.gdim)
        result = self._evaluate(F)
        for name in ("tau", *self.history):
            bad = ~np.isfinite(result[name].reshape(self.n, -1)).all(axis=1)
            if bad.any():  # (committed without a word until 2026-12-07)
                k = int(np.flatnonzero(bad)[0])
                raise ValueError(
                    f"MaterialDriver.step: {type(self.material).__name__} gave a non-finite "
                    f"{name} at state {k}; nothing was committed"
                )
        self.F = F.copy()
        for name in self.history:
            self.history[name] = result[name]
        return result["tau"]


def _checked_gradients(F, n: int, g: int) -> np.ndarray:
    """``F`` as (n, g, g) float64, refused unless finite with det F > 0.

    A helper's probe (2026-12-07): det F < 0 gave a Neo-Hookean NaN and a
    Mohr-Coulomb a finite stress, and a NaN was committed to J2's history.
    """
    F = check_finite("MaterialDriver", "F", F)
    if F.size != n * g * g:
        raise ValueError(
            f"MaterialDriver: F must have shape ({n}, {g}, {g}) (n states of g x g), got {F.shape}"
        )
    F = F.reshape(n, g, g)
    J = np.linalg.det(F)
    if np.any(J <= 0.0):
        k = int(np.flatnonzero(J <= 0.0)[0])
        raise ValueError(
            f"MaterialDriver: F must have det F > 0, got det F = {J[k]:g} at state {k}"
        )
    return F


def cauchy_stress(tau: np.ndarray, F: np.ndarray) -> np.ndarray:
    """σ = τ/J (n, 3, 3), Pa, of Kirchhoff stresses (n, 3, 3) and F (n, g, g)."""
    J = np.linalg.det(F)
    return tau / J[:, None, None]


def mixed_control(
    driver: MaterialDriver,
    F: np.ndarray,
    free: list[tuple[int, int]],
    held: dict[tuple[int, int], float],
    tolerance: float = 1e-9,
    max_iterations: int = 50,
    measure: str = "cauchy",
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Solve for the ``free`` entries of F so that the ``held`` stresses are met.

    A mixed-control material driver (Mast 2013, §3.8): some entries of the
    deformation gradient are prescribed (those of ``F`` not listed in ``free``),
    and as many Cauchy stress components as there are free entries are held.
    Newton's Jacobian is the law's own tangent, ∂τ_ab/∂F_ij = ∂τ_ab/∂ΔF_im (F_n⁻¹)_jm,
    and for Cauchy stresses ∂σ_ab/∂F_ij = (∂τ_ab/∂F_ij)/J − σ_ab (F⁻ᵀ)_ij, solved in
    the least-squares sense (on a singular return two free entries may move together).

    Args:
        driver: A one-point driver (``n=1``) at its committed state F_n.
        F: The deformation gradient to go to (g, g): the prescribed entries, and a
            start for the free ones.
        free: The entries (i, j) to solve for.
        held: Stress component (a, b) -> its value (Pa); as many as ``free``.
        tolerance: Stop when every held component is met to this fraction of the
            stresses in play: the largest held stress or stress component, or 1 Pa
            (held stresses of zero met a floor of 1e-9 Pa that round-off of 1e6 Pa
            stresses missed, 2026-12-07); Mast used 1e-6. The returns' own round-off
            is near 1e-10 of the stress.
        measure: ``"cauchy"`` (σ, Mast's) or ``"kirchhoff"`` (τ = Jσ) for the held stresses.
        max_iterations: Newton iterations before giving up.

    Returns:
        The deformation gradient (g, g) and the law's result there
        (:meth:`MaterialDriver.evaluate`, for one point), with ``sigma`` (3, 3) added.

    Raises:
        RuntimeError: Newton did not meet the held stresses.
    """
    if driver.n != 1:
        raise ValueError(f"mixed_control: the driver must have n = 1 point, got n = {driver.n}")
    if measure not in ("cauchy", "kirchhoff"):
        raise ValueError(f"mixed_control: measure must be 'cauchy' or 'kirchhoff', got {measure!r}")
    if len(free) != len(held):
        raise ValueError(
            f"mixed_control: as many held stresses as free entries are needed, got "
            f"{len(held)} held and {len(free)} free"
        )
    F = np.array(F, dtype=np.float64)
    Fn_inv = np.linalg.inv(driver.F[0])
    targets = np.array(list(held.values()), dtype=np.float64)
    scale = max(np.abs(targets).max(initial=0.0), 1.0)
    residual = np.full(len(held), np.inf)
    for _ in range(max_iterations):
        result = driver.evaluate(F[None])
        sigma = cauchy_stress(result["tau"], F[None])[0]
        held_stress = sigma if measure == "cauchy" else result["tau"][0]
        residual = np.array([held_stress[a, b] for a, b in held]) - targets
        scale = max(scale, float(np.abs(held_stress).max(initial=0.0)))
        if not np.all(np.isfinite(residual)):
            raise RuntimeError(
                "mixed_control: the law returned a non-finite stress at F = "
                f"{np.array2string(F, precision=6)}"
            )
        if np.abs(residual).max() <= tolerance * scale:
            return F, {**{k: v[0] for k, v in result.items()}, "sigma": sigma}
        D = result["tangent"][0]  # ∂τ_ab/∂ΔF_im, in-plane block
        J = np.linalg.det(F)
        F_inv_T = np.linalg.inv(F).T
        if measure == "cauchy":
            jacobian = np.array(
                [
                    [D[a, b, i] @ Fn_inv[j] / J - sigma[a, b] * F_inv_T[i, j] for i, j in free]
                    for a, b in held
                ]
            )
        else:
            jacobian = np.array([[D[a, b, i] @ Fn_inv[j] for i, j in free] for a, b in held])
        step = np.linalg.lstsq(jacobian, -residual, rcond=1e-12)[0]
        for (i, j), s in zip(free, step, strict=True):
            F[i, j] += s
    raise RuntimeError(
        f"mixed_control: the held stresses were not met in {max_iterations} iterations "
        f"(residual {np.abs(residual).max():.3g} Pa against {tolerance * scale:.3g} Pa)"
    )
