"""The nonlinear system of one time step, assembled in the parts of ``forms``.

The bulk of the step residual (``forms``) is linear with constant coefficients: with

  K_el : b(u, v) + e(v, φ) + e(u, ξ) − c(φ, ξ)     (``forms.bulk``),
  K_A  : a(u, v)                                    (``forms.a``, Kelvin-Voigt viscosity),

assembled once, the residual of the step to t_n at x = (u, φ) is

  R(x) = K_el x + c K_A (x − x̂) − f(t_n) + R_Γ3(x),

where the time scheme sets t_n, the rate coefficient c (1/s) and the anchor û of x̂ = (û, 0)
(``schemes.StepCoefficients``; backward Euler: c = 1/k, û = u_{n−1}), and only R_Γ3
(``gamma3.integrands.contact_terms``) is nonlinear. Its Jacobian is K = K_el + c K_A plus R_Γ3'(x):
each Newton iteration assembles the Γ3 terms only and adds matrices of one sparsity pattern.

Laws (``laws``, (2.16)-(2.17)) move their parts out of K_el, K_A into N(x) (``law_terms``),
added to R and, as N'(x), to the Jacobian; the kept factorisation then refreshes when GMRES
needs it (``changing_entries`` still names the Γ3 positions only).

``StepSystem`` offers what ``Newton`` uses of a nonlinear NGSolve ``BilinearForm``:
``Apply``, ``AssembleLinearization``, ``mat`` and, for static condensation, ``condense``,
``harmonic_extension``, ``harmonic_extension_trans`` and ``inner_solve``. With
``condense=True`` the element-interior DOFs of the elements away from Γ3 appear in K only;
they are eliminated once per value of c by a condensed form of K, and ``mat`` is the
Schur complement of K plus R_Γ3' on the remaining (coupling) DOFs. The interior DOFs of the
elements at Γ3 are kept as coupling DOFs of the system's own space.
"""

import ngsolve as ngs
import numpy as np

from ngcontact import meshes, parallel
from ngcontact.model.loads import as_cf
from ngcontact.solve.linalg.matrices import Absolute, diagonal as matrix_diagonal, matching_positions
from ngcontact.solve.law_terms import LawTerms
from ngcontact.gamma3.terms import Gamma3Terms


def has_interior_dofs(space):
    """True if ``space`` has free element-interior DOFs, which static condensation eliminates."""
    interior = space.FreeDofs().NumSet() - space.FreeDofs(coupling=True).NumSet()
    return parallel.sum(space.mesh, interior) > 0


def keep_interior_dofs(space, region):
    """Mark the element-interior (LOCAL) DOFs of the volume elements with a facet in the
    boundary ``region`` as coupling DOFs of ``space``, so that condensation leaves them."""
    mesh = space.mesh
    facets = {f.nr for el in region.Elements() for f in meshes.facets_of(mesh, el)}
    for nr in facets:
        for element in mesh.facets[nr].elements:
            for dof in space.GetDofNrs(element):
                if dof >= 0 and space.CouplingType(dof) == ngs.COUPLING_TYPE.LOCAL_DOF:
                    space.SetCouplingType(dof, ngs.COUPLING_TYPE.INTERFACE_DOF)
    space.FinalizeUpdate()                                  # recomputes FreeDofs(coupling=True)


