"""GMRES preconditioned by multigrid on nested meshes: the linear solver of large 3D steps.

A sparse direct factorisation of a 3D step Jacobian fills in like n^(4/3) in memory and n²
in time; this solver needs O(n) of both. The step Jacobian (``system``)

  J = [[K_uu + J_Γ3,uu,  Eᵀ + J_Γ3,uφ], [E + J_Γ3,φu,  −C + J_Γ3,φφ]]

is non-symmetric (glue, conduction) and indefinite (the negated electric equation). GMRES
(``krylov``, in Newton's block-scaled inner product: u in m and φ in V differ by ~10⁹ in the
Jacobian's entries, and unscaled GMRES stagnates) is preconditioned by

  M = the Γ3 – bulk – Γ3 method of ``gamma3_bulk`` on NGSolve's parts:
      S: an exact (UMFPACK) solve of J on the free DOFs of the Γ3 facets,
      B: block-diagonal diag(MG_u, −MG_φ): NGSolve's ``Preconditioner(form, "multigrid")``
         (V-cycles on the nested meshes, a direct solve on the coarsest mesh) for P1, its
         "bddc" for P2 and higher (``bulk_kind``), for the SPD forms

           u: (F̃ ε(u), ε(v)) + c (A ε(u), ε(v)),  F̃ = F + Eᵀ C⁻¹ E (piezo-stiffened),
              (c the time scheme's rate coefficient, 1/dt for backward Euler)
           φ: (C ∇φ, ∇ξ),

  y = S r;  y += B (r − J y);  y += S (r − J y).

On the 3D reference block (P1, first-contact window, ``bench --dim 3``) the GMRES iterations
per Newton iteration grow slowly with each level of refinement, and at a contact state the bulk
preconditioner alone (no S) needs far more than S B S (docs/scale.md).

NGSolve's multigrid needs the space to exist on the coarse mesh and be updated at every
refinement. The body's spaces are made on the refined mesh, so the preconditioner builds its
own hierarchy on a replica: a copy of the coarse mesh refined the same number of times, whose
DOFs are numbered as the body's (checked: the vertices must coincide). A mesh carries its
coarse mesh when made by ``meshes.nested_mesh`` (``ngcontact.geometries`` use it).
"""
import time as wallclock

import ngsolve as ngs
import numpy as np

from ngcontact.model import forms
from ngcontact.solve.linalg import gamma3_bulk
from ngcontact.solve.linalg.krylov import Gmres
from ngcontact.solve.linalg.linear_solver import untimed
from ngcontact.model.supports import dirichlet_flags
from ngcontact.model.machine_code import compiled
from ngcontact.meshes import COARSE, nested_mesh, refinements  # noqa: F401  (nested_mesh: the documented place of old)

def bulk_kind(body):
    """The bulk preconditioner of ``body``'s fields: "multigrid" when u or φ is P1 (BDDC's
    coarse space would be the whole P1 space), else NGSolve's "bddc" (P2 block, GMRES with
    S B S: fewer iterations than with multigrid, whatever its smoother, and as few on the finer
    mesh; docs/scale.md)."""
    return "multigrid" if min(body.order, body.order_phi) == 1 else "bddc"


def needs_nested_mesh(body):
    """True if the bulk preconditioner is multigrid (``bulk_kind``), which needs nested meshes."""
    return bulk_kind(body) == "multigrid"


