"""The contact side Γ3: the space B^h of (4.1), the L² projection P_B, and sampling.

B^h (piecewise constants on the facets of Γ3) is an order-0 ``FacetFESpace`` on all
facets, compressed to the facets of Γ3: a space defined only on Γ3 evaluates to zero
inside ``ds(skeleton=True)`` forms, where the Nitsche terms live, without an error
(NGSolve 6.2; tests/test_adhesion.py keeps the trap in view).
P_B of a CoefficientFunction is its facet average, assembled as a LinearForm over
``ds(skeleton=True)`` so that volume gradients (stresses) may appear in it.
"""
import ngsolve as ngs
import numpy as np

from ngcontact import meshes


def elements_at(mesh, region):
    """BitArray of the volume elements that have a facet on the boundary ``region``."""
    elements = ngs.BitArray(mesh.ne)
    elements.Clear()
    for el in region.Elements():
        for facet in meshes.facets_of(mesh, el):
            for volume in mesh[facet].elements:
                elements.Set(volume.nr)
    return elements


def element_boundary_layer(kinematics, mesh, region, bonus_intorder=0):
    """(integral, indicator) for integrals over the boundary ``region`` that need the volume
    element's gradients and may be statically condensed: ``integral(indicator * f)``
    integrates f over the element boundaries of the volume elements at ``region`` on the
    ``kinematics``' measure (``Kinematics.dx`` with ``element_boundary=True``,
    ``bonus_intorder`` more quadrature orders), where the indicator (order-0 facet
    GridFunction) is 1 on the facets of ``region`` and 0 elsewhere."""
    elements = elements_at(mesh, region)
    indicator = ngs.GridFunction(ngs.FacetFESpace(mesh, order=0), name="indicator")
    indicator.Set(1.0, definedon=region)

    def integral(integrand, weighted=True):
        return kinematics.dx(integrand, weighted=weighted, element_boundary=True, definedonelements=elements,
                             bonus_intorder=bonus_intorder)
    return integral, indicator


