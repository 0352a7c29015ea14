"""The semi-discrete system of a glued body lifted off an open Γ3, written independently of
ngcontact's step machinery: P1 in space, continuous in time, a stiff ODE for SciPy's Radau.

The same mesh and P1 spaces as a ``Body`` (u ∈ V^h zero on Γ1, φ ∈ W^h zero on Γa, β ∈ B^h
piecewise constant on the facets of Γ3, (4.1)), the weak form (2.30)-(2.32) of
docs/model.md with no contact stress (Γ3 open: u_ν < g, σ̃_ν = 0), no compliant layer
(p = 0), no conduction (ψ = 0) and no charges:

  (2.30)  K_A u̇ + K_b u + K_eᵀ φ + G(u, β) = f(t),
  (2.31)  K_e u − K_c φ = 0,
  (2.9)   β̇_f = −[β_f a_f(u) − ε_a]_+,   a_f(u) = (1/|f|) ∫_f γ_ν R_ν(u_ν)² da   (P_B),

with K_A = a(·,·) (Pa·s), K_b = b(·,·) (Pa), K_c = c(·,·), K_e the matrix of e(u, ξ),
f(t) = ∫ f0(t)·v dx, and the glue G_i(u, β) = ∫_Γ3 (−γ_ν β² R_ν(u_ν)) v_ν,i da (the
integrand of j_a (2.28) with p = 0), R_ν(s) = L for s < −L, −s on [−L, 0], 0 for s > 0.
φ has no time derivative and enters linearly: it is eliminated exactly, φ = K_c⁻¹ K_e u,
which leaves the ODE

  u̇ = K_A⁻¹ (f(t) − S u − G(u, β)),   S = K_b + K_eᵀ K_c⁻¹ K_e   (the open-circuit stiffness),
  β̇ = −[β a(u) − ε_a]_+,   u(0) = 0,  β(0) = β0.

Nothing of ngcontact's forms, spaces, Γ3 machinery or schemes is used: the matrices are
assembled here from the material tensors (Voigt, engineering shear: ``Body.tensors``), the Γ3
integrals are computed here from the facets' vertices, so that a mistake in ngcontact shows as
a disagreement. ``quadrature="exact"`` integrates the Γ3 terms exactly (each facet split where
u_ν crosses −L or 0; Gauss–Legendre with 2 points on each piece, exact for the piecewise
quadratic integrands); ``quadrature=(n_glue, n_beta)`` uses n-point Gauss–Legendre on the
whole facet instead (NGSolve's default orders give ngcontact (2, 3): its residual's Γ3 terms at
order 2p, P_B at order 2p + 2), the same semi-discrete system as ngcontact's where a kink of
R_ν lies inside a facet.

2D (plane strain, per metre of depth), P1, Γ1 = Γa only. Units SI: u in m, φ in V, t in s.

``backward_euler`` and ``bdf2`` step this system by the fully discrete schemes of
``ngcontact.schemes`` (re-derived from their formulas, solved by a Newton iteration of their
own), for checking ngcontact step by step; ``radau`` integrates it with ``solve_ivp``.
"""
import numpy as np
import ngsolve as ngs
import scipy.linalg as sla
from scipy.integrate import solve_ivp


def check_quadrature(quadrature):
    """``quadrature`` if it is "exact" or (n_glue, n_beta), two integers >= 1; else a ValueError."""
    if isinstance(quadrature, str) and quadrature == "exact":
        return quadrature
    if not (isinstance(quadrature, tuple) and len(quadrature) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in quadrature)):
        raise ValueError(f"quadrature must be 'exact' or (n_glue, n_beta), two integers >= 1, got {quadrature!r}")
    return quadrature


def _voigt_strain(u):
    """(ε11, ε22, 2ε12) of a 2D vector field (trial or test function)."""
    g = ngs.Grad(u)
    return ngs.CF((g[0, 0], g[1, 1], g[0, 1] + g[1, 0]))


def _dense(form, rows, cols):
    """The assembled BilinearForm as a dense array on the free rows × free columns."""
    return form.mat.ToDense().NumPy()[np.ix_(rows, cols)]


def _matrix(M):
    return ngs.CF(tuple(float(v) for v in np.asarray(M).flat), dims=np.shape(M))


