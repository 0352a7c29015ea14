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

How it is computed. The element matrices of W and of (div σ, q) come from NGSolve on the
discontinuous copies of the spaces (blocks in each element's own DOF order; the conforming
matrices are their sums, exactly). In each element the RT DOFs inside it and the L2 DOFs of
zero mean are eliminated once (static condensation: they belong to that element alone in every
patch problem), leaving its facet DOFs and its mean; every patch problem is then a small
system in the facet DOFs around its vertex and the means of its elements, and all of them form
one block-diagonal sparse system, factorised once (SuperLU) and solved for every right-hand
side. The hat functions enter as the trial functions of a P1 space, so that every patch's data
is a column of an assembled matrix. No Python loop runs over patches or elements at solve time.
"""
import ngsolve as ngs
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as sla_sparse

from ngcontact.solve.linalg.matrices import csr

BONUS = 4
"""Extra quadrature order for the data (a source or traction that is not a polynomial)."""


def _entries(matrix, rows, cols):
    """matrix[rows[k], cols[k]] for every k (a CSR matrix; 0 where it has no entry)."""
    return np.asarray(matrix[rows, cols]).ravel() if len(rows) else np.zeros(0)


def _facet_kind(mesh):
    return ngs.EDGE if mesh.dim == 2 else ngs.FACE


def _facets_of(mesh, el):
    return el.edges if mesh.dim == 2 else el.faces


def _element_blocks(form, mesh, trial, test):
    """The element matrices of a BilinearForm on discontinuous spaces, as an array
    (elements × test DOFs × trial DOFs) in each element's DOF order. Such spaces number each
    element's DOFs in one block after the other: the matrix's rows are read as blocks at once
    (checked), else element by element."""
    A = csr(form.mat, copy=True)
    ne = mesh.ne
    n_test, n_trial = A.shape[0] // ne, A.shape[1] // ne
    first_test, first_trial = list(test.GetDofNrs(ngs.ElementId(ngs.VOL, 0))), list(trial.GetDofNrs(ngs.ElementId(ngs.VOL, 0)))
    if (A.shape == (ne * n_test, ne * n_trial) and first_test == list(range(n_test))
            and first_trial == list(range(n_trial)) and np.all(np.diff(A.indptr) == n_trial)):
        A.sort_indices()
        expected = (np.arange(A.shape[0]) // n_test)[:, None] * n_trial + np.arange(n_trial)
        if np.array_equal(A.indices.reshape(-1, n_trial), expected):
            return A.data.reshape(ne, n_test, n_trial).copy()
    blocks = []
    for el in mesh.Elements(ngs.VOL):
        rows, cols = list(test.GetDofNrs(el)), list(trial.GetDofNrs(el))
        blocks.append(A[rows][:, cols].toarray())
    return np.array(blocks)


class Patches:
    """The vertex patches of a mesh as arrays: the vertices and facets of every volume element
    (in NGSolve's local order), the vertices of every facet, and the boundary name of every
    boundary facet (``boundary_name``, facet number -> name)."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.facet_kind = _facet_kind(mesh)
        self.boundary_name = {}                       # facet number -> boundary name
        for el in mesh.Elements(ngs.BND):
            self.boundary_name[_facets_of(mesh, el)[0].nr] = el.mat
        elements = list(mesh.Elements(ngs.VOL))
        self.element_vertices = np.array([[v.nr for v in el.vertices] for el in elements], dtype=np.int64)
        self.element_facets = np.array([[f.nr for f in _facets_of(mesh, el)] for el in elements], dtype=np.int64)
        facets = mesh.edges if mesh.dim == 2 else mesh.faces
        self.facet_vertices = np.array([[v.nr for v in f.vertices] for f in facets], dtype=np.int64)


class Equilibration:
    """Equilibrate fluxes of ``rows`` rows in RT_``order`` on ``mesh`` (module docstring).

    Parameters
    ----------
    mesh : ngsolve.Mesh (2D or 3D), one polynomial order throughout.
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
        self.nS, self.nQ = self.S.ndof, self.Q.ndof
        self._weight, self.neumann = weight, neumann
        self._element_matrices()
        self._condense()
        self._patch_system()

    # ------------------------------------------------------------------ element level
    def _element_matrices(self):
        """W_K and B_K of every element in its local order: rows × (facet DOFs, interior DOFs)
        of RT_p, rows × (mean, rest) of P_p."""
        mesh, rows, d = self.mesh, self.rows, self.mesh.dim
        S, Q = self.S, self.Q
        Sd = ngs.Discontinuous(S)
        sigma, tau = Sd.TnT()
        zero = ngs.CF((0,) * d)
        W = [[None] * rows for _ in range(rows)]
        for i in range(rows):
            for j in range(rows):
                trial = ngs.CF(tuple(sigma if k == i else zero for k in range(rows)), dims=(rows, d))
                test = ngs.CF(tuple(tau if k == j else zero for k in range(rows)), dims=(rows, d))
                form = ngs.BilinearForm(Sd)
                form += self._weight(trial, test) * ngs.dx
                W[j][i] = _element_blocks(form.Assemble(), mesh, Sd, Sd)
        div = ngs.BilinearForm(trialspace=Sd, testspace=Q)
        div += ngs.div(sigma) * Q.TestFunction() * ngs.dx
        Bd = _element_blocks(div.Assemble(), mesh, Sd, Q)                  # (ne, nQ_loc, nS_loc)
        # local DOF structure of each element: its facets' DOFs, its interior DOFs
        P = self.patches
        facet_count = len(P.facet_vertices)
        lists = [list(S.GetDofNrs(ngs.NodeId(P.facet_kind, f))) for f in range(facet_count)]
        width = max(len(dofs) for dofs in lists)
        # a refined mesh keeps the facets of its coarser levels, without DOFs: padded with -1
        self.facet_dofs = np.array([dofs if len(dofs) == width else [-1] * width for dofs in lists],
                                   dtype=np.int64)                           # (facets, w)
        self.el_sdofs = np.array([list(S.GetDofNrs(el)) for el in mesh.Elements(ngs.VOL)], dtype=np.int64)
        self.el_qdofs = np.array([list(Q.GetDofNrs(el)) for el in mesh.Elements(ngs.VOL)], dtype=np.int64)
        ne = mesh.ne
        nS_loc, nQ_loc = self.el_sdofs.shape[1], self.el_qdofs.shape[1]
        on_element = self.facet_dofs[P.element_facets]                     # (ne, facets, w) global DOFs
        on_element = on_element.reshape(ne, -1)
        match = on_element[:, :, None] == self.el_sdofs[:, None, :]         # (ne, facets·w, nS_loc)
        facet_order = match.argmax(axis=2)                                  # local positions, facet by facet
        interior_mask = ~match.any(axis=1)
        interior = np.nonzero(interior_mask)[1].reshape(ne, -1)
        nF, nI = facet_order.shape[1], interior.shape[1]
        self.w = self.facet_dofs.shape[1]
        self.nF_loc, self.nI_loc, self.nQ_loc = nF, nI, nQ_loc
        nY, nX = rows * (nF + 1), rows * (nI + nQ_loc - 1)
        K = np.zeros((ne, rows * (nS_loc + nQ_loc), rows * (nS_loc + nQ_loc)))
        for i in range(rows):
            for j in range(rows):
                K[:, j * nS_loc:(j + 1) * nS_loc, i * nS_loc:(i + 1) * nS_loc] = W[j][i]
            q0 = rows * nS_loc + i * nQ_loc
            K[:, q0:q0 + nQ_loc, i * nS_loc:(i + 1) * nS_loc] = Bd
            K[:, i * nS_loc:(i + 1) * nS_loc, q0:q0 + nQ_loc] = np.transpose(Bd, (0, 2, 1))
        # the permutation of the local unknowns into (Y, X), per element
        Ypos, Xpos = [], []
        for i in range(rows):
            Ypos.append(i * nS_loc + facet_order)
        for i in range(rows):
            Ypos.append(np.full((ne, 1), rows * nS_loc + i * nQ_loc))
        for i in range(rows):
            Xpos.append(i * nS_loc + interior)
        for i in range(rows):
            Xpos.append(rows * nS_loc + i * nQ_loc + 1 + np.tile(np.arange(nQ_loc - 1), (ne, 1)))
        Ypos, Xpos = np.concatenate(Ypos, axis=1), np.concatenate(Xpos, axis=1)
        take = lambda P, Q_: K[np.arange(ne)[:, None, None], P[:, :, None], Q_[:, None, :]]
        self.K_YY, self.K_YX, self.K_XY, self.K_XX = take(Ypos, Ypos), take(Ypos, Xpos), take(Xpos, Ypos), take(Xpos, Xpos)
        self.nY, self.nX = nY, nX
        self.facet_order = facet_order                     # local S positions of the facet DOFs
        self.interior = interior

    def _condense(self):
        """Per element: M⁻¹ = K_XX⁻¹, the condensed S_K = K_YY − K_YX M⁻¹ K_XY and the
        right-hand side map G_K = K_YX M⁻¹ (batched over the elements)."""
        Minv = np.linalg.inv(self.K_XX)
        self.Minv = Minv
        self.G = self.K_YX @ Minv
        self.S_cond = self.K_YY - self.G @ self.K_XY

    # ------------------------------------------------------------------ patch level
    def _patch_system(self):
        """The block-diagonal system of all condensed patch problems, and the maps from
        (element, patch) pairs to its unknowns, built with arrays: the unknowns of a patch are its
        facet DOFs around its vertex (row by row, not prescribed), its elements' means (row by
        row) and the multipliers of ∫ r_i = 0 (rows without a Dirichlet side), numbered patch by
        patch."""
        mesh, P, rows, nS = self.mesh, self.patches, self.rows, self.nS
        nF, nY, w = self.nF_loc, self.nY, self.w
        ne, nv_el = P.element_vertices.shape
        n_facets_el = P.element_facets.shape[1]
        self.hats = np.array([self.P1.GetDofNrs(ngs.NodeId(ngs.VERTEX, a))[0] for a in range(mesh.nv)],
                             dtype=np.int64)
        facet_count = len(P.facet_vertices)
        on_boundary = np.zeros(facet_count, dtype=bool)
        neumann = np.zeros((facet_count, rows), dtype=bool)
        for f, name in P.boundary_name.items():
            on_boundary[f] = True
            neumann[f] = [bool(self.neumann(name, i)) for i in range(rows)]
        pair_el = np.repeat(np.arange(ne), nv_el)
        pair_patch = P.element_vertices.ravel()
        pairs = len(pair_el)
        facets = P.element_facets[pair_el]                                 # (pairs, facets of an element)
        contains = (P.facet_vertices[facets] == pair_patch[:, None, None]).any(axis=2)
        fixed = contains[:, None, :] & neumann[facets].transpose(0, 2, 1)   # (pairs, rows, facets)
        free = contains[:, None, :] & ~fixed
        dirichlet_pair = (contains[:, None, :] & on_boundary[facets][:, None, :] & ~neumann[facets].transpose(0, 2, 1)
                          ).any(axis=2)                                     # (pairs, rows)
        dirichlet = np.zeros((mesh.nv, rows), dtype=bool)
        np.logical_or.at(dirichlet, pair_patch, dirichlet_pair)
        # keys of the unknowns: (patch, kind, id), kind 0 facet DOF (id row·nS + dof), 1 mean (id
        # element·rows + row), 2 border (id row); sorted they number the unknowns patch by patch
        big = max(rows * nS, ne * rows, rows) + 1
        key = lambda a, kind, ident: (a * 3 + kind) * big + ident
        dofs = self.facet_dofs[facets]                                      # (pairs, facets, w)
        row = np.arange(rows)[None, :, None, None]
        facet_keys = key(pair_patch[:, None, None, None], 0, row * nS + dofs[:, None, :, :])
        facet_keys = np.broadcast_to(facet_keys, (pairs, rows, n_facets_el, w))
        facet_free = np.broadcast_to(free[:, :, :, None], (pairs, rows, n_facets_el, w))
        mean_keys = key(pair_patch[:, None], 1, pair_el[:, None] * rows + np.arange(rows)[None, :])
        border_a, border_i = np.nonzero(~dirichlet)
        border_keys = key(border_a, 2, border_i)
        keys = np.unique(np.concatenate([facet_keys[facet_free], mean_keys.ravel(), border_keys]))
        self.size = len(keys)
        index = np.full((pairs, nY), -1, dtype=np.int64)
        index[:, :rows * nF] = np.where(facet_free, np.searchsorted(keys, facet_keys), -1).reshape(pairs, rows * nF)
        index[:, rows * nF:] = np.searchsorted(keys, mean_keys)
        self.pair_el, self.pair_patch, self.pair_index = pair_el, pair_patch, index
        facet_pos = np.searchsorted(keys, facet_keys[facet_free])
        self.free_system, first = np.unique(facet_pos, return_index=True)
        self.free_global = (np.broadcast_to(row * nS + dofs[:, None, :, :], facet_free.shape)[facet_free])[first]
        # the condensed element matrices of every pair into the system, and the borders
        S_pairs = self.S_cond[pair_el]
        keep = (index[:, :, None] >= 0) & (index[:, None, :] >= 0)
        r = np.broadcast_to(index[:, :, None], keep.shape)[keep]
        c = np.broadcast_to(index[:, None, :], keep.shape)[keep]
        v = S_pairs[keep]
        mean_mass = ngs.Integrate(ngs.CF(1.0), mesh, ngs.VOL, element_wise=True).NumPy()
        bordered = ~dirichlet[pair_patch]                                  # (pairs, rows)
        mean_pos = index[:, rows * nF:][bordered]
        border_pos = np.searchsorted(keys, key(np.broadcast_to(pair_patch[:, None], bordered.shape)[bordered], 2,
                                               np.broadcast_to(np.arange(rows)[None, :], bordered.shape)[bordered]))
        mass = np.broadcast_to(mean_mass[pair_el][:, None], bordered.shape)[bordered]
        self.system = sp.csc_matrix((np.concatenate([v, mass, mass]),
                                     (np.concatenate([r, mean_pos, border_pos]), np.concatenate([c, border_pos, mean_pos]))),
                                    shape=(self.size, self.size))
        self._lu = None
        # prescribed normal fluxes, in groups of w entries (one pair, row, facet) in the facet's DOF order
        fixed_full = np.broadcast_to(fixed[:, :, :, None], (pairs, rows, n_facets_el, w))
        p_idx, i_idx, f_idx, k_idx = np.nonzero(fixed_full)
        self.fixed_pairs = p_idx
        self.fixed_local = i_idx * nF + f_idx * w + k_idx
        self.fixed_global = i_idx * nS + dofs[p_idx, f_idx, k_idx]
        self.fixed_facet = facets[p_idx, f_idx]
        self._facet_blocks = {}
        if len(self.fixed_facet):
            n = ngs.specialcf.normal(mesh.dim)
            sigma, tau = self.S.TnT()
            boundary = ngs.BilinearForm(self.S)
            boundary += (sigma.Trace() * n) * (tau.Trace() * n) * ngs.ds
            Mb = csr(boundary.Assemble().mat, copy=True)
            for f in np.unique(self.fixed_facet):
                fd = list(self.facet_dofs[f])
                self._facet_blocks[int(f)] = (w, sla.cho_factor(Mb[fd][:, fd].toarray()))
        # the global DOFs of the X unknowns of every element (interior RT DOFs, P_p rest), per row
        interior_global = np.take_along_axis(self.el_sdofs, self.interior, axis=1)
        X_global = [interior_global + i * nS for i in range(rows)] + [self.el_qdofs[:, 1:] + i * self.nQ
                                                                      for i in range(rows)]
        self.X_global = np.concatenate(X_global, axis=1)        # (ne, nX)
        nI = self.nI_loc
        self.X_is_sigma = np.concatenate([np.ones(rows * nI, dtype=bool), np.zeros(self.nX - rows * nI, dtype=bool)])
        self.Y_mean_global = np.stack([self.el_qdofs[:, 0] + i * self.nQ for i in range(rows)], axis=1)

    # ------------------------------------------------------------------ one right-hand side
    def __call__(self, flux, source, traction):
        """σ* (a numpy array of the rows × nS coefficients) for the discrete flux ``flux``
        (rows × dim CoefficientFunction), the source f (``source``, a CF of ``rows``
        components: −div σ = f) and the Neumann data ``traction`` (a CF of ``rows`` components
        on the boundary, used where ``neumann`` says a row is prescribed)."""
        d, rows = self.mesh.dim, self.rows
        psi = self.P1.TrialFunction()
        tau = self.S.TestFunction()
        q = self.Q.TestFunction()
        flux = ngs.CF(flux, dims=(rows, d)) if rows > 1 else ngs.CF(flux, dims=(1, d))
        source = ngs.CF(source) if rows > 1 else ngs.CF((source,))
        traction = ngs.CF(traction) if rows > 1 else ngs.CF((traction,))
        rhs_w, rhs_div, rhs_t = [], [], []               # each: (DOFs of the row) × (hat functions)
        n = ngs.specialcf.normal(d)
        zero = ngs.CF((0,) * d)
        # W σ_h row by row, once as a plain CF (the weight is bilinear: its value on the unit
        # matrices), so that the forms below are linear in their proxies (3D: 8x faster)
        unit = lambda j, l: ngs.CF(tuple(1.0 if (k, m) == (j, l) else 0.0 for k in range(rows) for m in range(d)),
                                   dims=(rows, d))
        weighted = [ngs.CF(tuple(self._weight(flux, unit(j, l)) for l in range(d))).Compile() for j in range(rows)]
        for i in range(rows):
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
            form += psi * ngs.InnerProduct(weighted[i], tau) * ngs.dx
            rhs_w.append(csr(form.Assemble().mat, copy=True))
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.Q)
            form += (ngs.InnerProduct(flux[i, :], ngs.grad(psi)) - psi * source[i]) * q * ngs.dx(bonus_intorder=BONUS)
            rhs_div.append(csr(form.Assemble().mat, copy=True))
            if len(self.fixed_facet):
                form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
                form += psi * traction[i] * (tau.Trace() * n) * ngs.ds(bonus_intorder=BONUS)
                rhs_t.append(csr(form.Assemble().mat, copy=True))
        rhs_w, rhs_div = sp.vstack(rhs_w, format="csr"), sp.vstack(rhs_div, format="csr")
        hat_of_pair = self.hats[self.pair_patch]
        # the prescribed normal fluxes: Π(ψ_a t) facet by facet (groups of one row, patch, facet)
        x_fixed = np.zeros(0)
        if len(self.fixed_facet):
            rhs_t = sp.vstack(rhs_t, format="csr")
            x_fixed = _entries(rhs_t, self.fixed_global, hat_of_pair[self.fixed_pairs])
            for f, (size, chol) in self._facet_blocks.items():
                at = np.flatnonzero(self.fixed_facet == f)
                if len(at):
                    x_fixed[at] = sla.cho_solve(chol, x_fixed[at].reshape(-1, size).T).T.ravel()
        # X data of every pair (element-local), and Y data of the system's unknowns
        pairs = len(self.pair_el)
        X_glob = self.X_global[self.pair_el]                               # (pairs, nX)
        sig_x = self.X_is_sigma
        r_X = np.zeros((pairs, self.nX))
        r_X[:, sig_x] = _entries(rhs_w, X_glob[:, sig_x].ravel(),
                                 np.repeat(hat_of_pair, sig_x.sum())).reshape(pairs, -1)
        r_X[:, ~sig_x] = _entries(rhs_div, X_glob[:, ~sig_x].ravel(),
                                  np.repeat(hat_of_pair, (~sig_x).sum())).reshape(pairs, -1)
        rhs = np.zeros(self.size)
        # facet unknowns: the global data of the row's DOF at the patch's hat (once per unknown)
        patch_of_unknown = np.zeros(self.size, dtype=np.int64)
        patch_of_unknown[self.pair_index[self.pair_index >= 0]] = np.repeat(self.pair_patch, (self.pair_index >= 0).sum(1))
        rhs[self.free_system] = _entries(rhs_w, self.free_global, self.hats[patch_of_unknown[self.free_system]])
        # means: the element's data (row i) at the patch's hat
        means = self.pair_index[:, rows * self.nF_loc:]                  # (pairs, rows)
        rhs[means.ravel()] = _entries(rhs_div, self.Y_mean_global[self.pair_el].ravel(), np.repeat(hat_of_pair, rows))
        # known Y values of every pair: the prescribed fluxes (others 0 or unknown)
        y_known = np.zeros((pairs, self.nY))
        if len(x_fixed):
            y_known[self.fixed_pairs, self.fixed_local] = x_fixed
        # condensation: Y data − G r_X − K_YY-part of the known values (condensed S)
        S_pairs = self.S_cond[self.pair_el]
        cond = np.einsum("pyx,px->py", self.G[self.pair_el], r_X) + np.einsum("pyz,pz->py", S_pairs, y_known)
        valid = self.pair_index >= 0
        np.add.at(rhs, self.pair_index[valid], -cond[valid])
        if self._lu is None:
            self._lu = sla_sparse.splu(self.system)
        z = self._lu.solve(rhs)
        # every pair's Y, then its X by recovery: x = M⁻¹(r_X − K_XY y)
        y = np.where(valid, z[np.where(valid, self.pair_index, 0)], y_known)
        x = np.einsum("pxw,pw->px", self.Minv[self.pair_el],
                      r_X - np.einsum("pxy,py->px", self.K_XY[self.pair_el], y))
        result = np.zeros(rows * self.nS)
        np.add.at(result, self.free_global, z[self.free_system])
        if len(x_fixed):
            np.add.at(result, self.fixed_global, x_fixed)
        np.add.at(result, X_glob[:, sig_x].ravel(), x[:, sig_x].ravel())
        return result

    def gridfunctions(self, values):
        """The rows of σ* as GridFunctions of the RT space."""
        out = []
        for i in range(self.rows):
            gf = ngs.GridFunction(self.S)
            gf.vec.FV().NumPy()[:] = values[i * self.nS:(i + 1) * self.nS]
            out.append(gf)
        return out
