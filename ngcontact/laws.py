"""Nonlinear elasticity F and viscosity A: Lipschitz, strongly monotone maps of the strain
(the paper's hypotheses (2.16)-(2.17)), given as Python functions of CoefficientFunctions.

A law maps the strain (or the strain rate) ε, a symmetric dim × dim matrix
CoefficientFunction, to the stress, a symmetric dim × dim matrix CoefficientFunction (Pa):

    Material.with_elasticity(lambda eps: ...)          F(ε)
    Material.with_viscosity(lambda rate: ...)           A(ε̇)   (a number: A = τ F, as before)

NGSolve differentiates the expression for Newton (``BilinearForm.AssembleLinearization``)
and for Nitsche's variation σ_ν'(u)[v] (``CoefficientFunction.Diff``). The hypotheses are
checked before a run (``StrainLaw.bind``): the law is evaluated at ``SAMPLES`` pairs of
strains of sizes between 1e-3 and 1e1 times ``strain_scale`` and

    (F(a) − F(b)) : (a − b) ≥ m |a − b|²,   |F(a) − F(b)| ≤ L |a − b|     (Frobenius norms)

give the estimated monotonicity m and Lipschitz constant L (or the user's, checked against
the samples); m ≤ 0 at a sampled pair is an error naming the law and the pair. L sets the
scale of Nitsche's γ and of the penalty (``MaterialTensors.stiffness``); the tangent at
ε = 0 (``linear``) is the bulk the preconditioners of iterative solvers use.

Built-in laws (``ProjectionLaw``, ``PowerViscosity``) add a nonlinear part to the material's
own linear tensor ℰ (its F, or its A for a viscosity):

* ``ProjectionLaw(zeta, onto)``: ℰε + ζ(ε − P_K ε), P_K the projection onto a closed convex
  set K of strains (``VonMisesBall(radius)``: |dev ε| ≤ radius, with the 3D deviator of the
  plane-strain ε in 2D; ``Slab(i, lower, upper)``: lower ≤ ε_ii ≤ upper). ε − P_K ε is the
  gradient of ½ dist(ε, K)², monotone and 1-Lipschitz: m = λ_min(ℰ), L ≤ λ_max(ℰ) + ζ;
* ``PowerViscosity(zeta, exponent, delta)``: ℰε̇ + ζ (δ² + |dev ε̇|²)^((r−2)/2) dev ε̇,
  1 ≤ r ≤ 2, a shear-thinning (power-law) viscosity regularised by δ > 0 (s⁻¹) to be
  Lipschitz (L ≤ λ_max(ℰ) + ζ δ^(r−2)); the gradient of a convex potential, so monotone.
"""
import inspect
import math

import ngsolve as ngs
import numpy as np

from .checks import number
from .voigt import matrix_cf, strain_matrix, strain_vector, stress_matrix, stress_vector

SAMPLES = 64
"""Pairs of strains at which a law's hypotheses are checked."""


def deviator(eps, dim):
    """dev ε of the 3D strain (the plane-strain ε padded with zeros in 2D): its in-plane block,
    and |dev ε|² (Frobenius, the out-of-plane (tr ε/3)² included in 2D)."""
    trace = sum(eps[i, i] for i in range(dim))
    dev = eps - trace / 3 * ngs.Id(dim)
    norm2 = ngs.InnerProduct(dev, dev) + ((trace / 3) ** 2 if dim == 2 else 0)
    return dev, norm2


class VonMisesBall:
    """K = {ε : |dev ε| ≤ radius} (radius: a strain, dimensionless)."""

    def __init__(self, radius):
        self.radius = _positive("VonMisesBall: radius", radius)

    def excess(self, eps, dim):
        """ε − P_K ε = max(0, 1 − radius/|dev ε|) dev ε."""
        dev, norm2 = deviator(eps, dim)
        norm = ngs.sqrt(norm2 + 1e-300)
        return ngs.IfPos(norm - self.radius, 1 - self.radius / norm, 0) * dev

    def __repr__(self):
        return f"VonMisesBall({self.radius:g})"


class Slab:
    """K = {ε : lower ≤ ε_ii ≤ upper} for one normal component i (0, 1 or 2)."""

    def __init__(self, component, lower=-math.inf, upper=math.inf):
        if component not in (0, 1, 2):
            raise ValueError(f"Slab: component must be 0, 1 or 2 (a normal strain ε_ii), got {component!r}")
        self.component = component
        self.lower = -math.inf if lower == -math.inf else float(lower)
        self.upper = math.inf if upper == math.inf else float(upper)
        if not self.lower < self.upper or not (math.isfinite(self.lower) or math.isfinite(self.upper)):
            raise ValueError(f"Slab: need lower < upper, one of them finite, got {lower!r}, {upper!r}")

    def excess(self, eps, dim):
        """ε − P_K ε: (ε_ii − clip(ε_ii)) e_i ⊗ e_i."""
        if self.component >= dim:
            raise ValueError(f"Slab: component {self.component} does not exist in {dim}D")
        e = eps[self.component, self.component]
        over = 0.0
        if math.isfinite(self.upper):
            over = ngs.IfPos(e - self.upper, e - self.upper, 0)
        if math.isfinite(self.lower):
            over = over + ngs.IfPos(self.lower - e, e - self.lower, 0)
        unit = np.zeros((dim, dim))
        unit[self.component, self.component] = 1.0
        return over * ngs.CF(tuple(unit.flat), dims=(dim, dim))

    def __repr__(self):
        return f"Slab({self.component}, {self.lower:g}, {self.upper:g})"