class ContactSide:
    """Γ3 of a Body: facets, B^h, P_B, facet normals and points along Γ3."""

    def __init__(self, body):
        mesh, names = body.mesh, set(body.boundaries["contact_side"])
        if not names:
            raise ValueError("the body has no contact side Γ3: pass contact_side='...' to Body")
        self.mesh, self.dim = mesh, body.dim
        self.kinematics = kin = body.kinematics
        region = body.region("contact_side")
        # the same integrals over the volume elements at Γ3 only: ∫ indicator · f on their
        # element boundaries (ds(skeleton=True) visits every facet of the mesh)
        self.on_layer, self.indicator = element_boundary_layer(kin, mesh, region)
        self.elements = elements_at(mesh, region)     # the volume elements at Γ3
        # P_B and the recorded integrals: exact for polynomials of degree 2p + 2 on a facet;
        # the residual's Γ3 terms: order 2p, NGSolve's default for a test function of order p
        # (the recorded contact pressure then integrates to the force)
        orders = {"default": 0, "exact": 2 * body.order + 2, "residual": 2 * max(body.order, body.order_phi)}

        def on_facets(integrand, quadrature="default", weighted=True):
            return kin.ds(integrand, weighted=weighted, skeleton=True, definedon=region,
                          bonus_intorder=orders[quadrature])
        self.on_facets = on_facets
        facets = ngs.FacetFESpace(mesh, order=0)
        active = ngs.BitArray(facets.ndof)
        active.Clear()
        elements = [el for el in mesh.Elements(ngs.BND) if el.mat in names]
        # the DOF of each facet of Γ3, read off the space's element table (GetDofNrs per
        # element is a slow call per element)
        dofs = [el.dofs[0] for el in facets.Elements(ngs.BND)]
        self._facet_dof = {el.nr: dofs[el.nr] for el in elements}
        for el in elements:
            active.Set(self._facet_dof[el.nr])
        self.B = ngs.Compress(facets, active_dofs=active)
        self._mu = self.B.TestFunction()
        # |facet| per dof of B^h (m; m² in 3D), and its measure in the body's integrals (for a
        # body of revolution the area 2π ∫ r ds the facet sweeps)
        self.measure = self.facet_integrals(ngs.CF(1.0), weighted=False)()
        self.weighted_measure = self.measure if kin.weight is None else self._integrate(ngs.CF(1.0))
        # per dof of B^h: vertex numbers and coordinates of its facet
        order = {d: i for i, d in enumerate(np.flatnonzero(np.array(list(active))))}
        points = np.array([v.point for v in mesh.vertices]) if mesh.nv else np.zeros((0, self.dim))
        self.facet_vertex_numbers = np.zeros((self.B.ndof, self.dim), dtype=int)
        self.facet_elements = np.zeros(self.B.ndof, dtype=int)     # the volume element of each facet
        for el in elements:
            self.facet_elements[order[self._facet_dof[el.nr]]] = mesh[meshes.facets_of(mesh, el)[0]].elements[0].nr
            self.facet_vertex_numbers[order[self._facet_dof[el.nr]]] = [v.nr for v in el.vertices]
        self.facet_vertices = points[self.facet_vertex_numbers]
        self.midpoints = self.facet_vertices.mean(axis=1)
        # the Gauss points of the residual's order 2p on each facet (B^h's order)
        rule = ngs.IntegrationRule(meshes.facet_shape(mesh), 2 * max(body.order, body.order_phi))
        self._gauss, self.gauss_points = self._mapped(rule, elements, facets, order)
        weights = np.array(rule.weights)
        self.gauss_weights = np.outer(self.measure, weights / weights.sum())   # m (m² in 3D) per point
        # m² per point for a body of revolution: the ring 2π r ds it stands for
        self.gauss_weights = self.gauss_weights * kin.point_weights(self.gauss_points)
        n = ngs.specialcf.normal(self.dim)
        self.normals = np.array([self.project(n[i]) for i in range(self.dim)]).T
        # sample points: 2p + 1 equidistant points per edge in 2D; vertices, centroid and
        # edge midpoints per triangle in 3D (weights of the facet's vertices), mapped from the
        # reference facet onto each facet of Γ3, so that they lie on a curved facet (not on its
        # chord, where a point search fails) and belong to their own facet (there
        # ``specialcf.normal`` is the facet's normal, as in a gap written with it)
        weights = meshes.facet_sample_weights(mesh, body.order)
        # the reference segment has vertex 0 at x = 1, the reference triangle its vertices at
        # (1, 0), (0, 1), (0, 0)
        sample_rule = ngs.IntegrationRule([tuple(w[:self.dim - 1]) for w in weights], [1.0] * len(weights))
        self._mesh_points, self.sample_points = self._mapped(sample_rule, elements, facets, order)

    def _mapped(self, rule, elements, facets, order):
        """The points of ``rule`` mapped onto every facet of Γ3 (in the order of B^h's DOFs):
        NGSolve's mapped points and their coordinates (facets × points × dim)."""
        count = len(rule.points)
        index = np.zeros((self.B.ndof, count), dtype=int)
        for el in elements:
            index[order[self._facet_dof[el.nr]]] = el.nr * count + np.arange(count)
        points = self.mesh.MapToAllElements(rule, ngs.BND)[index.ravel()]
        coordinates = np.stack([c(points).ravel() for c in (ngs.x, ngs.y, ngs.z)[:self.dim]], axis=-1)
        return points, coordinates.reshape(self.B.ndof, count, self.dim)

    def facet_integrals(self, cf, quadrature="exact", weighted=True):
        """A function returning (∫_facet cf da for each facet of Γ3) when called: the
        LinearForm is built once and reassembled at each call (cf may hold GridFunctions).
        ``quadrature``: "exact" (degree 2p + 2 per facet) or "residual" (the rule of the
        residual's Γ3 terms: a kinked integrand such as a penalty force is integrated as the
        residual integrates it). For a body of revolution da = 2π r ds (the body's integral),
        unless not ``weighted``."""
        lf = ngs.LinearForm(self.B)
        lf += self.on_facets(cf.Compile() * self._mu, quadrature, weighted)

        def assemble():
            lf.Assemble()
            return lf.vec.FV().NumPy().copy()
        return assemble

    def _integrate(self, cf):
        return self.facet_integrals(cf)()

    def project(self, cf):
        """P_B cf: the facet averages of cf on Γ3 (numpy array, one value per facet; for a body
        of revolution over the ring the facet sweeps)."""
        return self._integrate(cf) / self.weighted_measure

    def integrate(self, cf):
        """∫_Γ3 cf da, with volume gradients allowed in cf. (Summed from the facet
        integrals of a LinearForm: ``Integrate`` over ``ds(skeleton=True)`` does not take
        GridFunction gradients from the volume element.)"""
        return float(self._integrate(cf).sum())

    def at_gauss_points(self, cf):
        """cf at ``gauss_points`` (facets × points), with the volume element's fields (stresses,
        so that a Nitsche multiplier can be evaluated) and the facet's normal."""
        return ngs.BoundaryFromVolumeCF(cf)(self._gauss).reshape(self.gauss_points.shape[:2])

    def sample(self, cf):
        """cf at the sample points (facets × points per facet), evaluated on each facet of
        Γ3 (a facet's vertex with that facet's normal); no volume gradients."""
        values = cf(self._mesh_points)
        return values.reshape(self.sample_points.shape[:2] + (1,)).squeeze(-1) if cf.dim == 1 else \
            values.reshape(self.sample_points.shape[:2] + (cf.dim,))

    def normal_displacement(self, u, normal=None):
        """u·ν at the sample points, with the (straight) facets' outward normals, or u·n_o
        with ``normal`` n_o, an obstacle normal (a CoefficientFunction of position)."""
        if normal is None:
            return np.einsum("fsd,fd->fs", self.sample(u), self.normals)
        return np.einsum("fsd,fsd->fs", self.sample(u), self.sample(normal))
