"""Equilibrated fluxes by local problems on vertex patches (Braess–Schöberl, Ern–Vohralík).

Given a discrete flux σ_h (a matrix CoefficientFunction: ``rows`` rows of ``dim`` components —
the stress, rows = dim, or the electric displacement, rows = 1) that satisfies the discrete
equilibrium −div σ = f in Ω, σ n = t on the Neumann parts of ∂Ω (row by row) in the Galerkin
sense, this module builds σ* with rows in the Raviart–Thomas space RT_p that satisfies it
exactly (up to the projection of f onto P_p):

  σ* = Σ_a σ_a over the vertices a, each σ_a on the patch ω_a of the elements around a:

  min ‖σ_a − ψ_a σ_h‖²_W  over σ_a ∈ RT_p(ω_a)^rows with σ_a n = 0 on ∂ω_a \\ ∂Ω and
                         σ_a n = Π(ψ_a t) on the Neumann parts of ∂ω_a ∩ ∂Ω (per row),
  subject to  div σ_a = Π_p(σ_h ∇ψ_a − ψ_a f)  on ω_a,

with ψ_a the P1 hat function of a and W a weight (the compliance, for an estimate in the
energy norm). The local problems are compatible where no Dirichlet boundary touches ω_a
(their constants are fixed by ∫ r = 0) because the discrete solution is Galerkin-orthogonal
to ψ_a e_i. Summing, div σ* = Π_p(σ_h ∇(Σψ_a) − f) = −Π_p f and σ* n = Π t: the Prager–Synge
argument then bounds the energy error by ‖σ* − σ_h‖ (``estimators.equilibrated``).

The global matrices are assembled once by NGSolve (the hat functions enter as the trial
functions of a P1 space, so that every patch's right-hand side is a column); each patch is a
small dense saddle-point system solved by numpy.
"""
import ngsolve as ngs
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as sla_sparse

from ..matrices import csr

BONUS = 4
"""Extra quadrature order for the data (a source or traction that is not a polynomial)."""


def _dense(matrix, rows, cols):
    """The dense submatrix matrix[rows][:, cols] of a CSR matrix (a vectorised gather: scipy's
    fancy indexing made the patch loop 2× slower)."""
    rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
    out = np.zeros((len(rows), len(cols)))
    if not len(rows) or not len(cols):
        return out
    position = np.full(matrix.shape[1], -1, dtype=np.int64)
    position[cols] = np.arange(len(cols))
    starts, stops = matrix.indptr[rows], matrix.indptr[rows + 1]
    counts = stops - starts
    index = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
    local_rows = np.repeat(np.arange(len(rows)), counts)
    local_cols = position[matrix.indices[index]]
    keep = local_cols >= 0
    np.add.at(out, (local_rows[keep], local_cols[keep]), matrix.data[index][keep])
    return out


def _entries(matrix, rows, cols):
    """matrix[rows[k], cols[k]] for every k (a CSR matrix; 0 where it has no entry)."""
    return np.asarray(matrix[rows, cols]).ravel() if len(rows) else np.zeros(0)


def _within_patches(matrix, row_patch, row_global, col_patch, col_global, row_offset, col_offset):
    """COO entries (rows, columns, values) of ``matrix`` between the patch-local unknowns
    (row_patch, row_global) and (col_patch, col_global) of the same patch, at positions
    row_offset + k and col_offset + l of the local lists (a vectorised E M Eᵀ masked to the
    diagonal blocks)."""
    E_rows = sp.csr_matrix((np.ones(len(row_global)), (np.arange(len(row_global)), row_global)),
                           shape=(len(row_global), matrix.shape[0]))
    E_cols = sp.csr_matrix((np.ones(len(col_global)), (np.arange(len(col_global)), col_global)),
                           shape=(len(col_global), matrix.shape[1]))
    product = (E_rows @ matrix @ E_cols.T).tocoo()
    same = row_patch[product.row] == col_patch[product.col]
    return product.row[same] + row_offset, product.col[same] + col_offset, product.data[same]


def _facet_nodes(mesh):
    return ngs.EDGE if mesh.dim == 2 else ngs.FACE