class StrainLaw:
    """A stress law σ = law(ε) of the strain (or strain rate), for ``Material.with_elasticity``
    and ``with_viscosity``.

    Parameters
    ----------
    function : callable, ε (symmetric dim × dim matrix CF) -> σ (symmetric dim × dim CF, Pa);
        it may read the material's linear tensor as a second argument ``linear(ε)`` if it
        takes two (the built-in laws do).
    name : for messages.
    lipschitz, monotonicity : the constants L, m (Pa; Pa·s for a viscosity), or None to
        estimate them from samples; given ones are checked against the samples.
    strain_scale : the size of the strains (or strain rates, 1/s) of the intended use, around
        which the samples are drawn.
    """

    def __init__(self, function, name=None, *, lipschitz=None, monotonicity=None, strain_scale=1e-3):
        if isinstance(function, str) or not callable(function):
            raise TypeError(f"a law must be a Python function of the strain CoefficientFunction, got "
                            f"{function!r} ({type(function).__name__})")
        self.function = function
        self.name = name or getattr(function, "__name__", "law")
        self.lipschitz = None if lipschitz is None else _positive(f"law {self.name!r}: lipschitz", lipschitz)
        self.monotonicity = None if monotonicity is None else _positive(f"law {self.name!r}: monotonicity",
                                                                       monotonicity)
        self.strain_scale = _positive(f"law {self.name!r}: strain_scale", strain_scale)
        self.takes_linear = self._arguments() >= 2

    def _arguments(self):
        try:
            return len(inspect.signature(self.function).parameters)
        except (TypeError, ValueError):            # a builtin without a signature: ε only
            return 1

    def bind(self, linear, dim, what):
        """The law for a ``dim``-D model whose material's linear tensor (Voigt, model
        dimension) is ``linear``: checked, its constants and tangent at 0 found."""
        return BoundLaw(self, np.asarray(linear, dtype=float), dim, what)

    def __repr__(self):
        return f"StrainLaw({self.name!r})"


class ProjectionLaw(StrainLaw):
    """ℰε + ζ(ε − P_K ε) (module docstring): ``zeta`` in Pa (Pa·s for a viscosity), ``onto``
    a ``VonMisesBall`` or a ``Slab``."""

    def __init__(self, zeta, onto, **options):
        zeta = _nonnegative("ProjectionLaw: zeta", zeta)
        if not hasattr(onto, "excess"):
            raise TypeError(f"ProjectionLaw: onto must be a VonMisesBall or a Slab, got {onto!r}")
        self.zeta, self.onto = zeta, onto

        def projection_law(eps, linear):
            dim = eps.dims[0]
            return linear(eps) + zeta * onto.excess(eps, dim)
        super().__init__(projection_law, f"projection law ζ = {zeta:g}, K = {onto!r}", **options)


class PowerViscosity(StrainLaw):
    """ℰε̇ + ζ (δ² + |dev ε̇|²)^((r−2)/2) dev ε̇ (module docstring): ``zeta`` in Pa·s^r... (Pa
    at |dev ε̇| = 1/s for r = 1), ``exponent`` r in [1, 2], ``delta`` δ > 0 in 1/s."""

    def __init__(self, zeta, exponent=1.5, delta=1.0, **options):
        zeta = _nonnegative("PowerViscosity: zeta", zeta)
        r = number("PowerViscosity: exponent (monotone and Lipschitz)", exponent, 1, 2)
        delta = _positive("PowerViscosity: delta", delta)
        self.zeta, self.exponent, self.delta = zeta, r, delta

        def power_viscosity(rate, linear):
            dim = rate.dims[0]
            dev, norm2 = deviator(rate, dim)
            return linear(rate) + zeta * (delta ** 2 + norm2) ** ((r - 2) / 2) * dev
        options.setdefault("strain_scale", delta)
        super().__init__(power_viscosity, f"power viscosity ζ = {zeta:g}, r = {r:g}, δ = {delta:g}", **options)


