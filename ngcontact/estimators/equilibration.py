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

How it is computed. The element matrices of the RT components, (σ_k, τ_l)_K, and of
(div σ, q)_K come from NGSolve on the discontinuous copies of the spaces (blocks in each
element's own DOF order; the conforming matrices are their sums, exactly), once per mesh and
order (``ElementData``, shared by the equilibrations of a mesh, each block assembled when a
weight first needs it): the weight of one row is one assembled form, that of several rows a
combination of the components' blocks (``set_weight``). In each element the RT
DOFs inside it and the DOFs of zero mean of L² are eliminated once (static condensation: they
belong to that element alone in every patch problem), leaving its facet DOFs and its mean;
every patch problem is then a small system in the facet DOFs around its vertex and the means
of its elements, and all of them form one block-diagonal system (``block_diagonal``: batched
dense solves of the 2D blocks, SuperLU for the larger 3D ones), solved for every right-hand
side. The hat functions enter as the trial functions of a P1 space, so that every patch's data
is a column of an assembled matrix. No Python loop runs over patches or elements at solve time.
``Rows`` equilibrates fluxes row by row (a stress's rows and the electric displacement), the
rows sharing one patch system; a row with other boundary conditions has patch problems of its
own only at the vertices on the boundaries where they differ.
"""
import threading
from concurrent.futures import Future
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np

from ngcontact import meshes, parallel
from ngcontact.model.kinematics import mesh_ds, mesh_dx
from ngcontact.model.voigt import matrix_cf
from ngcontact.solve.linalg.matrices import csr
from .block_diagonal import BlockDiagonal, in_background

BONUS = 4
"""Extra quadrature order for the data (a source or traction that is not a polynomial)."""
TIMERS = {name: ngs.Timer(f"ngcontact estimate: {name}") for name in
          ("element data", "patch structure", "condensation", "right-hand sides", "block solves", "recovery")}
"""NGSolve timers of the equilibration's parts (read by ``studies.estimate_cost``; they decide nothing)."""


def all_cores():
    """NGSolve's TaskManager outside MPI (else nothing), for NGSolve work while the background
    thread is idle: element-wise integrals, each element's one thread's, so that their values
    do not depend on the threads."""
    return ngs.TaskManager() if parallel.world() is None else nullcontext()


def _unique(values, return_index=False):
    """np.unique of an integer array by one sort (NumPy 2.4's own np.unique is far costlier on
    the keys of a 3D patch system: docs/speed.md); with ``return_index``, also the position of
    each value's first occurrence."""
    order = np.argsort(values, kind="stable") if return_index else None
    ordered = values[order] if return_index else np.sort(values)
    first = np.r_[True, ordered[1:] != ordered[:-1]] if len(ordered) else np.zeros(0, dtype=bool)
    return (ordered[first], order[first]) if return_index else ordered[first]


def _gridfunctions(S, values, rows):
    """The ``rows`` consecutive blocks of ``values`` as GridFunctions of the space ``S``."""
    out = []
    for i in range(rows):
        gf = ngs.GridFunction(S)
        gf.vec.FV().NumPy()[:] = values[i * S.ndof:(i + 1) * S.ndof]
        out.append(gf)
    return out


def _entries(matrix, rows, cols):
    """matrix[rows[k], cols[k]] for every k (a CSR matrix; 0 where it has no entry)."""
    return np.asarray(matrix[rows, cols]).ravel() if len(rows) else np.zeros(0)


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


def _element_dofs(space, numbered=None):
    """The DOFs of every volume element of ``space`` in its local order (elements × DOFs):
    ``numbered`` (the table NGSolve's numbering gives, ``_numbered_dofs``) where it agrees with
    the space on ``SAMPLED_ELEMENTS`` elements spread over the mesh, else read element by element
    (a Python call per element: a quarter of a small 2D certificate)."""
    ne = space.mesh.ne
    if numbered is not None and numbered.shape[0] == ne and ne:
        sample = np.unique(np.linspace(0, ne - 1, SAMPLED_ELEMENTS).astype(int))
        if all(list(numbered[k]) == list(space.GetDofNrs(ngs.ElementId(ngs.VOL, int(k)))) for k in sample):
            return numbered
    return np.array([el.dofs for el in space.Elements(ngs.VOL)], dtype=np.int64)


SAMPLED_ELEMENTS = 64
"""Elements on which a DOF table from NGSolve's numbering is checked against the space."""


def _numbered_dofs(space, patches, kind):
    """The element DOF table that NGSolve's numbering gives, or None if the space's sizes do not
    fit it (``_element_dofs`` checks it): "hats" (H1, order 1: vertex k is DOF k), "L2" (each
    element's DOFs together, element by element), "RT" (HDiv: the facets' lowest-order DOFs are
    the facet numbers, then the higher-order DOFs of each facet of an element together, facet by
    facet, then each element's interior DOFs together, element by element; an element lists its
    facets' lowest DOFs, then their higher ones, then its interior, facets in its own order)."""
    mesh = space.mesh
    ne, nf = mesh.ne, mesh.nfacet
    if kind == "hats":
        return patches.element_vertices if space.ndof == mesh.nv else None
    first = list(space.GetDofNrs(ngs.ElementId(ngs.VOL, 0))) if ne else []
    if kind == "L2":
        n = len(first)
        return np.arange(ne * n, dtype=np.int64).reshape(ne, n) if space.ndof == ne * n else None
    facets = patches.element_facets                          # (ne, facets of an element), its order
    count = facets.shape[1]
    used = np.unique(facets)            # a refined mesh keeps its coarser facets: lowest DOF only
    rank = np.searchsorted(used, facets)
    # the element's DOFs: count lowest, count·(w − 1) higher, the interior
    for w in range(1, len(first) // count + 1):
        interior = len(first) - count * w
        if nf + (w - 1) * len(used) + ne * interior == space.ndof:
            higher = nf + (w - 1) * rank[:, :, None] + np.arange(w - 1)         # (ne, count, w − 1)
            inner = nf + (w - 1) * len(used) + interior * np.arange(ne)[:, None] + np.arange(interior)
            return np.concatenate([facets, higher.reshape(ne, -1), inner], axis=1).astype(np.int64)
    return None


def _facet_dofs(S, mesh, patches, el_dofs):
    """The DOFs of every facet of the RT space ``S`` (facets × w; -1 for the facets of a
    refined mesh's coarser levels, which have none), read from its element DOF table
    ``el_dofs`` (``_element_dofs``): an
    element lists its facets' DOFs at the same local positions whatever the element (read off
    element 0); checked on every element (two elements sharing a facet must agree), else asked
    facet by facet."""
    first = list(el_dofs[0])
    local = [[first.index(d) for d in S.GetDofNrs(f)] for f in meshes.facets_of(mesh, mesh[ngs.ElementId(ngs.VOL, 0)])]
    table = np.full((len(patches.facet_vertices), len(local[0])), -1, dtype=np.int64)
    for k, positions in enumerate(local):
        table[patches.element_facets[:, k]] = el_dofs[:, positions]
    if all(np.array_equal(table[patches.element_facets[:, k]], el_dofs[:, positions])
           for k, positions in enumerate(local)):
        return table
    lists = [list(S.GetDofNrs(ngs.NodeId(patches.facet_kind, f))) for f in range(len(table))]
    width = max(len(dofs) for dofs in lists)
    return np.array([dofs if len(dofs) == width else [-1] * width for dofs in lists], dtype=np.int64)


class ElementPatchData:
    """The patch data of one row as element arrays (``ElementData.constant_patch_data``):
    ``flux`` (ψ_a σ_h, τ_j)_K (elements × RT DOFs × vertices), ``div`` (σ_h ∇ψ_a − ψ_a f, q_m)_K
    (elements × P_p DOFs × vertices), ``boundary`` the assembled (ψ_a t, τ·n) or None."""

    def __init__(self, flux, div, boundary):
        self.flux, self.div, self.boundary = flux, div, boundary


class Patches:
    """The vertex patches of a mesh as arrays: the vertices and facets of every volume element
    (in NGSolve's local order), the vertices of every facet, and the boundary name of every
    boundary facet (``boundary_name``, facet number -> name). It keeps the element data of
    RT_p × P_p per order (``elements``), so that the equilibrations of one mesh share them."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.facet_kind = meshes.facet_kind(mesh)
        self.boundary_name = {}                       # facet number -> boundary name
        boundary_vertices = []
        for el in mesh.Elements(ngs.BND):
            self.boundary_name[meshes.facets_of(mesh, el)[0].nr] = el.mat
            boundary_vertices.append([v.nr for v in el.vertices])
        elements = list(mesh.Elements(ngs.VOL))
        self.element_vertices = np.array([[v.nr for v in el.vertices] for el in elements], dtype=np.int64)
        self.element_facets = np.array([[f.nr for f in meshes.facets_of(mesh, el)] for el in elements], dtype=np.int64)
        self.facet_vertices = self._facet_vertices(elements[0], np.array(boundary_vertices, dtype=np.int64))
        self._elements = {}

    def _facet_vertices(self, first, boundary_vertices):
        """The vertices of every facet (-1 for the facets of a refined mesh's coarser levels),
        read from the element tables: an element lists the vertices of its k-th facet at the same
        local positions whatever the element (read off the first one); checked on every facet
        (the elements sharing it, and the boundary elements, must agree), else asked facet by
        facet."""
        mesh, vertices, facets = self.mesh, self.element_vertices, self.element_facets
        local = [v.nr for v in first.vertices]
        positions = [[local.index(v.nr) for v in mesh[f].vertices] for f in meshes.facets_of(mesh, first)]
        table = np.full((mesh.nfacet, len(positions[0])), -1, dtype=np.int64)
        for k, at in enumerate(positions):
            table[facets[:, k]] = vertices[:, at]
        ordered = np.sort(table, axis=1)
        agree = all(np.array_equal(ordered[facets[:, k]], np.sort(vertices[:, at], axis=1))
                    for k, at in enumerate(positions))
        if agree and len(boundary_vertices):
            agree = np.array_equal(ordered[list(self.boundary_name)], np.sort(boundary_vertices, axis=1))
        if agree:
            return table
        return np.array([[v.nr for v in f.vertices] for f in meshes.facets(mesh)], dtype=np.int64)

    def vertices_on(self, names):
        """The vertices on the boundaries ``names`` (a boolean array over the vertices)."""
        out = np.zeros(self.mesh.nv, dtype=bool)
        facets = [f for f, name in self.boundary_name.items() if name in names]
        out[self.facet_vertices[facets].ravel()] = True
        return out

    def elements(self, order):
        """The ``ElementData`` of RT_order × P_order on this mesh (built once per order)."""
        if order not in self._elements:
            self._elements[order] = ElementData(self, order)
        return self._elements[order]


class ElementData:
    """What the local problems of one mesh and order share whatever their weight and rows: the
    spaces, the DOF tables, the element matrices M_kl = (σ_k, τ_l)_K of the RT components
    (k, l < dim; every constant weight is a combination of them) and B_K = (div σ, q)_K, each in
    the element's own DOF order, and the positions of the facet and interior DOFs in it."""

    def __init__(self, patches, order):
        mesh = patches.mesh
        self.mesh = mesh
        self.S = ngs.HDiv(mesh, order=order, RT=True)
        self.Q = ngs.L2(mesh, order=order)
        self.P1 = ngs.H1(mesh, order=1)
        self.P1d = ngs.Discontinuous(self.P1)
        self.Sd = ngs.Discontinuous(self.S)
        self._element_vertices, self._hat_moments, self._hat_gradients = patches.element_vertices, None, None
        sigma = self.Sd.TrialFunction()
        div = ngs.BilinearForm(trialspace=self.Sd, testspace=self.Q)
        div += mesh_dx(ngs.div(sigma) * self.Q.TestFunction())
        self.el_sdofs = _element_dofs(self.S, _numbered_dofs(self.S, patches, "RT"))
        self.el_qdofs = _element_dofs(self.Q, _numbered_dofs(self.Q, patches, "L2"))
        self.facet_dofs = _facet_dofs(self.S, mesh, patches, self.el_sdofs)   # (facets, w), -1: no DOFs
        self.hats = np.zeros(mesh.nv, dtype=np.int64)                    # the P1 DOF of every vertex
        self.hats[patches.element_vertices.ravel()] = _element_dofs(self.P1, _numbered_dofs(self.P1, patches,
                                                                                            "hats")).ravel()
        ne = mesh.ne
        on_element = self.facet_dofs[patches.element_facets].reshape(ne, -1)   # (ne, facets·w) global DOFs
        match = on_element[:, :, None] == self.el_sdofs[:, None, :]         # (ne, facets·w, nS_loc)
        self.facet_order = match.argmax(axis=2)                            # local positions, facet by facet
        self.interior = np.nonzero(~match.any(axis=1))[1].reshape(ne, -1)
        # NGSolve orders every element's DOFs alike (facet by facet, then the interior), so the
        # blocks are split into facet (F) and interior (I) parts once, by slices
        if not ((self.facet_order == self.facet_order[0]).all() and (self.interior == self.interior[0]).all()):
            raise ValueError("the equilibrated estimator needs one element type throughout the mesh (its elements "
                             "order their RT DOFs differently)")
        F, I = self.facet_order[0], self.interior[0]
        self._order, self._nF = np.concatenate([F, I]), len(F)              # local DOFs: facets, then interior
        self._weighted = {}                                 # weight -> (W σ, τ)_K, facets first
        self._condensed = (None, None)                      # (rows, weight), a future of the condensed matrices
        self._lock = threading.Lock()
        self._normal_trace_mass = None
        div = _element_blocks(div.Assemble(), mesh, self.Sd, self.Q)      # (ne, nQ_loc, nS_loc)
        self.div_F, self.div_I = div[:, :, F], div[:, :, I]
        self.mean_mass = ngs.Integrate(ngs.CF(1.0), mesh, ngs.VOL, element_wise=True).NumPy()

    def patch_data(self, flux, source, traction, rows, weight, with_traction):
        """The patch data of every hat function ψ_a (the columns) for a flux of ``rows`` rows
        (−div σ = f, σn = t; ``Equilibration.__call__``): the matrices (W ψ_a σ_h, τ),
        (σ_h ∇ψ_a − ψ_a f, q) and, with ``with_traction``, (ψ_a t, τ·n) on the boundary, rows
        stacked. They depend on the mesh, the order and the weight only, so equilibrations that
        share those share them."""
        TIMERS["right-hand sides"].Start()
        d = self.mesh.dim
        psi = self.P1.TrialFunction()
        tau = self.S.TestFunction()
        q = self.Q.TestFunction()
        flux = ngs.CF(flux, dims=(rows, d)) if rows > 1 else ngs.CF(flux, dims=(1, d))
        if source is not None:
            source = ngs.CF(source) if rows > 1 else ngs.CF((source,))
        traction = ngs.CF(traction) if rows > 1 else ngs.CF((traction,))
        rhs_w, rhs_div = [], []                          # each: (DOFs of the row) × (hat functions)
        # W σ_h row by row as a plain CF, so that the forms below are linear in their proxies
        W = weight
        weighted = [ngs.CF(tuple(sum(W[j * d + l, m] * flux[m // d, m % d] for m in range(rows * d) if W[j * d + l, m])
                                 for l in range(d))).Compile() for j in range(rows)]
        compiled = ngs.CF(flux.Compile(), dims=(rows, d))    # (evaluated at every point of the forms)
        for i in range(rows):
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
            form += mesh_dx(psi * ngs.InnerProduct(weighted[i], tau))
            rhs_w.append(csr(form.Assemble().mat, copy=True))
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.Q)
            balance = ngs.InnerProduct(compiled[i, :], ngs.grad(psi))
            if source is not None:
                balance = balance - psi * source[i]
            form += mesh_dx(balance * q, bonus_intorder=BONUS)
            rhs_div.append(csr(form.Assemble().mat, copy=True))
        rhs_t = self._traction_data(traction, rows) if with_traction else None
        import scipy.sparse as sp                     # (SciPy loads when an estimate is first made)
        TIMERS["right-hand sides"].Stop()
        return sp.vstack(rhs_w, format="csr"), sp.vstack(rhs_div, format="csr"), rhs_t

    def constant_patch_data(self, values, source, traction, with_traction):
        """The patch data of ``patch_data`` for one row (W = I) whose flux is constant on every
        element (``values``, elements × dim: σ_h of P1 on straight elements), as element arrays
        (``ElementPatchData``) instead of assembled matrices: (ψ_a σ_h, τ)_K = Σ_c σ_c(K)
        (ψ_a e_c, τ)_K from the kept ``hat_moments``, and (σ_h ∇ψ_a, q)_K = |K| σ_h(K)·∇ψ_a(K)
        for the mean q = 1 (0 for the DOFs of zero mean of L²), the source's part assembled."""
        TIMERS["right-hand sides"].Start()
        flux = np.einsum("ec,ejca->eja", values, self.hat_moments())
        div = np.zeros((self.mesh.ne, self.el_qdofs.shape[1], flux.shape[2]))
        div[:, 0, :] = self.mean_mass[:, None] * np.einsum("ec,eac->ea", values, self.hat_gradients())
        if source is not None:
            psi, q = self.P1d.TrialFunction(), self.Q.TestFunction()
            form = ngs.BilinearForm(trialspace=self.P1d, testspace=self.Q)
            form += mesh_dx(-psi * source * q, bonus_intorder=BONUS)
            div += _element_blocks(form.Assemble(), self.mesh, self.P1d, self.Q)
        boundary = self._traction_data(ngs.CF((traction,)), 1) if with_traction else None
        TIMERS["right-hand sides"].Stop()
        return ElementPatchData(flux, div, boundary)

    def hat_moments(self):
        """(ψ_a e_c, τ_j)_K of every element (elements × RT DOFs × dim × vertices; assembled at
        the first request, one form of a discontinuous P1 vector trial)."""
        if self._hat_moments is None:
            d = self.mesh.dim
            V = ngs.Discontinuous(ngs.VectorH1(self.mesh, order=1))
            form = ngs.BilinearForm(trialspace=V, testspace=self.Sd)
            form += mesh_dx(ngs.InnerProduct(V.TrialFunction(), self.Sd.TestFunction()))
            blocks = _element_blocks(form.Assemble(), self.mesh, V, self.Sd)        # (ne, nS_loc, dim·vertices)
            self._hat_moments = blocks.reshape(self.mesh.ne, blocks.shape[1], d, -1)
        return self._hat_moments

    def hat_gradients(self):
        """∇ψ_a on every (straight) element (elements × vertices × dim, 1/m), from its vertices
        (kept)."""
        if self._hat_gradients is None:
            points = meshes.vertex_points(self.mesh)[self._element_vertices]           # (ne, d + 1, d)
            edges = points[:, 1:, :] - points[:, :1, :]                                   # rows p_k − p_0
            inverse = np.linalg.inv(edges)                # λ_k = (x − p_0)·(column k of edges⁻¹)
            grads = np.transpose(inverse, (0, 2, 1))
            self._hat_gradients = np.concatenate([-grads.sum(axis=1, keepdims=True), grads], axis=1)
        return self._hat_gradients

    def _traction_data(self, traction, rows):
        """(ψ_a t_i, τ·n) on the boundary, rows stacked (CSR; ``patch_data``)."""
        import scipy.sparse as sp
        psi, tau, n = self.P1.TrialFunction(), self.S.TestFunction(), ngs.specialcf.normal(self.mesh.dim)
        out = []
        for i in range(rows):
            form = ngs.BilinearForm(trialspace=self.P1, testspace=self.S)
            form += mesh_ds(psi * traction[i] * (tau.Trace() * n), bonus_intorder=BONUS)
            out.append(csr(form.Assemble().mat, copy=True))
        return sp.vstack(out, format="csr")

    def normal_trace_mass(self):
        """The matrix of ∫_∂Ω (σ·n)(τ·n) on RT_p (CSR; assembled at the first request)."""
        if self._normal_trace_mass is None:
            n = ngs.specialcf.normal(self.mesh.dim)
            sigma, tau = self.S.TnT()
            boundary = ngs.BilinearForm(self.S)
            boundary += mesh_ds((sigma.Trace() * n) * (tau.Trace() * n))
            self._normal_trace_mass = csr(boundary.Assemble().mat, copy=True)
        return self._normal_trace_mass

    def condensed(self, key, make):
        """The element matrices an equilibration condenses for ``key`` (its rows and weight),
        made by ``make`` unless the last request had the same key: equilibrations of one mesh
        with the same rows and weight (the patch systems of one flux with different boundary
        conditions) share them. One is kept (a weight that follows the time step would
        otherwise keep one per step). A request from another thread while they are being made
        waits for them."""
        with self._lock:
            made_here = self._condensed[0] != key
            if made_here:
                self._condensed = (key, Future())
            future = self._condensed[1]
        if made_here:
            try:
                future.set_result(make())
            except BaseException as error:
                future.set_exception(error)
                raise
        return future.result()

    def mass(self, l, k):
        """(FF, FI, II) of M_kl = (σ_k, τ_l)_K, test component l, trial k: ``weighted_mass`` of
        the weight with the one entry W[l, k] = 1 (a weight that does not couple two components
        never asks for their block)."""
        unit = np.zeros((self.mesh.dim, self.mesh.dim))
        unit[l, k] = 1.0
        return self.weighted_mass(unit)

    def weighted_mass(self, weight):
        """(FF, FI, II) of (W σ, τ)_K for a constant (dim × dim) weight W, assembled as one form
        (kept per weight)."""
        weight = np.asarray(weight, dtype=float)
        key = weight.tobytes()
        if key not in self._weighted:
            sigma, tau = self.Sd.TnT()
            form = ngs.BilinearForm(self.Sd)
            form += mesh_dx(ngs.InnerProduct(matrix_cf(weight) * sigma, tau))
            block = _element_blocks(form.Assemble(), self.mesh, self.Sd, self.Sd)
            self._weighted[key] = block[:, self._order[:, None], self._order[None, :]]
        block, nF = self._weighted[key], self._nF
        return block[:, :nF, :nF], block[:, :nF, nF:], block[:, nF:, nF:]


class Equilibration:
    """Equilibrate fluxes of ``rows`` rows in RT_``order`` on ``mesh`` (module docstring).

    Parameters
    ----------
    mesh : ngsolve.Mesh (2D or 3D), one polynomial order throughout.
    rows : the number of rows (dim for a stress, 1 for a flux vector).
    order : p of RT_p (div in P_p); p = the order of the primal unknown suits.
    weight : the constant weight W of the local problems, a symmetric positive definite
        (rows·dim × rows·dim) array: W(σ, τ) = Σ W[j·dim + l, i·dim + k] σ_ik τ_jl for two
        ``rows`` × dim matrices (trial σ, test τ). ``set_weight`` changes it.
    neumann : function (boundary name, row) -> True where the row's flux is prescribed
        (traction or charge data), False where the row's primal unknown is (Dirichlet).
    patches : ``Patches`` of the mesh (shared between equilibrations of one mesh).
    vertices : None (every vertex patch) or a boolean array over the vertices: the patches to
        set up (σ* is then the sum over these patches only).
    """

    def __init__(self, mesh, rows, order, weight, neumann, patches=None, vertices=None, later=False):
        self.mesh, self.rows, self.order = mesh, int(rows), int(order)
        self.vertices = None if vertices is None else np.asarray(vertices, dtype=bool)
        with TIMERS["element data"]:
            self.patches = patches or Patches(mesh)
            self.data = self.patches.elements(self.order)
        self.S, self.Q, self.P1 = self.data.S, self.data.Q, self.data.P1
        self.nS, self.nQ = self.S.ndof, self.Q.ndof
        self.neumann = neumann
        self._structure()
        self.weight = self._checked(weight)
        if not later:                           # (later: the caller calls set_up, possibly elsewhere)
            self.set_up()

    def set_up(self):
        """Number the patch problems and fill their system (the constructor does it unless
        ``later``; NumPy only, so a background thread may do it)."""
        with TIMERS["patch structure"]:
            self._patch_structure()
        self.set_weight(self.weight)

    def condense(self):
        """The condensed element matrices of the weight, made now (``ElementData.condensed``:
        another thread's ``set_up`` then reads them)."""
        rows, d = self.rows, self.mesh.dim
        return self.data.condensed((rows, self.weight.tobytes()),
                                   lambda: self._condense(self.weight.reshape(rows, d, rows, d)))

    # ------------------------------------------------------------------ element level
    def _structure(self):
        """The order of every element's local unknowns: rows × (facet DOFs, interior DOFs) of
        RT_p, rows × (mean, rest) of P_p, split into Y (facet DOFs, means: shared by the
        elements of a patch) and X (the rest: eliminated element by element)."""
        rows, data = self.rows, self.data
        nS_loc, nQ_loc = data.el_sdofs.shape[1], data.el_qdofs.shape[1]
        facet_order, interior = data.facet_order, data.interior
        nF, nI = facet_order.shape[1], interior.shape[1]
        self.w = data.facet_dofs.shape[1]
        self.nF_loc, self.nI_loc, self.nQ_loc, self.nS_loc = nF, nI, nQ_loc, nS_loc
        self.nY, self.nX = rows * (nF + 1), rows * (nI + nQ_loc - 1)

    def _checked(self, weight):
        """``weight`` as a (rows·dim × rows·dim) float array, else a TypeError or ValueError."""
        rows, d = self.rows, self.mesh.dim
        if callable(weight) or np.asarray(weight).dtype.kind not in "iuf":
            raise TypeError(f"Equilibration: weight must be a ({rows * d}, {rows * d}) array of numbers, got "
                            f"{type(weight).__name__}")
        weight = np.asarray(weight, dtype=float)
        if weight.shape != (rows * d, rows * d):
            raise ValueError(f"Equilibration: weight must be a ({rows * d}, {rows * d}) array (rows · dim), got shape "
                             f"{weight.shape}")
        return weight

    def set_weight(self, weight):
        """Use the weight ``weight`` (the class docstring): recombine the kept element matrices,
        condense them and fill the patch system (its factorisation is made at the next call)."""
        self.weight = self._checked(weight)
        with TIMERS["condensation"]:
            self.K_XY, self.Minv, self.G, self.S_cond = self.condense()
            # the columns of S_K that multiply the prescribed fluxes, one per prescribed value
            self._S_fixed = self.S_cond[self.pair_el[self.fixed_pairs], :, self.fixed_local]
            gather, border_values = self._pattern
            self.system.fill(np.concatenate([self.S_cond.reshape(-1), border_values]), gather)

    def _condense(self, weight):
        """(K_XY, M⁻¹, G, S) of every element for the weight [j, l, i, k]: M⁻¹ = K_XX⁻¹, the
        condensed S_K = K_YY − K_YX M⁻¹ K_XY and G_K = K_YX M⁻¹."""
        K_YY, K_YX, K_XX = self._blocks(weight)
        K_XY = np.ascontiguousarray(np.transpose(K_YX, (0, 2, 1)))     # K is symmetric
        Minv = np.linalg.inv(K_XX)
        G = K_YX @ Minv
        return K_XY, Minv, G, K_YY - G @ K_XY

    def _blocks(self, weight):
        """K_YY, K_YX, K_XX of every element by slices of the split element blocks
        (``ElementData``): Y = rows × facet DOFs, then the rows' means; X = rows × interior
        DOFs, then the rows' P_p rests."""
        rows, data = self.rows, self.data
        nF, nI, nR, ne = self.nF_loc, self.nI_loc, self.nQ_loc - 1, self.mesh.ne
        K_YY, K_YX = np.zeros((ne, self.nY, self.nY)), np.zeros((ne, self.nY, self.nX))
        K_XX = np.zeros((ne, self.nX, self.nX))
        F = lambda i: slice(i * nF, (i + 1) * nF)
        I = lambda i: slice(i * nI, (i + 1) * nI)
        R = lambda i: slice(rows * nI + i * nR, rows * nI + (i + 1) * nR)

        d = self.mesh.dim
        pairs = [(l, k) for l in range(d) for k in range(d) if np.any(weight[:, l, :, k])]

        if rows == 1:                                   # one assembled block per weight
            def weighted(part):
                return data.weighted_mass(weight[0, :, 0, :])[part]
        else:
            weighted = self._component_sum(weight, pairs)
        K_YY[:, :rows * nF, :rows * nF] = weighted(0)
        K_YX[:, :rows * nF, :rows * nI] = weighted(1)
        K_XX[:, :rows * nI, :rows * nI] = weighted(2)
        for i in range(rows):
            m = rows * nF + i
            K_YY[:, F(i), m] = K_YY[:, m, F(i)] = data.div_F[:, 0, :]
            K_YX[:, m, I(i)] = data.div_I[:, 0, :]
            K_YX[:, F(i), R(i)] = np.transpose(data.div_F[:, 1:, :], (0, 2, 1))
            K_XX[:, I(i), R(i)] = np.transpose(data.div_I[:, 1:, :], (0, 2, 1))
            K_XX[:, R(i), I(i)] = data.div_I[:, 1:, :]
        return K_YY, K_YX, K_XX

    def _component_sum(self, weight, pairs):
        """The weighted blocks of several rows from the component blocks M_kl of ``pairs``."""
        rows, data, ne = self.rows, self.data, self.mesh.ne

        def weighted(part):
            """Σ_lk weight[j, l, i, k] M_kl's ``part`` as (elements, rows·a, rows·b), row-blocks j, i,
            over the component pairs the weight couples."""
            summed = None
            for l, k in pairs:
                block = data.mass(l, k)[part]                              # (elements, a, b)
                term = np.multiply.outer(weight[:, l, :, k], block)         # (j, i, elements, a, b)
                summed = term if summed is None else summed + term
            _, _, _, a, b = summed.shape
            return summed.transpose(2, 0, 3, 1, 4).reshape(ne, rows * a, rows * b)
        return weighted

    # ------------------------------------------------------------------ patch level
    def _patch_structure(self):
        """The block-diagonal system of all condensed patch problems, and the maps from
        (element, patch) pairs to its unknowns, built with arrays: the unknowns of a patch are its
        facet DOFs around its vertex (row by row, not prescribed), its elements' means (row by
        row) and the multipliers of ∫ r_i = 0 (rows without a Dirichlet side), numbered patch by
        patch."""
        mesh, P, rows, nS, data = self.mesh, self.patches, self.rows, self.nS, self.data
        nF, nY, w = self.nF_loc, self.nY, self.w
        ne, nv_el = P.element_vertices.shape
        n_facets_el = P.element_facets.shape[1]
        self.hats = data.hats
        facet_count = len(P.facet_vertices)
        on_boundary = np.zeros(facet_count, dtype=bool)
        neumann = np.zeros((facet_count, rows), dtype=bool)
        of_name = {name: [bool(self.neumann(name, i)) for i in range(rows)] for name in set(P.boundary_name.values())}
        boundary_facets = np.fromiter(P.boundary_name, dtype=np.int64, count=len(P.boundary_name))
        on_boundary[boundary_facets] = True
        if len(boundary_facets):
            neumann[boundary_facets] = [of_name[name] for name in P.boundary_name.values()]
        pair_el = np.repeat(np.arange(ne), nv_el)
        pair_patch = P.element_vertices.ravel()
        pair_local = np.tile(np.arange(nv_el), ne)                         # the patch's vertex in the element
        self.every_pair = self.vertices is None                           # pairs are then element-major
        if not self.every_pair:
            chosen = self.vertices[pair_patch]
            pair_el, pair_patch, pair_local = pair_el[chosen], pair_patch[chosen], pair_local[chosen]
        self.pair_local = pair_local
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
        dofs = data.facet_dofs[facets]                                      # (pairs, facets, w)
        row = np.arange(rows)[None, :, None, None]
        facet_keys = key(pair_patch[:, None, None, None], 0, row * nS + dofs[:, None, :, :])
        facet_keys = np.broadcast_to(facet_keys, (pairs, rows, n_facets_el, w))
        facet_free = np.broadcast_to(free[:, :, :, None], (pairs, rows, n_facets_el, w))
        mean_keys = key(pair_patch[:, None], 1, pair_el[:, None] * rows + np.arange(rows)[None, :])
        set_up = np.ones(mesh.nv, dtype=bool) if self.every_pair else self.vertices
        border_a, border_i = np.nonzero(~dirichlet & set_up[:, None])
        border_keys = key(border_a, 2, border_i)
        keys = _unique(np.concatenate([facet_keys[facet_free], mean_keys.ravel(), border_keys]))
        self.size = len(keys)
        facet_pos = np.searchsorted(keys, facet_keys[facet_free])
        number = np.int32 if self.size < 2 ** 31 else np.int64           # (the system's unknowns)
        index = np.full((pairs, nY), -1, dtype=number)
        facet_index = np.full(facet_free.shape, -1, dtype=number)
        facet_index[facet_free] = facet_pos
        index[:, :rows * nF] = facet_index.reshape(pairs, rows * nF)
        index[:, rows * nF:] = np.searchsorted(keys, mean_keys)
        self.pair_el, self.pair_patch, self.pair_index = pair_el, pair_patch, index
        self.pairs_per_element = nv_el
        self.free_system, first = _unique(facet_pos, return_index=True)
        self.free_global = (np.broadcast_to(row * nS + dofs[:, None, :, :], facet_free.shape)[facet_free])[first]
        valid = index >= 0
        self.patch_of_unknown = np.zeros(self.size, dtype=np.int64)
        self.patch_of_unknown[index[valid]] = np.repeat(pair_patch, valid.sum(1))
        # where the condensed element matrices of every pair go in the system, and the borders
        # (one flatnonzero of the (pair, local row, local column) mask q = (pair nY + row) nY + column;
        # in the elements' condensed matrices, ne × nY × nY, the same entry is at q − (pair − its element) nY²)
        # (int32 arithmetic where it fits: these arrays have an entry per entry of the system)
        n2 = nY * nY
        small = np.int32 if pairs * n2 < 2 ** 31 else np.int64
        q = np.flatnonzero((valid[:, :, None] & valid[:, None, :]).ravel()).astype(small)
        pair_of_q = q // small(n2)
        local = q - pair_of_q * small(n2)                                  # row · nY + column
        del q
        row_of_q = local // small(nY)
        flat_index, start = index.ravel(), pair_of_q * small(nY)
        r = flat_index[start + row_of_q]
        c = flat_index[start + (local - row_of_q * small(nY))]
        keep = pair_el.astype(small)[pair_of_q] * small(n2) + local
        del start, row_of_q, local, pair_of_q
        bordered = ~dirichlet[pair_patch]                                  # (pairs, rows)
        mean_pos = index[:, rows * nF:][bordered]
        border_pos = np.searchsorted(keys, key(np.broadcast_to(pair_patch[:, None], bordered.shape)[bordered], 2,
                                               np.broadcast_to(np.arange(rows)[None, :], bordered.shape)[bordered]
                                               )).astype(number)
        mass = np.broadcast_to(data.mean_mass[pair_el][:, None], bordered.shape)[bordered]
        self.system = BlockDiagonal(keys // (3 * big), np.concatenate([r, mean_pos, border_pos]),
                                    np.concatenate([c, border_pos, mean_pos]))       # one block per patch
        # the entries' values: the condensed element matrices' at ``keep``, then the borders'
        self._pattern = (np.concatenate([keep, ne * n2 + np.arange(2 * len(mass), dtype=keep.dtype)]),
                         np.concatenate([mass, mass]))
        # prescribed normal fluxes, in groups of w entries (one pair, row, facet) in the facet's DOF order
        fixed_full = np.broadcast_to(fixed[:, :, :, None], (pairs, rows, n_facets_el, w))
        p_idx, i_idx, f_idx, k_idx = np.nonzero(fixed_full)
        self.fixed_pairs = p_idx
        self.fixed_local = i_idx * nF + f_idx * w + k_idx
        self.fixed_global = i_idx * nS + dofs[p_idx, f_idx, k_idx]
        self.fixed_facet = facets[p_idx, f_idx]
        self._facet_inverse = None
        if len(self.fixed_facet):
            Mb = data.normal_trace_mass()
            # the normal-trace mass matrix of every prescribed facet (w × w), inverted once; the
            # prescribed values come in groups of w (one pair, row and facet)
            groups = self.fixed_facet[::w]
            facets, self._facet_group = np.unique(groups, return_inverse=True)
            fd = data.facet_dofs[facets]
            blocks = _entries(Mb, np.repeat(fd, w, axis=1).ravel(), np.tile(fd, (1, w)).ravel())
            self._facet_inverse = np.linalg.inv(blocks.reshape(len(facets), w, w))
        # the global DOFs of the X unknowns of every element (interior RT DOFs, P_p rest), per row
        interior_global = np.take_along_axis(data.el_sdofs, data.interior, axis=1)
        X_global = [interior_global + i * nS for i in range(rows)] + [data.el_qdofs[:, 1:] + i * self.nQ
                                                                      for i in range(rows)]
        self.X_global = np.concatenate(X_global, axis=1)        # (ne, nX)
        nI = self.nI_loc
        self.X_is_sigma = np.concatenate([np.ones(rows * nI, dtype=bool), np.zeros(self.nX - rows * nI, dtype=bool)])
        self.Y_mean_global = np.stack([data.el_qdofs[:, 0] + i * self.nQ for i in range(rows)], axis=1)

    # ------------------------------------------------------------------ one right-hand side
    def __call__(self, flux, source, traction):
        """σ* (a numpy array of the rows × nS coefficients) for the discrete flux ``flux``
        (rows × dim CoefficientFunction), the source f (``source``, a CF of ``rows``
        components: −div σ = f; None for none) and the Neumann data ``traction`` (a CF of ``rows`` components
        on the boundary, used where ``neumann`` says a row is prescribed)."""
        rhs, data = self.right_hand_side(flux, source, traction)
        with TIMERS["block solves"]:
            z = self.system.solve(rhs)
        return self.recover(z, data)

    def data_matrices(self, flux, source, traction, with_traction=None):
        """The patch data of every hat function ψ_a for the arguments of ``__call__``
        (``ElementData.patch_data`` with this equilibration's rows and weight; the boundary's
        where normal fluxes are prescribed, or ``with_traction``)."""
        return self.data.patch_data(flux, source, traction, self.rows, self.weight,
                                    len(self.fixed_facet) > 0 if with_traction is None else with_traction)

    def right_hand_side(self, flux, source, traction, matrices=None):
        """(the patch system's right-hand side, the data ``recover`` needs) for the arguments of
        ``__call__``, or from their ``data_matrices`` (``matrices``)."""
        matrices = matrices or self.data_matrices(flux, source, traction)
        TIMERS["right-hand sides"].Start()
        element_wise = isinstance(matrices, ElementPatchData)
        rhs_t = matrices.boundary if element_wise else matrices[2]
        rows, hat_of_pair = self.rows, self.hats[self.pair_patch]
        # the prescribed normal fluxes: Π(ψ_a t) facet by facet (groups of one row, patch, facet)
        x_fixed = np.zeros(0)
        if len(self.fixed_facet):
            x_fixed = _entries(rhs_t, self.fixed_global, hat_of_pair[self.fixed_pairs])
            w = self.w
            x_fixed = np.einsum("gkl,gl->gk", self._facet_inverse[self._facet_group], x_fixed.reshape(-1, w)).ravel()
        # X data of every pair (element-local), and Y data of the system's unknowns
        pairs = len(self.pair_el)
        X_glob = self.X_global[self.pair_el]                               # (pairs, nX)
        sig_x = self.X_is_sigma
        rhs = np.zeros(self.size)
        means = self.pair_index[:, rows * self.nF_loc:]                  # (pairs, rows)
        if element_wise:                    # (one row: the pair's element and vertex index the arrays)
            el, at = self.pair_el[:, None], self.pair_local[:, None]
            r_X = np.concatenate([matrices.flux[el, self.data.interior[0][None, :], at],
                                  matrices.div[el, np.arange(1, self.nQ_loc)[None, :], at]], axis=1)
            facets = self.pair_index[:, :self.nF_loc]
            on = facets >= 0                # a facet unknown: the data of the elements around its facet
            rhs += np.bincount(facets[on], weights=matrices.flux[el, self.data.facet_order[0][None, :], at][on],
                               minlength=self.size)
            rhs[means.ravel()] = matrices.div[self.pair_el, 0, self.pair_local]
        else:
            rhs_w, rhs_div = matrices[0], matrices[1]
            r_X = np.zeros((pairs, self.nX))
            r_X[:, sig_x] = _entries(rhs_w, X_glob[:, sig_x].ravel(),
                                     np.repeat(hat_of_pair, sig_x.sum())).reshape(pairs, -1)
            r_X[:, ~sig_x] = _entries(rhs_div, X_glob[:, ~sig_x].ravel(),
                                      np.repeat(hat_of_pair, (~sig_x).sum())).reshape(pairs, -1)
            # facet unknowns: the global data of the row's DOF at the patch's hat (once per unknown)
            rhs[self.free_system] = _entries(rhs_w, self.free_global,
                                             self.hats[self.patch_of_unknown[self.free_system]])
            # means: the element's data (row i) at the patch's hat
            rhs[means.ravel()] = _entries(rhs_div, self.Y_mean_global[self.pair_el].ravel(),
                                          np.repeat(hat_of_pair, rows))
        # condensation: Y data − G r_X − S_K y_known, y_known the prescribed fluxes (others 0)
        cond = self._per_pair(self.G, r_X)
        y_known = np.zeros((pairs, self.nY))
        if len(x_fixed):
            y_known[self.fixed_pairs, self.fixed_local] = x_fixed
            nY = self.nY
            at = (self.fixed_pairs[:, None] * nY + np.arange(nY)[None, :]).ravel()
            cond += np.bincount(at, weights=(self._S_fixed * x_fixed[:, None]).ravel(),
                                minlength=cond.size).reshape(cond.shape)
        valid = self.pair_index >= 0
        rhs -= np.bincount(self.pair_index[valid], weights=cond[valid], minlength=self.size)
        TIMERS["right-hand sides"].Stop()
        return rhs, (r_X, x_fixed, y_known, X_glob)

    def _per_pair(self, element_matrices, vectors):
        """element_matrices[e] @ vectors[p] for every pair p of element e (element-major pairs
        without copies of the matrices)."""
        if self.every_pair:
            ne, k = self.mesh.ne, self.pairs_per_element
            return np.einsum("eab,ekb->eka", element_matrices, vectors.reshape(ne, k, -1)).reshape(len(vectors), -1)
        return np.einsum("pab,pb->pa", element_matrices[self.pair_el], vectors)

    def recover(self, z, data, exclude=None):
        """σ* from the patch system's solution ``z`` for the right-hand side of ``data``; with
        ``exclude`` (a boolean array over the vertices), without the patches of those vertices."""
        r_X, x_fixed, y_known, X_glob = data
        valid, sig_x = self.pair_index >= 0, self.X_is_sigma
        TIMERS["recovery"].Start()
        # every pair's Y, then its X by recovery: x = M⁻¹(r_X − K_XY y)
        y = np.where(valid, z[np.where(valid, self.pair_index, 0)], y_known)
        x = self._per_pair(self.Minv, r_X - self._per_pair(self.K_XY, y))
        facet_values = z[self.free_system]
        if exclude is not None:
            dropped = exclude[self.pair_patch]
            x[dropped] = 0.0
            facet_values = np.where(exclude[self.patch_of_unknown[self.free_system]], 0.0, facet_values)
            x_fixed = np.where(dropped[self.fixed_pairs], 0.0, x_fixed) if len(x_fixed) else x_fixed
        result = np.zeros(self.rows * self.nS)
        np.add.at(result, self.free_global, facet_values)
        if len(x_fixed):
            np.add.at(result, self.fixed_global, x_fixed)
        np.add.at(result, X_glob[:, sig_x].ravel(), x[:, sig_x].ravel())
        TIMERS["recovery"].Stop()
        return result

    def gridfunctions(self, values):
        """The rows of σ* as GridFunctions of the RT space."""
        return _gridfunctions(self.S, values, self.rows)


class Rows:
    """Fluxes of ``rows`` rows (the stress's, and the electric displacement as one more row)
    equilibrated row by row (the module docstring with the plain L² distance, W = I): each row's
    local problems are those of one row, so the rows share one patch system and its
    factorisation (``base``). A patch then has the facet DOFs and means of one row, not of all
    ``rows`` (docs/speed.md). A row whose boundary conditions differ from the first row's
    differ only on the patches of the vertices on the boundaries where they differ: those
    patches get a system of their own (``variants``, one per pattern of boundary conditions),
    the others are read from the shared one. The shared system is numbered and factorised by
    a background thread (``block_diagonal.in_background``) while this one condenses the element
    matrices and ``__call__`` assembles the patch data. The rows are not coupled by a weight (the
    compliance, a penalty on the skew part): σ* is the row-wise nearest equilibrated flux,
    which the Prager–Synge bound takes as well as any (``estimators.equilibrated``).

    ``neumann(name, row)`` as for ``Equilibration``; ``gridfunctions`` as there.
    """

    def __init__(self, mesh, rows, order, neumann, patches=None):
        self.rows = int(rows)
        patches = patches or Patches(mesh)
        names = sorted(set(patches.boundary_name.values()))
        self.patterns = [tuple(bool(neumann(name, i)) for name in names) for i in range(self.rows)]
        unit = np.eye(mesh.dim)
        # what NGSolve makes, here; the patch systems (NumPy, SciPy) in the background, while
        # the caller assembles the element mass, condenses and assembles the patch data (``__call__``)
        self.data = patches.elements(order)
        self.with_traction = any(any(pattern) for pattern in self.patterns)   # some flux prescribed
        if self.with_traction:
            self.data.normal_trace_mass()           # (the numbering reads it)
        self._differing = {}                            # pattern -> the vertices where it differs
        for pattern in self.patterns:
            if pattern != self.patterns[0] and pattern not in self._differing:
                vertices = patches.vertices_on({name for name, a, b in zip(names, self.patterns[0], pattern) if a != b})
                if vertices.any():
                    self._differing[pattern] = vertices
        self._make = lambda i, vertices=None, later=False: Equilibration(
            mesh, 1, order, unit, lambda name, _: neumann(name, i), patches, vertices, later)
        base = self._make(0, later=True)
        self._base, self._variants = in_background(lambda: (base.set_up(), base)[1]), None
        base.condense()                                 # (here, while the worker numbers the patches)
        self.S = self.data.S

    @property
    def base(self):
        """The shared patch system's ``Equilibration`` (set up in the background)."""
        return self._base.result()

    @property
    def variants(self):
        """Boundary pattern -> (its vertices, the ``Equilibration`` of their patches), set up
        at the first request, in this thread (the background one factorises the shared system
        meanwhile)."""
        if self._variants is None:
            self._base.result()                         # (its condensed element matrices serve these too)
            self._variants = {pattern: (vertices, self._make(self.patterns.index(pattern), vertices))
                              for pattern, vertices in self._differing.items()}
        return self._variants

    @property
    def of_row(self):
        """Per row: None (the shared system only) or (vertices, their own ``Equilibration``)."""
        return [self.variants.get(pattern) for pattern in self.patterns]

    def __call__(self, fluxes, sources, tractions, constants=None):
        """σ* (rows × nS coefficients) for the rows' fluxes (CFs of dim components), sources (−div
        σ_i = f_i; None for none) and Neumann data (CFs on the boundary), as
        ``Equilibration.__call__`` row by row. ``constants``: None, or per row the flux's value
        on every element (elements × dim) when it is constant on each of them and the elements
        are straight; the patch data are then element arrays, not assembled."""
        # the patch data of a row, made once (the variants read the base's)
        if constants is None:
            matrices = [self.data.patch_data(*row, 1, np.eye(self.S.mesh.dim), self.with_traction) for row in
                        zip(fluxes, sources, tractions)]
        else:
            matrices = [self.data.constant_patch_data(values, source, traction, self.with_traction)
                        for values, source, traction in zip(constants, sources, tractions)]
        base, of_row = self.base, self.of_row           # (the variants set up while the base factorises)
        data = [base.right_hand_side(None, None, None, m) for m in matrices]
        own = [None if variant is None else variant[1].right_hand_side(None, None, None, m)
               for variant, m in zip(of_row, matrices)]
        with TIMERS["block solves"]:                    # the shared system once, the rows as its columns
            z = base.system.solve(np.stack([rhs for rhs, _ in data], axis=1))
        out = []
        for i, variant in enumerate(of_row):
            if variant is None:
                out.append(base.recover(z[:, i], data[i][1]))
                continue
            vertices, equilibration = variant
            with TIMERS["block solves"]:
                z_own = equilibration.system.solve(own[i][0])
            out.append(base.recover(z[:, i], data[i][1], exclude=vertices) + equilibration.recover(z_own, own[i][1]))
        return np.concatenate(out)

    def gridfunctions(self, values):
        """The rows of σ* as GridFunctions of the RT space."""
        return _gridfunctions(self.S, values, self.rows)