class Patches:
    """The vertex patches of a mesh: for each vertex its volume elements and facets, and the
    boundary facets with their boundary names."""

    def __init__(self, mesh):
        self.mesh = mesh
        facet_kind = _facet_nodes(mesh)
        self.boundary_name = {}                       # facet number -> boundary name
        for el in mesh.Elements(ngs.BND):
            facet = (el.edges if mesh.dim == 2 else el.faces)[0].nr
            self.boundary_name[facet] = el.mat
        self.elements, self.facets = [], []
        for v in mesh.vertices:
            self.elements.append([el.nr for el in v.elements])
            self.facets.append([f.nr for f in (v.edges if mesh.dim == 2 else v.faces)])
        self.facet_kind = facet_kind


class Equilibration:
    """Equilibrate fluxes of ``rows`` rows in RT_``order`` on ``mesh`` (module docstring).

    Parameters
    ----------
    mesh : ngsolve.Mesh (2D or 3D).
    rows : the number of rows (dim for a stress, 1 for a flux vector).
    order : p of RT_p (div in P_p); p = the order of the primal unknown suits.
    weight : a function (sigma, tau) -> the integrand of the weight W of the local problems, for
        two ``rows`` × dim matrices (trial and test of the product space row by row).
    neumann : function (boundary name, row) -> True where the row's flux is prescribed
        (traction or charge data), False where the row's primal unknown is (Dirichlet).
    patches : ``Patches`` of the mesh (shared between equilibrations of one mesh).
    """

    def __init__(self, mesh, rows, order, weight, neumann, patches=None):
        self.mesh, self.rows, self.order = mesh, int(rows), int(order)
        self.patches = patches or Patches(mesh)
        self.S = ngs.HDiv(mesh, order=order, RT=True)
        self.Q = ngs.L2(mesh, order=order)
        self.P1 = ngs.H1(mesh, order=1)
        nS, nQ, d = self.S.ndof, self.Q.ndof, mesh.dim
        self.nS, self.nQ = nS, nQ
        sigma_rows, tau_rows = self.S.TnT()
        # W in blocks (row i of the trial, row j of the test): an S x S bilinear form each
        blocks = [[None] * rows for _ in range(rows)]
        for i in range(rows):
            for j in range(rows):
                trial = ngs.CF(tuple(sigma_rows if k == i else ngs.CF((0,) * d) for k in range(rows)), dims=(rows, d))
                test = ngs.CF(tuple(tau_rows if k == j else ngs.CF((0,) * d) for k in range(rows)), dims=(rows, d))
                form = ngs.BilinearForm(self.S)
                form += weight(trial, test) * ngs.dx
                form.Assemble()
                blocks[j][i] = csr(form.mat, copy=True)
        self.W = sp.bmat(blocks, format="csr")
        self._weight = weight
        q = self.Q.TestFunction()
        div = ngs.BilinearForm(trialspace=self.S, testspace=self.Q)
        div += ngs.div(sigma_rows) * q * ngs.dx
        div.Assemble()
        self.B = sp.block_diag([csr(div.mat, copy=True)] * rows, format="csr")
        boundary = ngs.BilinearForm(self.S)
        n = ngs.specialcf.normal(d)
        boundary += (sigma_rows.Trace() * n) * (tau_rows.Trace() * n) * ngs.ds
        boundary.Assemble()
        self.M_boundary = csr(boundary.mat, copy=True)
        ones = ngs.GridFunction(self.Q)
        ones.Set(1.0)
        mass = ngs.BilinearForm(self.Q)
        mass += self.Q.TrialFunction() * q * ngs.dx
        mass.Assemble()
        self.q_mean = csr(mass.mat, copy=True) @ ones.vec.FV().NumPy()           # ∫ r = q_mean · r
        self.neumann = neumann
        self._prepare_patches()

    def _prepare_patches(self):
        """Every patch's unknowns laid out one after the other: its free RT DOFs (row by row),
        its L2 DOFs, and the multipliers of ∫ r_i = 0 of its rows without a Dirichlet side; the
        prescribed (Neumann) facets per row. The patch problems then form one block-diagonal
        sparse system, factorised once (SuperLU) and solved for every right-hand side: the
        patches never pass through a Python loop at solve time."""
        S, Q, P = self.S, self.Q, self.patches
        facet_kind, rows, nS, nQ = P.facet_kind, self.rows, self.nS, self.nQ
        facet_dofs = {}
        interior_of = {}                                  # element -> its RT DOFs of no facet
        for el in self.mesh.Elements(ngs.VOL):
            on_facets = set()
            for f in (el.edges if self.mesh.dim == 2 else el.faces):
                dofs = facet_dofs.setdefault(f.nr, list(S.GetDofNrs(ngs.NodeId(facet_kind, f.nr))))
                on_facets.update(dofs)
            interior_of[el.nr] = [d for d in S.GetDofNrs(el) if d >= 0 and d not in on_facets]
        q_of = {el.nr: list(Q.GetDofNrs(el)) for el in self.mesh.Elements(ngs.VOL)}
        sig_patch, sig_global, q_patch, q_global, q_row = [], [], [], [], []
        border_patch, border_row = [], []
        fixed_patch, fixed_global, fixed_facet = [], [], []
        hats = []
        for a, (elements, facets) in enumerate(zip(P.elements, P.facets)):
            interior = [d for el in elements for d in interior_of[el]]
            q_dofs = [d for el in elements for d in q_of[el]]
            for i in range(rows):
                offset = i * nS
                free = [offset + d for d in interior]
                dirichlet = False
                for f in facets:
                    name = P.boundary_name.get(f)
                    if name is not None and self.neumann(name, i):
                        fixed_patch += [a] * len(facet_dofs[f])
                        fixed_global += [offset + d for d in facet_dofs[f]]
                        fixed_facet += [f] * len(facet_dofs[f])
                    else:
                        free += [offset + d for d in facet_dofs[f]]
                        dirichlet |= name is not None
                sig_patch += [a] * len(free)
                sig_global += free
                q_patch += [a] * len(q_dofs)
                q_global += [i * nQ + d for d in q_dofs]
                q_row += [i] * len(q_dofs)
                if not dirichlet:
                    border_patch.append(a)
                    border_row.append(i)
            hats.append(self.P1.GetDofNrs(ngs.NodeId(ngs.VERTEX, a))[0])
        self.hats = np.array(hats, dtype=np.int64)
        sig_patch, sig_global = np.array(sig_patch, dtype=np.int64), np.array(sig_global, dtype=np.int64)
        q_patch, q_global, q_row = (np.array(v, dtype=np.int64) for v in (q_patch, q_global, q_row))
        border_patch, border_row = np.array(border_patch, dtype=np.int64), np.array(border_row, dtype=np.int64)
        n_sig, n_q, n_b = len(sig_global), len(q_global), len(border_patch)
        self._sig = (sig_patch, sig_global)
        self._q = (q_patch, q_global)
        # the block-diagonal system in COO: W within each patch, B and Bᵀ, the borders
        entries = [_within_patches(self.W, sig_patch, sig_global, sig_patch, sig_global, 0, 0)]
        B = _within_patches(self.B, q_patch, q_global, sig_patch, sig_global, n_sig, 0)
        entries += [B, (B[1], B[0], B[2])]
        # border k of (patch a, row i): q_mean at the L2 DOFs of row i of patch a
        key = q_patch * rows + q_row
        border_of = {int(a * rows + i): n_sig + n_q + k for k, (a, i) in enumerate(zip(border_patch, border_row))}
        b_index = np.array([border_of.get(k, -1) for k in key.tolist()], dtype=np.int64)
        has_border = b_index >= 0
        q_positions = n_sig + np.arange(n_q)
        values = self.q_mean[q_global % nQ]
        entries += [(q_positions[has_border], b_index[has_border], values[has_border]),
                    (b_index[has_border], q_positions[has_border], values[has_border])]
        r, c, v = (np.concatenate(parts) for parts in zip(*entries))
        size = n_sig + n_q + n_b
        self._system = sp.csc_matrix((v, (r, c)), shape=(size, size))
        self._lu = None
        # prescribed normal fluxes: per facet its normal-trace mass block (Cholesky), and the
        # couplings of the fixed DOFs into the patch equations (W and B within the patch)
        fixed_patch, fixed_global = np.array(fixed_patch, dtype=np.int64), np.array(fixed_global, dtype=np.int64)
        self._fixed = (fixed_patch, fixed_global, np.array(fixed_facet, dtype=np.int64))
        W_fixed = _within_patches(self.W, sig_patch, sig_global, fixed_patch, fixed_global, 0, 0)
        B_fixed = _within_patches(self.B, q_patch, q_global, fixed_patch, fixed_global, n_sig, 0)
        r, c, v = (np.concatenate(parts) for parts in zip(W_fixed, B_fixed))
        self._coupling = sp.csr_matrix((v, (r, c)), shape=(size, len(fixed_global)))
        self._facet_blocks = {}
        for f in np.unique(self._fixed[2]):
            dofs = facet_dofs[int(f)]
            self._facet_blocks[int(f)] = (len(dofs), sla.cho_factor(_dense(self.M_boundary, dofs, dofs)))
        self._sizes = (n_sig, n_q, n_b)

    def __call__(self, flux, source, traction):
        """σ* (a numpy array of the rows × nS coefficients) for the discrete flux ``flux``
        (rows × dim CoefficientFunction), the source f (``source``, a CF of ``rows``
        components: −div σ = f) and the Neumann data ``traction`` (a CF of ``rows`` components
        on the boundary, used where ``neumann`` says a row is prescribed)."""
        d, rows, nS = self.mesh.dim, self.rows, self.nS
        psi = self.P1.TrialFunction()
        tau = self.S.TestFunction()
        q = self.Q.TestFunction()
        flux = ngs.CF(flux, dims=(rows, d)) if rows > 1 else ngs.CF(flux, dims=(1, d))
        source = ngs.CF(source) if rows > 1 else ngs.CF((source,))
        traction = ngs.CF(traction) if rows > 1 else ngs.CF((traction,))
        rhs_w, rhs_div, rhs_t = [], [], []               # each: (DOFs of the row) × (hat functions)
        n = ngs.specialcf.normal(d)
        for i in range(rows):
            test = ngs.CF(tuple(tau if k == i else ngs.CF((0,) * d) for k in range(rows)), dims=(rows, d))
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
            form += psi * self._weight(flux, test) * ngs.dx
            rhs_w.append(csr(form.Assemble().mat, copy=True))
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.Q)
            form += (ngs.InnerProduct(flux[i, :], ngs.grad(psi)) - psi * source[i]) * q * ngs.dx(bonus_intorder=BONUS)
            rhs_div.append(csr(form.Assemble().mat, copy=True))
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
            form += psi * traction[i] * (tau.Trace() * n) * ngs.ds(bonus_intorder=BONUS)
            rhs_t.append(csr(form.Assemble().mat, copy=True))
        rhs_w, rhs_div, rhs_t = (sp.vstack(m, format="csr") for m in (rhs_w, rhs_div, rhs_t))
        (sig_patch, sig_global), (q_patch, q_global) = self._sig, self._q
        fixed_patch, fixed_global, fixed_facet = self._fixed
        n_sig, n_q, n_b = self._sizes
        # the prescribed normal fluxes of every patch on its Neumann facets: Π(ψ_a t) facet by facet
        x_fixed = _entries(rhs_t, fixed_global, self.hats[fixed_patch])
        for f, (size, chol) in self._facet_blocks.items():
            at = np.flatnonzero(fixed_facet == f)              # groups of ``size`` (one row, one patch)
            if len(at):
                x_fixed[at] = sla.cho_solve(chol, x_fixed[at].reshape(-1, size).T).T.ravel()
        rhs = np.concatenate([_entries(rhs_w, sig_global, self.hats[sig_patch]),
                              _entries(rhs_div, q_global, self.hats[q_patch]), np.zeros(n_b)])
        if len(x_fixed):
            rhs -= self._coupling @ x_fixed
        if self._lu is None:
            self._lu = sla_sparse.splu(self._system)
        z = self._lu.solve(rhs)
        result = np.zeros(rows * nS)
        np.add.at(result, sig_global, z[:n_sig])
        np.add.at(result, fixed_global, x_fixed)
        return result

    def gridfunctions(self, values):
        """The rows of σ* as GridFunctions of the RT space."""
        out = []
        for i in range(self.rows):
            gf = ngs.GridFunction(self.S)
            gf.vec.FV().NumPy()[:] = values[i * self.nS:(i + 1) * self.nS]
            out.append(gf)
        return out