class BoundLaw:
    """A StrainLaw for one model dimension and one material: ``voigt_stress(strain_voigt)`` the
    Voigt stress CF; ``linear`` the tangent at 0 (Voigt); ``lipschitz``, ``monotonicity``."""

    def __init__(self, law, linear, dim, what):
        self.law, self.dim, self.what, self.name = law, dim, what, law.name

        def linear_stress(eps):
            return stress_matrix(matrix_cf(linear) * strain_vector(eps, dim), dim)
        self._linear_stress = linear_stress
        self._check()

    def matrix_stress(self, eps):
        """σ = law(ε) as a matrix CF, for a strain matrix CF ε."""
        if self.law.takes_linear:
            return self.law.function(eps, self._linear_stress)
        return self.law.function(eps)

    def voigt_stress(self, strain_voigt):
        """The Voigt stress of a Voigt strain CF (``forms.strain``)."""
        return stress_vector(self.matrix_stress(strain_matrix(strain_voigt, self.dim)), self.dim)

    # ---------------------------------------------------------------- the hypotheses (2.16)-(2.17)
    def _check(self):
        dim, name = self.dim, self.law.name
        values = [ngs.Parameter(0.0) for _ in range(dim * (dim + 1) // 2)]
        pairs = [(i, j) for i in range(dim) for j in range(i, dim)]
        entries = {}
        for p, (i, j) in zip(values, pairs):
            entries[i, j] = entries[j, i] = p
        eps = ngs.CF(tuple(entries[i, j] for i in range(dim) for j in range(dim)), dims=(dim, dim))
        try:
            sigma = self.matrix_stress(eps)
        except Exception as error:
            raise ValueError(f"{self.what} law {name!r} failed on a strain CoefficientFunction: {error}") from error
        if not isinstance(sigma, ngs.CoefficientFunction):
            raise TypeError(f"{self.what} law {name!r} must return a CoefficientFunction, got "
                            f"{type(sigma).__name__}")
        if tuple(sigma.dims) != (dim, dim):
            raise ValueError(f"{self.what} law {name!r} must return a {dim}x{dim} stress, got shape "
                             f"{tuple(sigma.dims)}")
        mesh = _point_mesh()
        point = mesh(0.25, 0.25)

        def evaluate(strain):
            for p, (i, j) in zip(values, pairs):
                p.Set(float(strain[i, j]))
            return np.array(sigma(point)).reshape(dim, dim)
        rng = np.random.default_rng(20261125)           # the same samples in every run
        scale = self.law.strain_scale
        m, L = math.inf, 0.0
        for k in range(SAMPLES):
            a, b = (_sample(rng, dim, scale) for _ in range(2))
            if k % 4 == 0:
                b = a + _sample(rng, dim, scale * 1e-3)    # close pairs: the local slopes
            sa, sb = evaluate(a), evaluate(b)
            for strain, stress in ((a, sa), (b, sb)):
                if not np.all(np.isfinite(stress)):
                    raise ValueError(f"{self.what} law {name!r} gives a non-finite stress {stress.tolist()} at "
                                     f"the strain {strain.tolist()}")
                if not np.allclose(stress, stress.T, rtol=1e-9, atol=1e-12 * (np.abs(stress).max() + 1e-300)):
                    raise ValueError(f"{self.what} law {name!r} gives a non-symmetric stress {stress.tolist()} "
                                     f"at the strain {strain.tolist()}")
            d, ds = a - b, sa - sb
            norm2 = float(np.sum(d * d))
            slope = float(np.sum(ds * d)) / norm2
            if not slope > 0:
                raise ValueError(f"{self.what} law {name!r} is not strongly monotone (2.16)-(2.17): "
                                 f"(σ(a) − σ(b)):(a − b) = {slope * norm2:.4g} ≤ 0 at a = {a.tolist()}, "
                                 f"b = {b.tolist()}")
            m, L = min(m, slope), max(L, math.sqrt(float(np.sum(ds * ds)) / norm2))
        if self.law.monotonicity is not None and self.law.monotonicity > m * (1 + 1e-9):
            raise ValueError(f"{self.what} law {name!r}: the given monotonicity {self.law.monotonicity:.4g} "
                             f"exceeds the sampled {m:.4g}")
        if self.law.lipschitz is not None and self.law.lipschitz < L * (1 - 1e-9):
            raise ValueError(f"{self.what} law {name!r}: the given Lipschitz constant {self.law.lipschitz:.4g} "
                             f"is below the sampled {L:.4g}")
        self.monotonicity = self.law.monotonicity or m
        self.lipschitz = self.law.lipschitz or L
        # the tangent at 0 (Voigt, engineering strain): central differences of σ(0 ± h e_J)
        h = 1e-6 * scale
        n = len(pairs)
        tangent = np.zeros((n, n))
        order = [(0, 0), (1, 1), (0, 1)] if dim == 2 else [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
        for J, (k, l) in enumerate(order):
            e = np.zeros((dim, dim))
            e[k, l] = e[l, k] = h / (1 if k == l else 2)         # engineering shear h
            column = (evaluate(e) - evaluate(-e)) / (2 * h)
            tangent[:, J] = [column[i, j] for (i, j) in order]
        self.linear = 0.5 * (tangent + tangent.T)


_MESH = None


def _point_mesh():
    global _MESH
    if _MESH is None:
        from netgen.geom2d import unit_square
        _MESH = ngs.Mesh(unit_square.GenerateMesh(maxh=2.0))
    return _MESH


def _sample(rng, dim, scale):
    size = scale * 10 ** rng.uniform(-3, 1)
    a = rng.standard_normal((dim, dim))
    a = 0.5 * (a + a.T)
    return size * a / np.linalg.norm(a)


def _positive(name, value):
    return number(name, value, 0, low_open=True)


def _nonnegative(name, value):
    return number(name, value, 0)
