"""Newton's corrections with the Signorini switch of Γ3 settled in an inner loop.

When the contact zone shrinks (the load reversed, a pull-off), the semismooth Newton releases
about one Gauss point of Γ3 per iteration: releasing the points in tension loads the next ones,
which the next correction releases, and the points of the front's facets open and close again
meanwhile (docs/stability.md, "The pull-off"). Each of those iterations assembles the Γ3 terms
and solves the whole system.

Nitsche's Signorini term (``enforcement.nitsche``) is a sum over the Gauss points q of Γ3 of
rank-one terms: with P_q(x) = σ̃_ν − γ(u_ν − g) at q, a_q = θ σ_ν'(v, ξ)_q − γ_q v_ν(q) (the test
functions' part) and the weight ω_q of the point (m in 2D, m² in 3D and on a section),

  R(x) ∋ Σ_q (ω_q/γ_q) χ_q [P_q(x)] a_q,   χ_q = 1 where P_q ≤ 0 (the contact set), else 0,

so the Jacobian's contact part is Σ_q (ω_q/γ_q) χ_q a_q b_qᵀ, b_q = ∂P_q/∂x (``SignoriniPoints``:
σ_ν'(·)_q and u_ν(q) as sparse rows, γ_q, P_q and the slope of σ̃_ν in u_ν at the state). A Newton
correction w solves J w = r at x with the contact set χ of x. The linear model of R with another
contact set χ' (the other laws' pieces kept) differs from it by the switched points only:

  (J + Σ_{q∈Q} s_q c_q a_q b_qᵀ) w = r + Σ_{q∈Q} s_q c_q P_q a_q,   s_q = χ'_q − χ_q, c_q = ω_q/γ_q,

a change of rank |Q|: with Z = J⁻¹ a_Q (one solve with the correction's factorisation per
switched point) it is solved by Woodbury's identity in a |Q| × |Q| system. ``SwitchLoop``
iterates χ' ← {P_q − b_q·w ≤ 0} (a primal–dual active set step on the linear model) until χ'
repeats, and replaces the correction by that model's solution: the cascade of a shrinking
contact zone is followed inside one Newton iteration, each switch costing one solve with a
kept factorisation instead of an assembly and a solve of the whole system.

Where the correction's solver is the kept factorisation of an earlier Jacobian (GMRES,
``linear_solver.KeptFactorization``), Z comes from that factorisation and the corrected w is
solved again by GMRES on J + U Vᵀ to the correction's accuracy. Newton then goes on as after any
correction: the residual at the new iterate and its convergence test decide (``stopping``), so
the loop changes how many iterations a step takes, not the state it converges to.

Where the model is far from R the loop rests: in a solve that starts with Γ3 open (a first
contact) until ``step_length`` has made its cuts and an iterate presses, and throughout such a
solve where Γ3 has no glue (conduction alone: the conduction's switches, which the model does
not follow, lead its first contact), and in an iteration after which a law in ``KEPT`` changed
piece. A solve that fails with the loop is made again without it (``Newton.solve``).

At a solve's first correction the loop also picks the slope of the glue's R_ν at its kink
u_ν = 0, where a body at rest sits: the pressed side's where the correction moves every such
point into the foundation (the correction is then made again), else the glued side's.

Measured (docs/stability.md, section 13): the reference history's pull-off in 3–6 iterations a
step instead of 9–23, its first contact in 5–6.
"""
import ngsolve as ngs
import numpy as np

from ngcontact.gamma3 import integrands
from ngcontact.gamma3.enforcement.nitsche import NitscheTerms
from ngcontact.model.forms import step_normal_stress_variation
from ngcontact.solve.linalg.gmres import gmres
from ngcontact.solve.linalg import petsc_solver
from ngcontact.solve.linalg.linear_solver import DirectSolver, KeptFactorization, reproducible

MAX_LOOP = 30
"""The most contact sets the loop tries in one Newton iteration."""
EXACT_TRIES = 5
"""With the kept factorisation: the most GMRES solves of the model, each followed by the contact
set its solution gives."""
KEPT = ("the compliant layer p", "the glue R_ν", "the potential truncation φ_L")
"""The switches of ``switches.Switches`` the model keeps at their pieces: where one of them changed
between Newton's last two iterates (the bond ending, say), the loop rests for that iteration."""


