"""Nonlinear elasticity F and viscosity A: Lipschitz, strongly monotone maps of the strain
(the paper's hypotheses (2.16)-(2.17)), given as Python functions of CoefficientFunctions.

A law maps the strain (or the strain rate) ε, a symmetric matrix CoefficientFunction, to the
stress, a symmetric matrix CoefficientFunction of the same size (Pa): 2 × 2 in plane strain,
3 × 3 in 3D and on the meridian section of a body of revolution, in the frame (e_r, e_z, e_θ)
with ε_rθ = ε_zθ = 0 (``model.kinematics``):

    Material.with_elasticity(lambda eps: ...)          F(ε)
    Material.with_viscosity(lambda rate: ...)           A(ε̇)   (a number: A = τ F, as before)

NGSolve differentiates the expression for Newton (``BilinearForm.AssembleLinearization``)
and for Nitsche's variation σ_ν'(u)[v] (``CoefficientFunction.Diff``). The hypotheses are
checked before a run (``StrainLaw.bind``): the law is evaluated at ``SAMPLES`` pairs of
strains of sizes from a thousandth to ten of ``strain_scale`` and

    (F(a) − F(b)) : (a − b) ≥ m |a − b|²,   |F(a) − F(b)| ≤ L |a − b|     (Frobenius norms)

give the estimated monotonicity m and Lipschitz constant L (or the user's, checked against
the samples); m ≤ 0 at a sampled pair is an error naming the law and the pair. L starts the
law's stiffness ``scale`` (a Parameter), which sets Nitsche's γ and the penalty
(``MaterialTensors.contact_stiffness``); the tangent at ε = 0 (``linear``) is the bulk the
preconditioners of iterative solvers use.

The hypotheses allow any constants, and a law may be steeper at the run's strains than at
the samples: an estimated L is then raised to the slope found there, and the step redone
with the new γ (``law_watch``). Only evidence against (2.16)-(2.17) is refused: a slope ≤ 0
(or below a given m), one above a given L, a non-finite stress, or a slope that grows without
bound along a ray of strains.

The law solved with is the law checked (``BoundLaw.verify``: a law reading a global variable
or a Parameter changed since its check is refused by name), and the run's own strains, which
may lie beyond the samples, are checked step by step (``law_watch``).

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

from ngcontact.checks import number
from ngcontact.model.voigt import matrix_cf

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
        if isinstance(function, (str, ngs.CoefficientFunction)) or not callable(function):
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

    def bind(self, linear, kinematics, what):
        """The law for a body of ``kinematics`` (``model.kinematics``) whose material's linear
        tensor (Voigt, in that kinematics) is ``linear``: checked, its constants and tangent at
        0 found."""
        return BoundLaw(self, np.asarray(linear, dtype=float), kinematics, what)

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
    """A StrainLaw for one kinematics and one material: ``voigt_stress(strain_voigt)`` the
    Voigt stress CF; ``linear`` the tangent at 0 (Voigt); ``lipschitz``, ``monotonicity``.

    Its stress at ``FINGERPRINT`` sampled strains is kept: each later call (``matrix_stress``)
    first compares the checked stress CF and a fresh call with it (``verify``). The run's
    strains are checked with ``jacobian``, ``chord`` and ``hypotheses`` (``law_watch``);
    ``checked_range``: the largest strain sampled so far; ``tangent_bound``: the largest norm
    of the tangent at the samples; ``scale`` (a Parameter, Pa or Pa·s): the slope that sets
    the contact stiffness (``MaterialTensors.contact_stiffness``), L at first, raised by the
    law watch to the steepest slope found at the run's strains where L was estimated."""

    def __init__(self, law, linear, kinematics, what):
        self.law, self.kinematics, self.what, self.name = law, kinematics, what, law.name
        self.dim = kinematics.matrix_size
        """The size of the strain matrices the law acts on."""

        def linear_stress(eps):
            return kinematics.stress_matrix(matrix_cf(linear) * kinematics.strain_vector(eps))
        self._linear_stress = linear_stress
        self.basis = strain_basis(kinematics.pairs, self.dim)
        self._check()

    def describe(self):
        """"elasticity law 'name'" (for messages)."""
        return f"{self.what} law {self.name!r}"

    def _call(self, eps, when=""):
        """law(ε), its type and shape checked."""
        name, dim = self.describe(), self.dim
        try:
            sigma = self.law.function(eps, self._linear_stress) if self.law.takes_linear else self.law.function(eps)
        except Exception as error:
            raise ValueError(f"{name} failed on a strain CoefficientFunction{when}: {error}") from error
        if not isinstance(sigma, ngs.CoefficientFunction):
            raise TypeError(f"{name} must return a CoefficientFunction, got {type(sigma).__name__}{when}")
        if sigma.is_complex:
            raise TypeError(f"{name} must return a real stress CoefficientFunction, got a complex one{when}")
        if tuple(sigma.dims) != (dim, dim):
            raise ValueError(f"{name} must return a {dim}x{dim} stress, got shape {tuple(sigma.dims)}{when}")
        return sigma

    def matrix_stress(self, eps):
        """σ = law(ε) as a matrix CF, for a strain matrix CF ε: the law called again, once
        ``verify`` found it unchanged since its check."""
        self.verify()
        return self._call(eps, " (called again after its check)")

    def voigt_stress(self, strain_voigt):
        """The Voigt stress of a Voigt strain CF (``forms.strain``)."""
        kinematics = self.kinematics
        return kinematics.stress_vector(self.matrix_stress(kinematics.strain_matrix(strain_voigt)))

    # ---------------------------------------------------------------- the law as checked
    def verify(self, fresh=True):
        """Raise a ValueError if the law is not the one checked: the checked stress CF (a
        Parameter it reads has changed) or, with ``fresh``, a new call of the law (a global
        variable it reads has changed) gives another stress at a ``FINGERPRINT`` strain
        (without ``fresh``, at the first and the largest only: the check of every step)."""
        found = self._changed(self._sigma, self._prints if fresh else (self._prints[0], self._prints[-1]))
        cause = "a Parameter or other CoefficientFunction it reads has a new value"
        if found is None and fresh:
            found = self._changed(self._call(self._eps, " (called again after its check)"))
            cause = "a new call of the law builds another stress: it reads a variable that has changed"
        if found is not None:
            strain, now, then = found
            raise ValueError(f"{self.describe()} has changed since it was checked ({cause}): at the strain "
                             f"{_fmt(strain)} it gives σ = {_fmt(now)} Pa, checked {_fmt(then)} Pa. The hypotheses "
                             "(2.16)-(2.17) hold for the law as checked only: a law must be a fixed function of the "
                             "strain; build the Body again after changing what the law reads")

    def _changed(self, sigma, prints=None):
        """(strain, stress now, stress checked) at the first of the ``prints`` (default: all
        ``FINGERPRINT`` strains) where ``sigma`` differs from the checked law, or None."""
        for strain, then in self._prints if prints is None else prints:
            now = self.evaluate(strain, sigma)
            scale = np.abs(then).max() + 1e-300
            if not np.all(np.abs(now - then) <= 1e-12 * scale):         # NaN differs too
                return strain, now, then
        return None

    def evaluate(self, strain, sigma=None):
        """The stress (numpy dim × dim) of the checked law (or of ``sigma``, a CF of the same
        placeholder strain) at a strain (numpy dim × dim)."""
        for p, (i, j) in zip(self._values, self._pairs):
            p.Set(float(strain[i, j]))
        return np.array((self._sigma if sigma is None else sigma)(self._point)).reshape(self.dim, self.dim)

    # ---------------------------------------------------------------- the hypotheses (2.16)-(2.17)
    def _check(self):
        dim = self.dim
        self._values = [ngs.Parameter(0.0) for _ in range(dim * (dim + 1) // 2)]
        self._pairs = [(i, j) for i in range(dim) for j in range(i, dim)]
        entries = {}
        for p, (i, j) in zip(self._values, self._pairs):
            entries[i, j] = entries[j, i] = p
        self._eps = ngs.CF(tuple(entries[i, j] for i in range(dim) for j in range(dim)), dims=(dim, dim))
        self._sigma = self._call(self._eps)
        self._point = _point_mesh()(0.25, 0.25)
        scale = self.law.strain_scale
        rng = np.random.default_rng(20261125)           # the same samples in every run
        m, L, strains = self.hypotheses(rng, scale)
        name = self.describe()
        if self.law.monotonicity is not None and self.law.monotonicity > m * (1 + 1e-9):
            raise ValueError(f"{name}: the given monotonicity {self.law.monotonicity:.4g} "
                             f"exceeds the sampled {m:.4g}")
        if self.law.lipschitz is not None and self.law.lipschitz < L * (1 - 1e-9):
            raise ValueError(f"{name}: the given Lipschitz constant {self.law.lipschitz:.4g} "
                             f"is below the sampled {L:.4g}")
        self.monotonicity = self.law.monotonicity or m
        self.lipschitz = self.law.lipschitz or L
        self.scale = ngs.Parameter(self.lipschitz)
        self.checked_range = max(float(np.linalg.norm(a)) for a in strains)
        picked = strains[::max(1, len(strains) // FINGERPRINT)][:FINGERPRINT - 1] + [max(strains, key=np.linalg.norm)]
        self._prints = [(a, self.evaluate(a)) for a in picked]
        # the largest norm of the tangent at the samples (and at 0): the sampled chords come in
        # random directions and find less than the steepest; the run's tangents are held to it
        self.tangent_bound = max(float(np.linalg.norm(self.jacobian(a), 2)) for a in [0 * strains[0]] + strains)
        # the tangent at 0 (Voigt, engineering strain): central differences of σ(0 ± h e_J)
        h = 1e-6 * scale
        order = self.kinematics.pairs
        tangent = np.zeros((len(order), len(order)))
        for J, (k, l) in enumerate(order):
            e = np.zeros((dim, dim))
            e[k, l] = e[l, k] = h / (1 if k == l else 2)         # engineering shear h
            column = (self.evaluate(e) - self.evaluate(-e)) / (2 * h)
            tangent[:, J] = [column[i, j] for (i, j) in order]
        self.linear = 0.5 * (tangent + tangent.T)

    def hypotheses(self, rng, scale, largest=None, where=""):
        """(m, L, the strains a) of ``SAMPLES`` pairs (a, b) of sizes 1e-3 to 1e1 × ``scale`` (or up
        to ``largest``), a quarter close pairs (local slopes); a non-finite or non-symmetric stress
        or (σ(a) − σ(b)):(a − b) ≤ 0 raises a ValueError naming the law, the strain and ``where``."""
        dim, name = self.dim, self.describe()
        top = 1.0 if largest is None else math.log10(largest / scale)
        m, L, strains = math.inf, 0.0, []
        project = self.kinematics.project
        for k in range(SAMPLES):
            a, b = (_sample(rng, dim, scale, top, project) for _ in range(2))
            if k % 4 == 0:
                b = a + _sample(rng, dim, scale * 1e-3, top, project)    # close pairs: the local slopes
            sa, sb = self.evaluate(a), self.evaluate(b)
            for strain, stress in ((a, sa), (b, sb)):
                if not np.all(np.isfinite(stress)):
                    raise ValueError(f"{name} gives a non-finite stress {stress.tolist()} at "
                                     f"the strain {strain.tolist()}{where}")
                if not np.allclose(stress, stress.T, rtol=1e-9, atol=1e-12 * (np.abs(stress).max() + 1e-300)):
                    raise ValueError(f"{name} gives a non-symmetric stress {stress.tolist()} "
                                     f"at the strain {strain.tolist()}{where}")
                if np.abs(stress - project(stress)).max() > 1e-9 * (np.abs(stress).max() + 1e-300):
                    raise ValueError(f"{name} gives the stress {stress.tolist()} at the strain {strain.tolist()}"
                                     f"{where}: its entries outside {self.kinematics.name}'s components "
                                     f"{list(self.kinematics.pairs)} are not 0 (a law of a body of revolution "
                                     "must not couple its torsion-free strains to twist)")
            d, ds = a - b, sa - sb
            norm2 = float(np.sum(d * d))
            slope = float(np.sum(ds * d)) / norm2
            if not slope > 0:
                raise ValueError(f"{name} is not strongly monotone (2.16)-(2.17): "
                                 f"(σ(a) − σ(b)):(a − b) = {slope * norm2:.4g} ≤ 0 at a = {a.tolist()}, "
                                 f"b = {b.tolist()}{where}")
            m, L = min(m, slope), max(L, math.sqrt(float(np.sum(ds * ds)) / norm2))
            strains.append(a)
        return m, L, strains

    def reset_scale(self):
        """The stiffness ``scale`` back to L (a new Simulation starts from the law as checked)."""
        self.scale.Set(self.lipschitz)

    def jacobian(self, strain, h=None):
        """The tangent dσ/dε at ``strain`` (numpy) in the orthonormal ``basis`` of symmetric
        strains (Frobenius), by forward differences of step ``h`` (default 1e-6 of the strain's
        size or of ``strain_scale``)."""
        h = h or 1e-6 * max(float(np.linalg.norm(strain)), self.law.strain_scale)
        sigma = self.evaluate(strain)
        columns = [coordinates(self.evaluate(strain + h * B) - sigma, self.basis) / h for B in self.basis]
        return np.array(columns).T

    def chord(self, strain, direction, h):
        """(d:(σ(ε + h d) − σ(ε))/h, |σ(ε + h d) − σ(ε)|/h) for the unit strain ``direction``
        d (numpy): the exact slopes of the checked law along a chord at ``strain``."""
        step = self.evaluate(strain + h * direction) - self.evaluate(strain)
        return float(np.sum(step * direction)) / h, float(np.linalg.norm(step)) / h


FINGERPRINT = 8
"""Sampled strains at which a law's stress is kept when checked (``BoundLaw.verify``)."""


def strain_basis(pairs, dim):
    """An orthonormal basis (Frobenius) of the symmetric dim × dim matrices with entries at
    ``pairs`` (i, j) only (numpy): e_i ⊗ e_i and (e_i ⊗ e_j + e_j ⊗ e_i)/√2."""
    basis = []
    for i, j in sorted(pairs):
        B = np.zeros((dim, dim))
        B[i, j] = B[j, i] = 1.0 if i == j else math.sqrt(0.5)
        basis.append(B)
    return basis


def coordinates(M, basis):
    """The coordinates of symmetric matrices ``M`` (..., dim, dim) in the ``basis``."""
    return np.einsum("...ij,bij->...b", M, np.array(basis))


def _fmt(a):
    return np.array2string(np.asarray(a), precision=4, separator=", ").replace("\n", "")


_MESH = None


def _point_mesh():
    global _MESH
    if _MESH is None:
        from netgen.geom2d import unit_square
        _MESH = ngs.Mesh(unit_square.GenerateMesh(maxh=2.0))
    return _MESH


def _sample(rng, dim, scale, top=1.0, project=None):
    """A random symmetric strain of size 1e-3 to 10**top × ``scale`` (only the entries
    ``project`` keeps)."""
    size = scale * 10 ** rng.uniform(-3, top)
    a = rng.standard_normal((dim, dim))
    a = 0.5 * (a + a.T)
    if project is not None:
        a = project(a)
    return size * a / np.linalg.norm(a)


def _positive(name, value):
    return number(name, value, 0, low_open=True)


def _nonnegative(name, value):
    return number(name, value, 0)