class Hierarchy:
    """The bulk preconditioners B of the u and φ forms (module docstring) at the time scheme's
    rate coefficient c = ``rate`` (1/s; 1/dt for backward Euler), on V and W of ``body``: for
    multigrid (``bulk_kind``) on the replica hierarchy, a copy of the coarse mesh refined as the
    body's; for BDDC on the body's own mesh (one level). ``set_rate`` changes c on the finest level only: the
    coarse levels keep the first one (a spectrally equivalent coarse correction: the viscous
    term scales the elastic one by 1 + τ/dt for Kelvin-Voigt A = τF), which saves rebuilding
    the hierarchy at a cut-back. ``realcompile``: compile the integrands to machine code (for the
    3D Voigt-matrix integrands: docs/measurements.md, section
    ngcontact/solve/linalg/multigrid.py). ``displacement=False``: the φ part only
    (the potential at t = 0 solves for φ with u held: no u hierarchy, larger than the φ
    one, is built for it; ``pre_u`` is then None)."""

    def __init__(self, body, rate, realcompile=False, displacement=True):
        self.kind = bulk_kind(body)
        kept = body.hierarchy
        if self.kind != "bddc" and kept is None:
            raise ValueError("the multigrid solver needs nested meshes: build the mesh with "
                             "ngcontact.meshes.nested_mesh(ngmesh, refine) (ngcontact.geometries do), or give "
                             "Body(hierarchy=...)")
        levels = iter([body.mesh]) if self.kind == "bddc" else kept.levels()     # one mesh refined in place
        self.mesh = next(levels)
        self.V = ngs.VectorH1(self.mesh, order=body.order,
                              **dirichlet_flags(body.boundaries["clamped"], body.supports, body.dim))
        self.W = ngs.H1(self.mesh, order=body.order_phi, dirichlet=body.region_names("grounded"))
        (u, v), (phi, xi) = self.V.TnT(), self.W.TnT()
        self.rate = ngs.Parameter(rate)
        integrand, phi_integrand = forms.preconditioner_forms(body, u, v, phi, xi, self.rate)
        self.form_u = self.pre_u = None
        if displacement:
            self.form_u = ngs.BilinearForm(self.V, symmetric=True)
            self.form_u += body.kinematics.dx(compiled(integrand, realcompile))
            self.pre_u = ngs.Preconditioner(self.form_u, self.kind)
        self.form_phi = ngs.BilinearForm(self.W, symmetric=True)
        self.form_phi += body.kinematics.dx(compiled(phi_integrand, realcompile))
        self.pre_phi = ngs.Preconditioner(self.form_phi, self.kind)
        self._assemble()
        self.levels = 1
        for _ in levels:
            self.V.Update()
            self.W.Update()
            self._assemble()
            self.levels += 1
        if self.kind != "bddc":
            kept.check(self.mesh, body.mesh, body.size, "the multigrid solver")
        if self.V.ndof + self.W.ndof != body.ndof:
            raise ValueError(f"the multigrid replica has {self.V.ndof + self.W.ndof} DOFs, the body {body.ndof}")

    def _assemble(self):
        if self.form_u is not None:
            self.form_u.Assemble()
        if self.W.ndof:
            self.form_phi.Assemble()

    def set_rate(self, rate):
        """c (1/s) of the u form's finest level (module docstring)."""
        if rate != self.rate.Get():
            self.rate.Set(rate)
            if self.form_u is not None:
                self.form_u.Assemble()


class Preconditioner(ngs.BaseMatrix):
    """M ≈ J⁻¹ on the free DOFs (module docstring): Γ3 solve, block multigrid, Γ3 solve; the
    ``gamma3_bulk.Parts`` of NGSolve's vectors."""

    def __init__(self, hierarchy, matrix, freedofs, layer, electric, free=None):
        super().__init__()
        self.hierarchy, self.matrix, self.electric = hierarchy, matrix, electric
        self.n_u = hierarchy.V.ndof
        self.free = np.array(list(freedofs), dtype=bool) if free is None else free    # numpy mask of freedofs
        self.solver = matrix.Inverse(layer, inverse="umfpack") if layer.NumSet() else None
        self.surface = self.solver is not None
        self._u_in, self._u_out = (ngs.GridFunction(hierarchy.V).vec for _ in range(2))
        self._phi_in, self._phi_out = (ngs.GridFunction(hierarchy.W).vec for _ in range(2))
        self._defect = matrix.CreateColVector()

    def IsComplex(self):
        return False

    def Height(self):
        return self.matrix.height

    def Width(self):
        return self.matrix.width

    def clear(self, y):
        y[:] = 0.0

    def surface_solve(self, r, y):
        y.data = self.solver * r

    def defect(self, r, y):
        self._defect.data = r - self.matrix * y
        return self._defect

    surface_defect = defect

    def add_surface(self, s, y):
        y.data += self.solver * s

    def add_bulk(self, x, y):
        """y += diag(MG_u, −MG_φ) x on the free DOFs."""
        values, out, n_u, free = x.FV().NumPy(), y.FV().NumPy(), self.n_u, self.free
        if self.hierarchy.pre_u is not None:
            self._u_in.FV().NumPy()[:] = values[:n_u]
            self._u_out.data = self.hierarchy.pre_u.mat * self._u_in
            out[:n_u] += np.where(free[:n_u], self._u_out.FV().NumPy(), 0.0)
        if self.electric:
            self._phi_in.FV().NumPy()[:] = values[n_u:]
            self._phi_out.data = self.hierarchy.pre_phi.mat * self._phi_in
            out[n_u:] -= np.where(free[n_u:], self._phi_out.FV().NumPy(), 0.0)

    def Mult(self, x, y):
        gamma3_bulk.apply(self, x, y)