class SignoriniPoints:
    """The rank-one data of Nitsche's Signorini term at the Gauss points of Γ3 (module
    docstring), for the Γ3 parts ``gamma3`` (``gamma3.build.Gamma3`` with Nitsche's terms) of
    the Contact ``contact`` and the state ``state`` (the GridFunction of (u, φ))."""

    def __init__(self, gamma3, contact, state):
        self.enforcement, self.side, self.X, self.contact = gamma3.enforcement, gamma3.side, state.space, contact
        self.weights = gamma3.side.gauss_weights.ravel()
        enf = self.enforcement
        u, phi = state.components
        self._probe = ngs.GridFunction(self.X)
        v, xi = self._probe.components
        self._variation = step_normal_stress_variation(enf.tensors, v, xi, enf.coefficients.rate, enf.n).Compile()
        self._normal_part = (v * enf.n).Compile()
        shift = ngs.Parameter(0.0)
        u_n = u * enf.n
        traction = integrands.adhesion_traction(contact, gamma3.beta.gf, u_n)
        self._P = enf.P(u, phi, traction).Compile()
        self._gamma = (enf.gamma * ngs.CF(1.0)).Compile()
        self._slope = integrands.adhesion_traction(contact, gamma3.beta.gf, u_n + shift).Diff(shift).Compile()
        self._linear, self._rate = None, None

    def linear(self, theta):
        """(σ_ν'(·)_q, u_ν(q), γ_q (Pa/m), a_q = θ σ_ν'(·)_q − γ_q u_ν(q)): scipy CSR matrices
        (points × DOFs) and γ per point, made again only when the rate coefficient c of the step
        changed (σ_ν' holds c A, γ follows the step's stiffness). Each DOF of the volume elements
        at Γ3 is probed at once with the others of its colour: DOFs that share no such element."""
        import scipy.sparse as sp
        rate = self.enforcement.coefficients.rate.Get()
        if self._linear is None or rate != self._rate:
            S, N = self._make_rows()
            gamma = self.side.at_gauss_points(self._gamma).ravel()
            self._linear = (S, N, gamma, (theta * S - sp.diags(gamma) @ N).tocsr())
            self._rate = rate
        return self._linear

    def _make_rows(self):
        import scipy.sparse as sp
        side, X = self.side, self.X
        facets, points = side.gauss_points.shape[:2]
        element_dofs = {nr: np.array([d for d in X.GetDofNrs(ngs.ElementId(ngs.VOL, int(nr))) if d >= 0])
                        for nr in np.unique(side.facet_elements)}
        elements_of = {}
        for nr, dofs in element_dofs.items():
            for d in dofs:
                elements_of.setdefault(d, []).append(nr)
        colour = {}
        for d in sorted(elements_of):                 # greedy: no two DOFs of an element alike
            used = {colour[n] for nr in elements_of[d] for n in element_dofs[nr] if n in colour}
            c = 0
            while c in used:
                c += 1
            colour[d] = c
        ncolours = max(colour.values()) + 1
        by_colour = [[] for _ in range(ncolours)]
        for d, c in colour.items():
            by_colour[c].append(d)
        owner = np.full((ncolours, facets), -1)       # the DOF of each colour on each facet's element
        for f, nr in enumerate(side.facet_elements):
            for d in element_dofs[nr]:
                owner[colour[d], f] = d
        values = self._probe.vec.FV().NumPy()
        out = []
        for cf in (self._variation, self._normal_part):
            rows, cols, vals = [], [], []
            for c, dofs in enumerate(by_colour):
                values[:] = 0.0
                values[dofs] = 1.0
                at = side.at_gauss_points(cf)                     # facets × points
                dof = np.repeat(owner[c], points)
                flat = at.ravel()
                keep = (dof >= 0) & (flat != 0.0)
                rows.append(np.flatnonzero(keep))
                cols.append(dof[keep])
                vals.append(flat[keep])
            out.append(sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                     shape=(facets * points, X.ndof)))
        values[:] = 0.0
        return tuple(out)

    def at_state(self):
        """(P_q (Pa), ∂σ̃_ν/∂u_ν at q (Pa/m)) at the current state."""
        return tuple(self.side.at_gauss_points(cf).ravel() for cf in (self._P, self._slope))


