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
"""
import ngsolve as ngs

from .forms import electric_displacement, matrix_cf, strain, stress
from .loads import as_cf


def bulk_forms(body):
    """The BilinearForms of K_el and K_A (not assembled); K_A is None without viscosity."""
    dim, T = body.dim, body.tensors
    (u, phi), (v, xi) = body.X.TnT()
    K_el = ngs.BilinearForm(body.X, symmetric=False)
    K_el += (ngs.InnerProduct(stress(T, u, phi, dim), strain(v, dim))
             + ngs.InnerProduct(electric_displacement(T, u, phi, dim), ngs.grad(xi))) * ngs.dx
    if not T.viscous:
        return K_el, None
    K_A = ngs.BilinearForm(body.X, symmetric=False)
    K_A += ngs.InnerProduct(matrix_cf(T.A) * strain(u, dim), strain(v, dim)) * ngs.dx
    return K_el, K_A


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

    ``add_boundary_terms(integrand, ds)`` adds a (nonlinear) Γ3 part. ``begin_step()``
    assembles f(t_n) and (1/k) K_A x_{n−1}; it is called again by ``Apply`` when t_n or
    1/k changed. ``boundary_residual`` holds R_Γ3 at the last ``Apply``.
    """

    def __init__(self, body, loads, u_old, inv_dt, time):
        self.body, self.u_old, self.inv_dt, self.time = body, u_old, inv_dt, time
        self.K_el, self.K_A = bulk_forms(body)
        for form in (self.K_el, self.K_A):
            if form is not None:
                form.Assemble()
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

    def add_boundary_terms(self, integrand, ds):
        """Add ∫ integrand ds (nonlinear in the trial functions) to R; ``integrand`` should
        be compiled."""
        if self.boundary is None:
            self.boundary = ngs.BilinearForm(self.body.X, symmetric=False)
        self.boundary += integrand * ds

    def begin_step(self):
        """Assemble the parts fixed during a step: f(t_n), (1/k) K_A x_{n−1} and K."""
        inv_dt = self.inv_dt.Get()
        if self._stamp is None or self._stamp[1] != inv_dt:
            self.K.AsVector().data = self.K_el.mat.AsVector()
            if self.K_A is not None:
                self.K.AsVector().data += inv_dt * self.K_A.mat.AsVector()
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
            self.boundary.Apply(x, self.boundary_residual)
            r.data += self.boundary_residual

    def AssembleLinearization(self, x):
        """``mat`` = R'(x) = K + R_Γ3'(x)."""
        self._refresh()
        if self.boundary is None:
            self.mat.AsVector().data = self.K.AsVector()
            return
        self.boundary.AssembleLinearization(x)
        self.mat.AsVector().data = self.K.AsVector() + self.boundary.mat.AsVector()