def _rule(n):
    """n-point Gauss–Legendre on [0, 1]: (points, weights summing to 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


class SemiDiscreteColumn:
    """The ODE of the module docstring on the mesh of ``body``.

    Parameters
    ----------
    body : ngcontact.Body, 2D, order 1, with Γ1 (clamped), Γa (grounded) and Γ3 (contact_side);
        only its mesh, boundary names and material tensors are read.
    contact : ngcontact.Contact; only adhesion γ_ν (Pa/m), bond_length L (m), eps_a (1/s) and a
        number beta0 are read. A compliant layer (p ≠ 0) or a conductive foundation is refused:
        they are not part of this system.
    force : t (s, a float) ↦ the vertical body force f0_y (N/m³), uniform in space.
    quadrature : "exact", or (n_glue, n_beta) Gauss–Legendre points per facet (module docstring).

    Attributes: ``n_u`` (free u DOFs), ``n_beta`` (facets of Γ3), ``midpoints`` (facets × 2, m),
    ``scale`` (m: u is integrated as u/scale, scale = L).
    """

    def __init__(self, body, contact, force, quadrature="exact"):
        mesh = body.mesh
        if mesh.dim != 2 or body.order != 1 or body.order_phi != 1:
            raise ValueError(f"SemiDiscreteColumn is 2D P1 only, got dim {mesh.dim}, order ({body.order}, "
                             f"{body.order_phi})")
        if body.supports:
            raise ValueError(f"SemiDiscreteColumn takes Γ1 only, got supports {[s.key for s in body.supports]}")
        if callable(contact.compliance) or contact.compliance != 0:
            raise ValueError(f"SemiDiscreteColumn has no compliant layer: Contact.compliance must be 0, "
                             f"got {contact.compliance!r}")
        if contact.conducts:
            raise ValueError(f"SemiDiscreteColumn has no conduction: Contact.conductance must be 0, "
                             f"got {contact.conductance!r}")
        if not isinstance(contact.beta0, (int, float)):
            raise TypeError(f"SemiDiscreteColumn takes a number beta0, got {type(contact.beta0).__name__}")
        self.quadrature = check_quadrature(quadrature)
        self.gamma, self.L, self.eps_a = float(contact.adhesion), float(contact.bond_length), float(contact.eps_a)
        self.beta0 = float(contact.beta0)
        self.force = force
        self.scale = self.L
        T = body.tensors
        clamped, grounded = "|".join(body.boundaries["clamped"]), "|".join(body.boundaries["grounded"])
        self.V = V = ngs.VectorH1(mesh, order=1, dirichlet=clamped)
        self.W = W = ngs.H1(mesh, order=1, dirichlet=grounded)
        self.free_u = np.flatnonzero(np.array(list(V.FreeDofs()), dtype=bool))
        self.free_phi = np.flatnonzero(np.array(list(W.FreeDofs()), dtype=bool))
        self.n_u = len(self.free_u)
        u, v = V.TnT()
        phi, xi = W.TnT()
        forms = {}
        for name, (trial_space, test_space, integrand) in dict(
                A=(V, V, ngs.InnerProduct(_matrix(T.A) * _voigt_strain(u), _voigt_strain(v))),
                b=(V, V, ngs.InnerProduct(_matrix(T.F) * _voigt_strain(u), _voigt_strain(v))),
                c=(W, W, ngs.InnerProduct(_matrix(T.C) * ngs.grad(phi), ngs.grad(xi))),
                e=(V, W, ngs.InnerProduct(_matrix(T.E) * _voigt_strain(u), ngs.grad(xi)))).items():
            form = ngs.BilinearForm(trialspace=trial_space, testspace=test_space)
            form += integrand * ngs.dx
            form.Assemble()
            forms[name] = form
        fu, fp = self.free_u, self.free_phi
        self.K_A = _dense(forms["A"], fu, fu)
        K_b = _dense(forms["b"], fu, fu)
        self.K_e = _dense(forms["e"], fp, fu)                    # rows ξ, columns u: e(u, ξ)
        self.K_c = _dense(forms["c"], fp, fp)
        self._c_factor = sla.cho_factor(self.K_c)
        self.S = K_b + self.K_e.T @ sla.cho_solve(self._c_factor, self.K_e)
        self._A_factor = sla.cho_factor(self.K_A)
        self._AinvS = sla.cho_solve(self._A_factor, self.S)
        load = ngs.LinearForm(V)
        load += v[1] * ngs.dx
        load.Assemble()
        self.load = load.vec.FV().NumPy()[fu].copy()            # ∫ v_y dx per free DOF (m²)
        self._facets(mesh, body.boundaries["contact_side"])

    # ------------------------------------------------------------------ geometry of Γ3
    def _facets(self, mesh, names):
        """Per facet of Γ3: length, outward normal, and the free-DOF indices (−1: held) of
        (vertex a x, a y, vertex b x, b y)."""
        position = {int(d): i for i, d in enumerate(self.free_u)}
        points = np.array([p.point for p in mesh.vertices])
        lengths, normals, dofs, mids = [], [], [], []
        for el in mesh.Elements(ngs.BND):
            if el.mat not in names:
                continue
            a, b = (vertex.nr for vertex in el.vertices)
            (volume,) = mesh[el.edges[0]].elements
            third = [w.nr for w in mesh[volume].vertices if w.nr not in (a, b)][0]
            t = points[b] - points[a]
            n = np.array([t[1], -t[0]]) / np.linalg.norm(t)
            if n @ (points[third] - points[a]) > 0:              # outward: away from the element
                n = -n
            lengths.append(np.linalg.norm(t))
            normals.append(n)
            mids.append((points[a] + points[b]) / 2)
            dofs.append([position.get(int(d), -1) for w in (a, b)
                         for d in self.V.GetDofNrs(ngs.NodeId(ngs.VERTEX, w))])
        if not lengths:
            raise ValueError(f"no facet of Γ3 {names} in the mesh")
        self.lengths, self.normals = np.array(lengths), np.array(normals)
        self.dofs, self.midpoints = np.array(dofs), np.array(mids)
        self.n_beta = len(lengths)
        # the normal vector of each facet at its four DOFs: u_ν at vertex a = Σ n_d u_{a,d}
        self._weights = np.concatenate([self.normals, self.normals], axis=1)     # facets × 4

    def _u_normal(self, u):
        """(u_ν at vertex a, u_ν at vertex b) per facet (m)."""
        values = np.where(self.dofs >= 0, u[np.maximum(self.dofs, 0)], 0.0) * self._weights
        return values[:, :2].sum(axis=1), values[:, 2:].sum(axis=1)

    def _points(self, ua, ub, n):
        """Quadrature points and weights on [0, 1] per facet (facets × points) for the vertex
        values ua, ub of u_ν: n-point Gauss–Legendre, or with n = None 2 points on each of the
        three pieces between the crossings of −L and 0 (a piece of zero length has weight 0):
        exact for the piecewise quadratic integrands."""
        nf = len(ua)
        if n is not None:
            x, w = _rule(n)
            return np.broadcast_to(x, (nf, n)), np.broadcast_to(w, (nf, n))
        d = ub - ua
        with np.errstate(divide="ignore", invalid="ignore"):
            cuts = np.stack([(-self.L - ua) / d, -ua / d], axis=1)
        cuts = np.where(np.isfinite(cuts), np.clip(cuts, 0.0, 1.0), 0.0)
        cuts = np.sort(np.concatenate([np.zeros((nf, 1)), cuts, np.ones((nf, 1))], axis=1), axis=1)
        a, length = cuts[:, :-1, None], np.diff(cuts, axis=1)[:, :, None]
        x, w = _rule(2)
        return (a + length * x).reshape(nf, -1), (length * w).reshape(nf, -1)

    def _R(self, s):
        """R_ν(s) (m) and R_ν'(s)."""
        R = np.clip(-s, 0.0, self.L)
        return R, np.where((s < 0) & (s > -self.L), -1.0, 0.0)

    def _at_points(self, ua, ub, n):
        """(weights, basis (2 × facets × points), R_ν, R_ν') at the quadrature points."""
        s, w = self._points(ua, ub, n)
        R, dR = self._R((1 - s) * ua[:, None] + s * ub[:, None])
        return w, np.stack([1 - s, s]), R, dR

    # ------------------------------------------------------------------ the Γ3 terms
    def glue(self, u, beta, derivatives=False):
        """G(u, β) on the free u DOFs (N/m), a(u) per facet (1/s); with ``derivatives`` also
        ∂G/∂u (dense), ∂G/∂β (n_u × facets) and ∂a/∂u (facets × n_u)."""
        ua, ub = self._u_normal(u)
        n_glue, n_beta = (None, None) if self.quadrature == "exact" else self.quadrature
        weights, dofs, on = self._weights, self.dofs, self.dofs >= 0
        facet = np.broadcast_to(np.arange(self.n_beta)[:, None], dofs.shape)

        def spread(per_vertex):                   # facets × 2 (vertex a, b) -> facets × 4 DOFs
            return np.repeat(per_vertex, 2, axis=1) * weights

        w, basis, R, dR = self._at_points(ua, ub, n_glue)
        coefficient = (-self.gamma * beta ** 2 * self.lengths)[:, None]
        G = np.zeros(self.n_u)
        np.add.at(G, dofs[on], spread(coefficient * np.einsum("vfq,fq,fq->fv", basis, R, w))[on])
        w_b, basis_b, R_b, dR_b = self._at_points(ua, ub, n_beta)
        a = self.gamma * np.einsum("fq,fq->f", w_b, R_b ** 2)
        if not derivatives:
            return G, a
        stiff = coefficient[:, :, None] * np.einsum("vfq,xfq,fq,fq->fvx", basis, basis, dR, w)
        local_u = np.repeat(np.repeat(stiff, 2, axis=1), 2, axis=2) * weights[:, :, None] * weights[:, None, :]
        pair = on[:, :, None] & on[:, None, :]
        rows = np.broadcast_to(dofs[:, :, None], pair.shape)
        cols = np.broadcast_to(dofs[:, None, :], pair.shape)
        G_u = np.zeros((self.n_u, self.n_u))
        np.add.at(G_u, (rows[pair], cols[pair]), local_u[pair])
        G_beta = np.zeros((self.n_u, self.n_beta))
        local_beta = spread((-2 * self.gamma * beta * self.lengths)[:, None]
                            * np.einsum("vfq,fq,fq->fv", basis, R, w))
        np.add.at(G_beta, (dofs[on], facet[on]), local_beta[on])
        a_u = np.zeros((self.n_beta, self.n_u))
        local_a = spread(self.gamma * np.einsum("vfq,fq,fq,fq->fv", basis_b, 2 * R_b, dR_b, w_b))
        np.add.at(a_u, (facet[on], dofs[on]), local_a[on])
        return G, a, G_u, G_beta, a_u

    def potential(self, u):
        """φ on the free W DOFs (V) of the displacement u (free DOFs): φ = K_c⁻¹ K_e u (2.31)."""
        return sla.cho_solve(self._c_factor, self.K_e @ u)

    def full(self, u, beta=None):
        """(u on all V DOFs, φ on all W DOFs), held DOFs 0: to compare with a GridFunction's vectors."""
        U, P = np.zeros(self.V.ndof), np.zeros(self.W.ndof)
        U[self.free_u], P[self.free_phi] = u, self.potential(u)
        return U, P

    # ------------------------------------------------------------------ the ODE
    def rates(self, t, u, beta, derivatives=False):
        """(u̇, β̇) at time t (s) for u (free DOFs, m) and β; with ``derivatives`` also the
        Jacobian blocks (∂u̇/∂u, ∂u̇/∂β, ∂β̇/∂u, ∂β̇/∂β)."""
        parts = self.glue(u, beta, derivatives)
        G, a = parts[:2]
        du = sla.cho_solve(self._A_factor, self.force(t) * self.load - self.S @ u - G)
        drive = beta * a - self.eps_a
        dbeta = -np.maximum(drive, 0.0)
        if not derivatives:
            return du, dbeta
        G_u, G_beta, a_u = parts[2:]
        on = (drive > 0).astype(float)
        return du, dbeta, (-self._AinvS - sla.cho_solve(self._A_factor, G_u),
                           -sla.cho_solve(self._A_factor, G_beta),
                           -(on * beta)[:, None] * a_u, -np.diag(on * a))

    def _split(self, y):
        return y[:self.n_u] * self.scale, y[self.n_u:]

    def _fun(self, t, y):
        du, dbeta = self.rates(t, *self._split(y))
        return np.concatenate([du / self.scale, dbeta])

    def _jac(self, t, y):
        _, _, (uu, ub, bu, bb) = self.rates(t, *self._split(y), derivatives=True)
        return np.block([[uu, ub / self.scale], [bu * self.scale, bb]])

    def initial(self):
        """(u(0), β(0)) = (0, β0)."""
        return np.zeros(self.n_u), np.full(self.n_beta, self.beta0)

    def radau(self, T, rtol=1e-12, atol=1e-14):
        """Integrate over [0, T] (s) by SciPy's Radau IIA (order 5) with the exact Jacobian;
        ``atol`` applies to u/L and β (dimensionless). Returns (u, β, the solve_ivp result)."""
        u0, beta0 = self.initial()
        result = solve_ivp(self._fun, (0.0, T), np.concatenate([u0 / self.scale, beta0]), method="Radau",
                           rtol=rtol, atol=atol, jac=self._jac)
        if not result.success:
            raise RuntimeError(f"Radau failed on [0, {T}] s: {result.message}")
        u, beta = self._split(result.y[:, -1])
        return u, beta, result

    # ------------------------------------------------------------------ fully discrete replicas
    def _solve_step(self, t, c, u_hat, u, beta, beta_hat=None, tol=1e-13, maxit=50):
        """Newton for c K_A (u − û) + S u + G(u, β) = f(t): with ``beta_hat`` None, β is given;
        else jointly with c (β − β̂) + [β a(u) − ε_a]_+ = 0 (β implicit in u too). Returns (u, β)."""
        force = self.force(t) * self.load
        n = self.n_u
        for _ in range(maxit):
            G, a, G_u, G_beta, a_u = self.glue(u, beta, derivatives=True)
            r_u = c * self.K_A @ (u - u_hat) + self.S @ u + G - force
            J = c * self.K_A + self.S + G_u
            if beta_hat is None:
                du = np.linalg.solve(J, -r_u)
                u = u + du
                if np.abs(du).max() <= tol * max(np.abs(u).max(), 1e-300):
                    return u, beta
                continue
            drive = beta * a - self.eps_a
            on = (drive > 0).astype(float)
            r_b = c * (beta - beta_hat) + np.maximum(drive, 0.0)
            full = np.block([[J, G_beta], [on[:, None] * beta[:, None] * a_u, np.diag(c + on * a)]])
            delta = np.linalg.solve(full, -np.concatenate([r_u, r_b]))
            u, beta = u + delta[:n], beta + delta[n:]
            if np.abs(delta[:n]).max() <= tol * max(np.abs(u).max(), 1e-300) and np.abs(delta[n:]).max() <= tol:
                return u, beta
        raise RuntimeError(f"the replica's Newton did not converge in {maxit} iterations at t = {t} s")

    def _implicit_beta(self, u, beta, kappa):
        """β_n = (β̂ + κ ε_a)/(1 + κ a(u)) where β̂ a > ε_a, else β̂ (the implicit update of (2.9))."""
        a = self.glue(u, beta)[1]
        return np.where(beta * a > self.eps_a, (beta + kappa * self.eps_a) / (1 + kappa * a), beta)

    def backward_euler(self, steps, T):
        """``steps`` equal steps to T of the paper's backward Euler with the implicit β update
        from u_{n−1} (``Contact(beta_update="implicit")``). Returns (u, β) at T."""
        u, beta = self.initial()
        k = T / steps
        for n in range(1, steps + 1):
            beta = self._implicit_beta(u, beta, k)
            u, beta = self._solve_step(n * k, 1 / k, u, u, beta)
        return u, beta

    def bdf2(self, steps, T):
        """``steps`` equal steps to T of BDF2 (``schemes.bdf2``): a backward Euler first step
        (β implicit from u_0), then c = 3/(2k), û = (4 u_{n−1} − u_{n−2})/3 and β_n implicit in
        both β_n and u_n: 3/(2k) (β_n − β̂) = −[β_n a(u_n) − ε_a]_+, β̂ = (4 β_{n−1} − β_{n−2})/3,
        β_n kept in [0, 1] as ngcontact keeps it: where β̂ < 0 (BDF2's β oscillates once
        k γ_ν R_ν² > 1/2 and β̂ falls below 0 where β drops by more than 4× in a step) β_n = 0.
        Returns (u, β) at T."""
        u, beta = self.initial()
        k = T / steps
        beta_first = self._implicit_beta(u, beta, k)
        u1, beta1 = self._solve_step(k, 1 / k, u, u, beta_first)
        past = (u, beta)
        u, beta = u1, beta1
        for n in range(2, steps + 1):
            u_hat, beta_hat = (4 * u - past[0]) / 3, np.maximum((4 * beta - past[1]) / 3, 0.0)
            past = (u, beta)
            u, beta = self._solve_step(n * k, 1.5 / k, u_hat, u, beta, beta_hat)
        return u, beta