class _Updated(ngs.BaseMatrix):
    """J + U Vᵀ: ``matrix`` plus the rank-k term U (numpy n × k) Vᵀ (scipy k × n)."""

    def __init__(self, matrix, U, V):
        super().__init__()
        self.matrix, self.U, self.V = matrix, U, V

    def Mult(self, x, y):
        y.data = self.matrix * x
        y.FV().NumPy()[:] += self.U @ (self.V @ x.FV().NumPy())

    def Height(self):
        return self.matrix.height

    def Width(self):
        return self.matrix.width

    def CreateRowVector(self):
        return self.matrix.CreateRowVector()

    def CreateColVector(self):
        return self.matrix.CreateColVector()


class SwitchLoop:
    """The inner loop of Newton's corrections (module docstring) on the Signorini points
    ``points``; ``theta``: Nitsche's θ. ``switches`` counts the points the loop switched,
    ``tries`` the contact sets it tried, over the simulation."""

    def __init__(self, points, theta):
        self.points, self.theta = points, theta
        self.switches = self.tries = 0
        self._pieces = None              # the other laws' pieces at the last iterate
        self._pressed = False            # whether Γ3 pressed at the solve's start

    @staticmethod
    def applies(contact, gamma3, system, solver, distributed):
        """Whether the loop runs for ``contact`` (None: no Γ3) with the built ``gamma3``, the
        StepSystem ``system`` and the correction ``solver``: Nitsche's method on a contact with
        glue or conduction, a linear bulk (no law's terms in K), one process, and a solver whose
        factorisation it can apply again (the built-in direct or kept one, an NGSolve
        factorisation: not PETSc's MUMPS)."""
        if contact is None or distributed or system.laws is not None or not isinstance(gamma3.enforcement, NitscheTerms):
            return False
        if not (contact.adhesion > 0 or contact.conducts) or type(solver) not in (DirectSolver, KeptFactorization):
            return False
        direct = solver if isinstance(solver, DirectSolver) else solver.direct
        return direct.name not in petsc_solver.NAMES

    @staticmethod
    def _other_pieces(newton):
        """The pieces of the laws of Γ3 the model keeps fixed and that do not follow the contact
        set (``switches.Switches``: the compliant layer, the glue, the potential truncation)."""
        if newton.switches is None:
            return {}
        return {name: value for name, value in newton.switches().items() if name in KEPT}

    def _rest_side(self, newton, x, tol):
        """A solve's first correction: where points of Γ3 sit on the glue's kink u_ν = 0 (a body
        at rest) and the correction presses every one of them, R_ν is linearised on its pressed
        side there (``Contact.rest_side``) and the correction made again; else on its glued side.
        Either is a slope of R_ν at the kink; the one the body moves to saves the iteration that
        would switch them all."""
        contact = self.points.contact
        contact.rest_side.Set(0.0)
        if contact.adhesion <= 0:
            return
        N = self.points.linear(self.theta)[1]
        kink = N @ x.FV().NumPy() == 0.0
        if kink.any() and (N[kink] @ newton.w.FV().NumPy() < 0.0).all():     # u_ν grows along −w
            contact.rest_side.Set(1.0)
            newton.linear_solve(x, tol=tol)

    def _factorisation(self, solver):
        return solver.inverse if isinstance(solver, DirectSolver) else solver.direct.inverse

    def __call__(self, newton, x, residuals, tol=None):
        """Replace Newton's last correction ``newton.w`` (for the residual ``newton.r`` at the
        state ``x``; ``residuals``: the solve's residual history; ``tol``: the accuracy it was
        solved to) by the solution of the linear model whose contact set is its own; it rests
        where a law the model keeps at its pieces (``KEPT``) changed between the last two
        iterates."""
        import scipy.sparse as sp
        P, slope = self.points.at_state()
        if len(residuals) == 1:                      # a solve (or a try of it) begins
            self._pressed, self._pieces = bool((P <= 0.0).any()), None
            self._rest_side(newton, x, tol)
        limit = newton.step_length
        if not self._pressed and self.points.contact.adhesion > 0 and (P <= 0.0).any() and \
                (limit is None or limit.spent):
            self._pressed = True                     # a glued first contact, once the step length cuts no more
        if not self._pressed:
            return
        pieces = self._other_pieces(newton)
        moved = self._pieces is not None and any(not np.array_equal(pieces[name], self._pieces[name])
                                                 for name in pieces)
        self._pieces = pieces
        if moved:
            return
        S, N, gamma, a = self.points.linear(self.theta)
        b = (S + sp.diags(slope - gamma) @ N).tocsr()
        c = self.points.weights / gamma
        w0 = newton.w.FV().NumPy().copy()
        before = P <= 0.0
        inverse = self._factorisation(newton.solver)
        solve = _CorrectionSolve(newton, inverse)
        Z, w, tried = {}, w0, set()
        for _ in range(MAX_LOOP):
            now = P - b @ w <= 0.0
            key = now.tobytes()
            if key in tried:
                break
            tried.add(key)
            self.tries += 1
            Q = np.flatnonzero(now != before)
            chosen = (now, Q)
            if not len(Q):
                w = w0
                continue
            for q in Q:
                if q not in Z:
                    Z[q] = solve(a[q].toarray().ravel())
            Zq = np.stack([Z[q] for q in Q], axis=1)
            V, m = _switched(now, Q, b, c, P)
            y = w0 + Zq @ m
            try:
                w = y - Zq @ np.linalg.solve(np.eye(len(Q)) + V @ Zq, V @ y)
            except np.linalg.LinAlgError:            # the model is singular there: the plain correction
                return
        now, Q = chosen                              # (the first set tried, at least)
        if isinstance(newton.solver, KeptFactorization):    # Z was approximate: the model solved again
            for _ in range(EXACT_TRIES):
                if not len(Q):
                    w = w0
                else:
                    V, m = _switched(now, Q, b, c, P)
                    w = solve.exactly(a[Q].T.toarray(), V, m, w)
                settled = P - b @ w <= 0.0
                if np.array_equal(settled, now):
                    break
                now, Q = settled, np.flatnonzero(settled != before)
        self.switches += len(Q)
        newton.w.FV().NumPy()[:] = w