class StepSystem:
    """R(x) and its Jacobian for a Body under Loads, on the space ``X``.

    Parameters
    ----------
    weak_form : the ``weak_form.WeakForm`` of the step: its body and loads (CoefficientFunctions
        of the ``time`` Parameter), the time scheme's ``coefficients`` (t_n, the rate coefficient
        c and the anchor û, read here, written by the scheme only) and its terms.
    X : the system's own product space V × W (``body.space()``); condensation marks DOFs on it.
    condense : static condensation of the interior DOFs away from ``kept`` (a boundary
        region, Γ3).

    ``generation`` counts the changes of the bulk matrix K (with c), after which a kept
    factorisation no longer fits. ``add_boundary_terms(side)`` adds R_Γ3;
    ``begin_step(state)`` prepares the step the scheme has set; ``boundary_residual`` holds
    R_Γ3 at the last ``Apply``.
    """

    def __init__(self, weak_form, X, *, condense=False, kept=None):
        body, coefficients = weak_form.body, weak_form.coefficients
        self.weak_form, self.body, self.X, self.coefficients = weak_form, body, X, coefficients
        self.loads = weak_form.loads
        self.condense = bool(condense)
        if self.condense and kept is not None:
            keep_interior_dofs(X, kept)
        trial, test = X.TnT()
        T = body.tensors
        if not T.linear:
            if self.condense:
                raise ValueError("condense=True needs linear tensors: a nonlinear law makes the interiors nonlinear")
        self.K_el = ngs.BilinearForm(X, symmetric=False)
        self.K_el += weak_form.bulk(trial, test)
        self.K_A = None
        if T.viscous and T.A_law is None:
            self.K_A = ngs.BilinearForm(X, symmetric=False)
            self.K_A += weak_form.a(trial[0], test[0])
        weak_supports = weak_form.supports(trial, test)
        for elastic, viscous, integral in weak_supports:
            self.K_el += integral(elastic)
            if viscous is not None:
                self.K_A += integral(viscous)
        self.laws = None                 # N(x): (2.16)-(2.17), on Ω and on the weak supports
        if not T.linear:
            self.laws = LawTerms(weak_form, X)
        for form in (self.K_el, self.K_A):
            if form is not None:
                form.Assemble()
        if self.condense:
            self._K_condensed = ngs.BilinearForm(X, symmetric=False, condense=True)
            self._K_condensed += weak_form.stepped_bulk(trial, test)
            for elastic, viscous, integral in weak_supports:
                self._K_condensed += integral(elastic if viscous is None else elastic + coefficients.rate * viscous)
            self._schur = None
        self.f = ngs.LinearForm(X)
        for integral in weak_form.f(test):
            self.f += integral
        self.K = self.K_el.mat.CreateMatrix()
        self._full = self.K_el.mat.CreateMatrix()
        self.mat = self._full
        self.boundary = None
        self._x_old = ngs.GridFunction(X)
        self._constant = self._x_old.vec.CreateVector()       # f + c K_A x̂
        self.boundary_residual = self._x_old.vec.CreateVector()
        self.boundary_residual[:] = 0.0
        self._internal = self._x_old.vec.CreateVector()       # K x − c K_A x̂
        self._rate, self._linearized = None, False
        self._positions = {}
        self.generation = 0                                    # counts the changes of K
        # the Dirichlet DOFs of V: all of them, and those of Γ1 (u = 0)
        self.held = ~np.array(list(body.V.FreeDofs()), dtype=bool)  # public: Newton starts keep them
        self._boundary_dofs = {}                               # per support component or electrode: its DOFs
        clamped = ngs.VectorH1(body.mesh, order=body.order, dirichlet=body.region_names("clamped"))
        self._clamped = ~np.array(list(clamped.FreeDofs()), dtype=bool)

    # ----------------------------------------------------------------------- building
    def add_boundary_terms(self, side, realcompile=False):
        """Add the weak form's Γ3 part ∫_Γ3 (j_a + S − j_e) da to R (once; ``WeakForm.gamma3``,
        attached by ``gamma3.build``); ``side`` the ContactSide (``gamma3.terms.Gamma3Terms``:
        interpreted, or with ``realcompile`` compiled to machine code at once)."""
        if self.boundary is not None:
            raise RuntimeError("the Γ3 terms are added once")
        self.boundary = Gamma3Terms(self.X, self.weak_form.gamma3, side, realcompile)

    @property
    def machine_code(self):
        """Whether the Γ3 Jacobian's integrand is compiled to machine code."""
        return self.boundary is not None and self.boundary.machine_code

    def use_machine_code(self):
        """From now on, assemble the Γ3 terms compiled to machine code (``Gamma3Terms``)."""
        if self.boundary is not None and self.boundary.use_machine_code():
            self._positions.clear()               # keyed by target; the new form's matrix has its own layout
            self._linearized = False

    # ----------------------------------------------------------------------- one step
    def begin_step(self, state):
        """Prepare the step the scheme has set (t_n, c, û of ``coefficients``): assemble
        f(t_n), c K_A x̂ and, when c changed, K (and its condensed form); set the supports'
        displacements and the electrode potentials at t_n in the ``state`` GridFunction (u, φ)."""
        t, rate = self.coefficients.t, self.coefficients.rate.Get()
        if rate != self._rate:
            K = parallel.local_matrix(self.K).AsVector()
            K.data = parallel.local_matrix(self.K_el.mat).AsVector()
            if self.K_A is not None:
                K.data += rate * parallel.local_matrix(self.K_A.mat).AsVector()
            if self.condense:
                self._K_condensed.Assemble()
            if self.laws is not None:
                self.laws.assemble_scales()
            self._absK = None
            self._rate = rate
            self.generation += 1
        self.f.Assemble()
        if parallel.any_rank(self.body.mesh, not np.all(np.isfinite(self.f.vec.FV().NumPy()))):
            culprit = self.loads.nonfinite(self.body) or "a load"
            raise ValueError(f"{culprit} is not finite at t = {t:.6g} s (NaN or inf)")
        self._constant.data = self.f.vec
        if self.K_A is not None:
            self._x_old.components[0].vec.data = self.coefficients.anchor.vec
            self._constant.data += rate * (self.K_A.mat * self._x_old.vec)
        self._set_displacements(state.components[0])
        phi = state.components[1]                              # φ on Γa (0 where not given)
        for names, value in self.loads.potential.items():
            self._set_on_boundary(("φ", names), phi, as_cf(value, 1, f"potential[{names!r}]"), names)
        if parallel.any_rank(self.body.mesh, not np.all(np.isfinite(state.vec.FV().NumPy()))):
            culprit = self.loads.nonfinite(self.body) or "a prescribed displacement or potential"
            raise ValueError(f"{culprit} is not finite at t = {t:.6g} s (NaN or inf)")

    def _set_displacements(self, u):
        """u on the supports at t_n: 0, then ``Loads.displacement`` (u·ν along an axis: that
        component times ν_i); Γ1 last, so that u = 0 at a vertex Γ1 shares with a support."""
        if not self.body.supports:
            return
        values = u.vec.FV().NumPy()
        values[self.held] = 0.0
        for key, value in self.loads.displacement.items():
            support = self.body.support_of(key)
            cf = as_cf(value, support.size, f"Loads.displacement[{key!r}]")
            for j, axis in enumerate(support.axes):
                self._set_on_boundary(("u", axis, key), u.components[axis],
                                      support.sign * (cf[j] if support.size > 1 else cf), key)
        values[self._clamped] = 0.0
        if self.body.axis:
            self._check_axis(u)

    def _check_axis(self, u):
        """A ValueError if a prescribed displacement moved u_r on the axis of a body of revolution
        off 0 at this step (where another support meets the axis: ``axisymmetric.check_loads``
        checks the data at the start, a value of time only here)."""
        radial = u.components[0]
        on = self._boundary_dofs.get("axis")
        if on is None:
            on = self._boundary_dofs["axis"] = np.array(
                list(radial.space.GetDofs(self.body.mesh.Boundaries("|".join(self.body.axis)))), dtype=bool)
        values = radial.vec.FV().NumPy()
        moved = np.abs(values[on]).max(initial=0.0)
        if parallel.any_rank(self.body.mesh, moved > 1e-12 * np.abs(values).max(initial=0.0) + 1e-300):
            keys = [key for key in self.loads.displacement if 0 in self.body.support_of(key).axes]
            raise ValueError(f"Loads.displacement{keys}: u_r = {moved:.6g} m on the axis r = 0 of the body of "
                             f"revolution at t = {self.coefficients.t:.6g} s, where u_r = 0 (the body would be torn "
                             "open along its axis); the radial value of a support that meets the axis must vanish "
                             "there at every time (e.g. proportional to x)")

    def _set_on_boundary(self, key, gf, cf, names):
        """gf = cf at the DOFs of the boundaries ``names`` (interpolated as ``GridFunction.Set``),
        every other DOF kept: NGSolve's ``gf.Set(cf, BND, definedon=...)`` zeroes them, which lost
        the warm start of every step with supports and, with two prescribed supports, the values
        of the first. The DOFs of each region are found once (``key``), not at every step."""
        region = self.body.mesh.Boundaries(names)
        on = self._boundary_dofs.get(key)
        if on is None:
            on = self._boundary_dofs[key] = np.array(list(gf.space.GetDofs(region)), dtype=bool)
        kept = gf.vec.FV().NumPy()[~on]
        gf.Set(cf, ngs.BND, definedon=region)
        gf.vec.FV().NumPy()[~on] = kept

    # ----------------------------------------------------------------------- BilinearForm protocol
    def Apply(self, x, r):
        """r = R(x)."""
        r.data = self.K * x
        r.data -= self._constant
        if self.laws is not None:
            r.data += self.laws.apply(x)
        self._internal.data = r + self.f.vec
        if self.boundary is not None:
            self.boundary_residual.data = self.boundary.residual(x)
            r.data += self.boundary_residual

    def AssembleLinearization(self, x):
        """``mat`` = R'(x) = K + R_Γ3'(x), or with ``condense`` its Schur complement on the
        coupling DOFs."""
        if self.condense:
            self._linearize_boundary(x)
            self.mat = self._add_to_condensed()
        else:
            self._assemble_full(x)

    def _linearize_boundary(self, x):
        if self.boundary is not None:
            self.boundary.linearize(x)
            self._linearized = True

    def _assemble_full(self, x):
        """The full Jacobian K + R_Γ3'(x) into ``_full`` (R_Γ3' added at the positions of
        its entries in K's pattern)."""
        self._linearize_boundary(x)
        parallel.local_matrix(self._full).AsVector().data = parallel.local_matrix(self.K).AsVector()
        if self.laws is not None:
            self.laws.add_tangent(x, parallel.local_matrix(self._full))
        if self.boundary is not None:
            self._add_boundary(self._full)

    def _add_boundary(self, target):
        """target += R_Γ3' (target: K's pattern, or the Schur complement's; the ranks' parts
        on a distributed mesh)."""
        target, boundary = parallel.local_matrix(target), parallel.local_matrix(self.boundary.mat)
        positions = self._positions.get(id(target))
        if positions is None:
            positions = self._positions[id(target)] = matching_positions(boundary, target, self.boundary.layer)
        source, into = positions
        target.AsVector().FV().NumPy()[into] += boundary.AsVector().FV().NumPy()[source]

    def changing_entries(self):
        """The positions among the values of ``mat`` (the last linearisation's) where the Γ3
        terms add: within one ``generation`` nothing else changes. None before the first."""
        positions = self._positions.get(id(parallel.local_matrix(self.mat)))
        return None if positions is None else positions[1]

    @property
    def harmonic_extension(self):
        return self._K_condensed.harmonic_extension

    @property
    def harmonic_extension_trans(self):
        return self._K_condensed.harmonic_extension_trans

    @property
    def inner_solve(self):
        return self._K_condensed.inner_solve

    def _add_to_condensed(self):
        """Schur complement of K + R_Γ3' (R_Γ3' has no entries on the condensed DOFs, so it
        adds to the Schur complement of K at matching positions)."""
        if self._schur is None:
            self._schur = self._K_condensed.mat.CreateMatrix()
        self._schur.AsVector().data = self._K_condensed.mat.AsVector()
        if self.boundary is not None:
            self._add_boundary(self._schur)
        return self._schur

    # ----------------------------------------------------------------------- for Newton's norms
    def force_scale(self, norm):
        """S = max(‖f_n‖, ‖K x − c K_A x̂‖) at the x of the last ``Apply``, in the
        scaled norm ``norm`` (a ``residual_norm.ResidualNorm``) over every DOF, held ones included:
        the step's loads and the bulk's internal forces (at held DOFs: the reactions of the
        supports and the charges of the electrodes), without the Γ3 terms (``stopping``)."""
        return max(norm.dual_everywhere(self.f.vec), norm.dual_everywhere(self._internal))

    def block_force_scales(self, norm):
        """[S_u, S_φ]: ``force_scale`` of each field on its own (forces, charges), J^½."""
        return [max(f, k) for f, k in zip(norm.block_duals(self.f.vec, everywhere=True),
                                          norm.block_duals(self._internal, everywhere=True))]

    def contact_magnitude(self, x):
        """|R_Γ3'| |x| (numpy, cumulated on a distributed mesh) with the Γ3 Jacobian of the
        last linearisation (zeros before any): the Γ3 part of ``magnitude``."""
        if not self._linearized:
            return np.zeros(len(x))
        size = np.abs(parallel.cumulated(x))
        total = Absolute(self.boundary.mat) @ size
        if parallel.is_distributed(self.body.mesh):
            return parallel.distributed_values(self._constant, total)
        return total

    def bulk_diagonal(self):
        """The diagonal of the bulk's K = K_el + c K_A (numpy, cumulated on a distributed
        mesh): the scales of Newton's norms come from it (``residual_norm.ResidualNorm``), not from the
        Γ3 terms, so that a stiff contact term cannot set the units it is expressed in."""
        diagonal = matrix_diagonal(self.K)
        if self.laws is not None:                             # the laws' tangents at 0
            diagonal = diagonal + self.laws.diagonal()
        if parallel.is_distributed(self.body.mesh):          # the ranks' parts of the diagonal
            diagonal = parallel.distributed_values(self._constant, diagonal)
        return diagonal

    def magnitude(self, x, contact=None):
        """|K| |x| + |f + c K_A x̂| + |R_Γ3'| |x| (numpy), with the Γ3 Jacobian of the
        last linearisation (``contact``: ``contact_magnitude(x)`` if already computed): the size
        of the terms that sum to R(x), whose round-off limits how far Newton can reduce it. On a
        distributed mesh (cumulated values) |K| is the sum of the ranks' |K_p|, an upper bound of
        |K| at interface DOFs."""
        if self._absK is None:
            self._absK = Absolute(self.K)
        bulk = self._absK @ np.abs(parallel.cumulated(x))
        if self.laws is not None:
            bulk = bulk + self.laws.magnitude(parallel.cumulated(x))
        if parallel.is_distributed(self.body.mesh):
            bulk = parallel.distributed_values(self._constant, bulk)
        return bulk + np.abs(parallel.cumulated(self._constant)) + \
            (self.contact_magnitude(x) if contact is None else contact)

    @property
    def uncondensed(self):
        """This system without static condensation (``mat`` is the full Jacobian): for a
        solve in part of the unknowns, such as the potential at t = 0."""
        return self if not self.condense else _Uncondensed(self)


class _Uncondensed:
    """A StepSystem's residual and full Jacobian, whatever its ``condense``."""

    condense = False

    def __init__(self, system):
        self.Apply, self.bulk_diagonal, self.magnitude = system.Apply, system.bulk_diagonal, system.magnitude
        self.force_scale, self.contact_magnitude = system.force_scale, system.contact_magnitude
        self.AssembleLinearization, self.mat = system._assemble_full, system._full

