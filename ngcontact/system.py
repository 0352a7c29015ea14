"""The nonlinear system of one backward Euler step, assembled in parts.

The bulk of (4.6)-(4.7) is linear with constant coefficients: with the two matrices

  K_el : b(u, v) + e(v, φ) + e(u, ξ) − c(φ, ξ)   (F, E, C; the electric equation negated),
  K_A  : a(u, v)                                  (A, the Kelvin-Voigt viscosity),

assembled once, the step residual at x = (u, φ) is

  R(x) = K_el x + (1/k) K_A (x − x_{n−1}) − f(t_n) + R_Γ3(x),

where only R_Γ3, the contact terms on Γ3, is nonlinear. Its Jacobian is
K_el + (1/k) K_A + R_Γ3'(x): each Newton iteration assembles the Γ3 terms only and adds
matrices of one sparsity pattern. ``StepSystem`` has the interface ``Newton`` uses of a
nonlinear ``BilinearForm`` (``Apply``, ``AssembleLinearization``, ``mat``).

Static condensation (``condense=True``): the element-interior DOFs of the elements away
from Γ3 appear in K only, so they are eliminated once per time step size by a condensed
form of K; the Newton matrix is then the Schur complement of K plus R_Γ3' on the remaining
DOFs (the interior DOFs of the elements at Γ3 are kept as coupling DOFs).
"""
import warnings

import ngsolve as ngs
import numpy as np

from .forms import electric_displacement, matrix_cf, strain, stress
from .loads import as_cf


def bulk_forms(body, inv_dt=None, condense=False):
    """The BilinearForms of K_el and K_A (not assembled; K_A is None without viscosity), or,
    given the Parameter ``inv_dt``, the one form K = K_el + (1/k) K_A."""
    dim, T = body.dim, body.tensors
    (u, phi), (v, xi) = body.X.TnT()
    elastic = (ngs.InnerProduct(stress(T, u, phi, dim), strain(v, dim))
               + ngs.InnerProduct(electric_displacement(T, u, phi, dim), ngs.grad(xi)))
    viscous = ngs.InnerProduct(matrix_cf(T.A) * strain(u, dim), strain(v, dim)) if T.viscous else None
    if inv_dt is not None:
        K = ngs.BilinearForm(body.X, symmetric=False, condense=condense)
        K += (elastic + inv_dt * viscous if viscous is not None else elastic) * ngs.dx
        return K
    K_el = ngs.BilinearForm(body.X, symmetric=False)
    K_el += elastic * ngs.dx
    if viscous is None:
        return K_el, None
    K_A = ngs.BilinearForm(body.X, symmetric=False)
    K_A += viscous * ngs.dx
    return K_el, K_A


def keep_interior_dofs(body, region):
    """Mark the element-interior (LOCAL) DOFs of the volume elements with a facet in the
    boundary ``region`` as coupling DOFs of body.X, so that condensation leaves them."""
    X, mesh = body.X, body.mesh
    facets = {f.nr for el in region.Elements() for f in (el.edges if body.dim == 2 else el.faces)}
    for nr in facets:
        for element in mesh.facets[nr].elements:
            for dof in X.GetDofNrs(element):
                if dof >= 0 and X.CouplingType(dof) == ngs.COUPLING_TYPE.LOCAL_DOF:
                    X.SetCouplingType(dof, ngs.COUPLING_TYPE.INTERFACE_DOF)
    X.FinalizeUpdate()                                      # recomputes FreeDofs(coupling=True)


def has_interior_dofs(space):
    """True if ``space`` has free element-interior DOFs, which static condensation eliminates."""
    return space.FreeDofs(coupling=True).NumSet() < space.FreeDofs().NumSet()


def load_form(body, loads):
    """f(t): the LinearForm of the loads f0, f2 (on v) and q0, qb (on ξ)."""
    dim, mesh = body.dim, body.mesh
    v, xi = body.X.TestFunction()
    f = ngs.LinearForm(body.X)
    if loads.f0 is not None:
        f += as_cf(loads.f0, dim, "f0") * v * ngs.dx
    if loads.q0 is not None:
        f += as_cf(loads.q0, 1, "q0") * xi * ngs.dx
    for names, f2 in loads.f2.items():
        f += as_cf(f2, dim, f"f2[{names!r}]") * v * ngs.ds(mesh.Boundaries(names))
    for names, qb in loads.qb.items():
        f += as_cf(qb, 1, f"qb[{names!r}]") * xi * ngs.ds(mesh.Boundaries(names))
    return f