class MultigridSolver:
    """w = J⁻¹ r by GMRES preconditioned with ``Preconditioner``: the linear solver protocol
    of ``linear_solver`` (``solve(matrix, freedofs, r, w, generation, timer, weights, tol)``,
    counters ``factorizations`` (of the Γ3 surface problem, one per solve),
    ``krylov_iterations``, ``krylov_failures``).

    Parameters
    ----------
    body : the Body (its mesh made by ``nested_mesh``).
    system : the StepSystem (its ``coefficients.rate``, 1/s); when its ``generation`` (the
        rate coefficient, with the time step) changes, the finest level takes the new c
        (``Hierarchy.set_rate``).
    layer : BitArray of the DOFs on the Γ3 facets (``ContactSide``), or None.
    electric : whether φ is an unknown.
    tol : GMRES's relative reduction of the preconditioned residual (Newton asks for less
        where that suffices, inexact Newton).
    maxiter : GMRES iterations before a solve counts as failed (its best iterate is used).
    realcompile : compile the hierarchy's integrands to machine code.
    displacement : whether u has free DOFs in the solves (False for the potential at t = 0:
        the hierarchy of the φ form only).

    ``margin`` (0.1): Newton asks GMRES for ``margin`` × (its target / its residual)
    (``newton.Newton``): on the 3D block 0.1 takes the same Newton iterations as 1e-3 and fewer
    GMRES iterations (docs/measurements.md, section ngcontact/solve/linalg/multigrid.py).
    """

    margin = 0.1

    def __init__(self, body, system, layer=None, *, electric=True, tol=1e-8, maxiter=300, realcompile=False,
                 displacement=True):
        self.body, self.system, self.layer, self.electric = body, system, layer, electric
        self.displacement = displacement
        self.realcompile = realcompile
        self.tol, self.maxiter = tol, int(maxiter)
        self.factorizations = self.krylov_iterations = self.krylov_failures = 0
        self.hierarchy, self._generation = None, None
        self._krylov = Gmres()
        self._masks = (None, None, None)       # (freedofs, its numpy mask, its Γ3 DOFs)
        self.setup_s = 0.0                     # wall time of building hierarchies, s

    @property
    def name(self):
        if bulk_kind(self.body) == "bddc":
            return "GMRES preconditioned by Γ3 solves around block BDDC"
        levels = f"{self.hierarchy.levels} levels" if self.hierarchy else "nested meshes"
        return f"GMRES preconditioned by Γ3 solves around block multigrid ({levels})"

    def solve(self, matrix, freedofs, r, w, generation=None, timer=untimed, weights=None, tol=None, changing=None):
        """w = J⁻¹ r to the relative accuracy ``tol`` (default: the solver's) in the
        ``weights`` norm of the preconditioned residual."""
        with timer("factorization"):
            if self.hierarchy is None or generation != self._generation:
                start = wallclock.perf_counter()
                if self.hierarchy is None:
                    self.hierarchy = Hierarchy(self.body, self.system.coefficients.rate.Get(), self.realcompile,
                                               self.displacement)
                else:
                    self.hierarchy.set_rate(self.system.coefficients.rate.Get())
                self._generation = generation
                self.setup_s += wallclock.perf_counter() - start
            if self._masks[0] is not freedofs:
                self._masks = (freedofs, np.array(list(freedofs), dtype=bool),
                               freedofs if self.layer is None else self.layer & freedofs)
            _, free, layer = self._masks
            pre = Preconditioner(self.hierarchy, matrix, freedofs, layer, self.electric, free)
            self.factorizations += 1
        with timer("solve"):
            converged, iterations, _ = self._krylov.solve(matrix, freedofs, pre, r, w, weights,
                                                          self.tol if tol is None else tol, self.maxiter)
        self.krylov_iterations += iterations
        if not converged:
            self.krylov_failures += 1

    def __repr__(self):
        return f"MultigridSolver(tol={self.tol}, maxiter={self.maxiter})"