def _switched(now, Q, b, c, P):
    """The rank-|Q| change of the linear model where the points Q switch to the contact set
    ``now`` (module docstring): V = diag(s c) b_Q (CSR) and m = s c P_Q, s = ±1 as a point enters
    or leaves the contact set."""
    import scipy.sparse as sp
    s = np.where(now[Q], 1.0, -1.0) * c[Q]
    return (sp.diags(s) @ b[Q]).tocsr(), s * P[Q]


class _CorrectionSolve:
    """Solves with the factorisation of Newton's last correction, through the static
    condensation of the system when it has one (as ``Newton.linear_solve``)."""

    def __init__(self, newton, inverse):
        self.newton, self.inverse = newton, inverse
        self.system = newton.system

    def _condensed(self, values, solve):
        """The full solution for the right-hand side ``values`` (numpy), ``solve(rc, out)``
        solving on the coupling DOFs (all DOFs without condensation)."""
        system = self.system
        rhs, out = self.newton.w.CreateVector(), self.newton.w.CreateVector()
        rhs.FV().NumPy()[:] = values
        out[:] = 0.0
        with reproducible():
            if self.newton.condense:
                rc = rhs.CreateVector()
                rc.data = rhs + system.harmonic_extension_trans * rhs
                solve(rc, out)
                out.data += system.harmonic_extension * out
                out.data += system.inner_solve * rhs
            else:
                solve(rhs, out)
        return out.FV().NumPy().copy()

    def __call__(self, values):
        def solve(rc, out):
            out.data = self.inverse * rc
        return self._condensed(values, solve)

    def exactly(self, U, V, m, start):
        """The solution of (J + U Vᵀ) w = r + U m by GMRES preconditioned by the kept
        factorisation, to the solver's own accuracy (``KeptFactorization.tol``), from zero;
        ``start`` where GMRES does not converge."""
        newton, solver = self.newton, self.newton.solver
        operator = _Updated(self.system.mat, U, V)
        converged = []

        def solve(rc, out):
            converged.append(gmres(operator, self.inverse, rc, out, newton.norm.weights, solver.tol,
                                   solver.max_budget)[0])
        w = self._condensed(newton.r.FV().NumPy() + U @ m, solve)
        return w if converged[0] else start