class StepSystem:
    """R(x) and its Jacobian for a Body under Loads.

    Parameters
    ----------
    body, loads : Body and Loads (CoefficientFunctions of the ``time`` Parameter).
    u_old : GridFunction of u_{n−1} on body.V.
    inv_dt, time : Parameters holding 1/k (1/s) and t_n (s).

    condense : static condensation of the interior DOFs away from ``kept`` (a boundary
        region, Γ3); marks the interior DOFs of the elements at ``kept`` as coupling DOFs of
        body.X. Then ``AssembleLinearization(x, condensed=True)`` sets ``condensed_mat`` and
        ``K_condensed`` offers ``harmonic_extension``, ``harmonic_extension_trans`` and
        ``inner_solve`` (as a condensed BilinearForm does).

    ``add_boundary_terms(terms, ds)`` adds a (nonlinear) Γ3 part. ``begin_step()``
    assembles f(t_n) and (1/k) K_A x_{n−1}; it is called again by ``Apply`` when t_n or
    1/k changed. ``boundary_residual`` holds R_Γ3 at the last ``Apply``.
    """

    def __init__(self, body, loads, u_old, inv_dt, time, *, condense=False, kept=None):
        self.body, self.u_old, self.inv_dt, self.time = body, u_old, inv_dt, time
        self.condense = bool(condense)
        if self.condense and kept is not None:
            keep_interior_dofs(body, kept)
        self.K_el, self.K_A = bulk_forms(body)
        for form in (self.K_el, self.K_A):
            if form is not None:
                form.Assemble()
        if self.condense:
            self.K_condensed = bulk_forms(body, inv_dt, condense=True)
            self.condensed_mat = None
        self.f = load_form(body, loads)
        self.K = self.K_el.mat.CreateMatrix()
        self.mat = self.K_el.mat.CreateMatrix()
        self.boundary = None
        self._x_old = ngs.GridFunction(body.X)
        self._constant = self._x_old.vec.CreateVector()       # f + (1/k) K_A x_{n−1}
        self.boundary_residual = self._x_old.vec.CreateVector()
        self.boundary_residual[:] = 0.0
        self._stamp = None
        self.begin_step()

    def add_boundary_terms(self, terms, ds, realcompile=False):
        """Add ∫ terms(u, φ) ds to R: ``terms(u, φ)`` is the integrand (linear in the test
        functions) for the state (u, φ). Its Jacobian comes from a BilinearForm in the trial
        functions; R_Γ3 itself from a LinearForm in a copy of the state, whose assembly is
        about as fast as the Jacobian's where the BilinearForm's Apply is not (under
        TaskManager, ds(skeleton=True))."""
        if self.boundary is None:
            self.boundary = ngs.BilinearForm(self.body.X, symmetric=False)
            self.state = ngs.GridFunction(self.body.X)
            self._boundary_linear = ngs.LinearForm(self.body.X)
        self.boundary += _compiled(terms(*self.body.X.TrialFunction()), realcompile) * ds
        self._boundary_linear += terms(*self.state.components).Compile() * ds

    def begin_step(self):
        """Assemble the parts fixed during a step: f(t_n), (1/k) K_A x_{n−1} and K."""
        inv_dt = self.inv_dt.Get()
        if self._stamp is None or self._stamp[1] != inv_dt:
            self.K.AsVector().data = self.K_el.mat.AsVector()
            if self.K_A is not None:
                self.K.AsVector().data += inv_dt * self.K_A.mat.AsVector()
            if self.condense:
                self.K_condensed.Assemble()
        self.f.Assemble()
        self._constant.data = self.f.vec
        if self.K_A is not None:
            self._x_old.components[0].vec.data = self.u_old.vec
            self._constant.data += inv_dt * (self.K_A.mat * self._x_old.vec)
        self._stamp = (self.time.Get(), inv_dt)

    def _refresh(self):
        if self._stamp != (self.time.Get(), self.inv_dt.Get()):
            self.begin_step()

    def Apply(self, x, r):
        """r = R(x)."""
        self._refresh()
        r.data = self.K * x
        r.data -= self._constant
        if self.boundary is not None:
            self.state.vec.data = x
            self._boundary_linear.Assemble()
            self.boundary_residual.data = self._boundary_linear.vec
            r.data += self.boundary_residual

    def AssembleLinearization(self, x, condensed=False):
        """``mat`` = R'(x) = K + R_Γ3'(x); ``condensed=True``: ``condensed_mat`` = its Schur
        complement on the coupling DOFs."""
        self._refresh()
        if self.boundary is not None:
            self.boundary.AssembleLinearization(x)
        if condensed:
            self._add_to_condensed()
        elif self.boundary is None:
            self.mat.AsVector().data = self.K.AsVector()
        else:
            self.mat.AsVector().data = self.K.AsVector() + self.boundary.mat.AsVector()

    def _add_to_condensed(self):
        """condensed_mat = Schur complement of K + R_Γ3' (R_Γ3' has no entries on the
        condensed DOFs, so it adds to the Schur complement of K at matching positions)."""
        target = self.K_condensed.mat
        if self.condensed_mat is None:
            self.condensed_mat = target.CreateMatrix()
            self._positions = _matching_positions(self.boundary.mat, target) if self.boundary else None
        values = self.condensed_mat.AsVector().FV().NumPy()
        values[:] = target.AsVector().FV().NumPy()
        if self.boundary is not None:
            source, into = self._positions
            values[into] += self.boundary.mat.AsVector().FV().NumPy()[source]


def _compiled(cf, realcompile):
    """cf.Compile(), to machine code if ``realcompile`` (falls back, with a warning, when
    there is no working C++ compiler)."""
    if realcompile:
        try:
            return cf.Compile(realcompile=True, wait=True)
        except Exception as err:                               # NGSolve raises a plain Exception
            warnings.warn(f"realcompile failed ({err}); using Compile()", RuntimeWarning)
    return cf.Compile()


def _matching_positions(source, target):
    """Index arrays (s, t): entry s of ``source``'s values sits at entry t of ``target``'s,
    for the structural entries of ``source`` that ``target`` has."""
    def keys(matrix):
        _, cols, ptr = matrix.CSR()
        rows = np.repeat(np.arange(matrix.height, dtype=np.int64), np.diff(np.asarray(ptr, dtype=np.int64)))
        return rows * matrix.width + np.asarray(cols, dtype=np.int64)
    s, t = keys(source), keys(target)
    where = np.clip(np.searchsorted(t, s), 0, len(t) - 1)
    found = t[where] == s
    return np.flatnonzero(found), where[found]
