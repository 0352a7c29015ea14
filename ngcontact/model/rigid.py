"""Rigid motions of a body that its supports leave free, and whether its contact can hold them.

A body under force control is held only in part by its supports: e.g. the Hertz half-disk
with u_x = 0 on its flat top and a traction there is free to move vertically and to rotate
about a point of the top; only the contact on Γ3 fixes those motions. A rigid motion r is
held by the contact when it moves Γ3 along the contact normal n somewhere (r·n ≠ 0 on a part
of Γ3 of positive measure); one that slides Γ3 along the obstacle (a translation along a
plane obstacle) is held by nothing, and every step of such a body is singular.

The rigid motions (translations, and rotations about the body's centre scaled by its size, so
that all are of unit size) are tested in the least-squares sense: the supports hold the
combinations c of them with G c ≠ 0, G the Gram matrix of their values at the held DOFs of V
and of their normal components on the weak ("normal") supports; the free ones span the
null space of G. The contact holds the free ones if the Gram matrix of r·n on Γ3 is regular
on them.
"""
import ngsolve as ngs
import numpy as np

from ngcontact import parallel

TOLERANCE = 1e-8
"""Eigenvalues of a Gram matrix of unit-size motions below this (relative to 1) count as zero."""
AXES = "xyz"


def motions(body):
    """The rigid motions of ``body``'s kinematics as (CoefficientFunction, name)
    (``Kinematics.rigid_motions``): translations along the axes, rotations about the centre of
    the mesh's bounding box divided by the body's size; for a body of revolution the translation
    along its axis alone."""
    dim = body.dim
    coordinates = np.asarray(body.mesh.ngmesh.Coordinates()).reshape(-1, dim)   # none on MPI's rank 0
    high = [parallel.maximum(body.mesh, coordinates[:, i]) for i in range(dim)]       # on every rank: collective
    low = [parallel.minimum(body.mesh, coordinates[:, i]) for i in range(dim)]
    return body.kinematics.rigid_motions([(high[i] + low[i]) / 2 for i in range(dim)], body.size)


def free_motions(body):
    """(fields, basis): the rigid motions (``motions``) and an orthonormal basis (columns,
    coefficients of the fields) of the combinations the supports leave free; no columns for a
    body that is clamped or held in full somewhere."""
    fields = motions(body)
    if body.boundaries["clamped"] or any(len(s.axes) == body.dim for s in body.supports):
        return fields, np.zeros((len(fields), 0))
    mesh, held = body.mesh, ~np.array(list(body.V.FreeDofs()), dtype=bool)
    region = mesh.Boundaries(body.region_names("supports"))
    values = []
    for field, _ in fields:
        gf = ngs.GridFunction(body.V)
        gf.Set(field, ngs.BND, definedon=region)
        values.append(gf.vec.FV().NumPy()[held])
    values = np.array(values)
    gram = parallel.sum(mesh, values @ values.T) / max(1, parallel.sum(mesh, held.sum()))
    weak = [n for s in body.supports if s.normal for n in s.names]
    if weak:
        region = mesh.Boundaries("|".join(weak))

        def integral(f):
            return ngs.Integrate(body.kinematics.ds(f, region, weighted=False), mesh)
        normal = [ngs.InnerProduct(field, ngs.specialcf.normal(body.dim)) for field, _ in fields]
        area = parallel.sum(mesh, integral(ngs.CF(1.0)))
        gram = gram + parallel.sum(mesh, np.array([[integral(a * b) for b in normal] for a in normal])) / area
    eigenvalues, vectors = np.linalg.eigh(gram)
    return fields, vectors[:, eigenvalues < TOLERANCE * max(1.0, eigenvalues.max())]


def normal_components(fields, side, normal):
    """r·n of each field at the sample points of Γ3 (fields × points), with the contact normal
    ``normal`` (an obstacle normal, or None for the facet normals)."""
    return np.array([side.normal_displacement(field, normal).ravel() for field, _ in fields])


class Floating:
    """The rigid motions of a body that only its contact holds (``basis``, orthonormal
    coefficients of ``fields``), checked: a free motion the contact cannot hold is a
    ValueError. ``bool(floating)`` says whether there are any.

    Parameters
    ----------
    body : Body.  gamma3 : the ``observables.Gamma3`` of its contact, or None (no contact:
        the supports alone must hold the body; Newton names a singular system).
    """

    def __init__(self, body, gamma3):
        self.fields, self.basis = free_motions(body)
        self.gamma3 = gamma3
        if not self or gamma3 is None:
            return
        side = gamma3.side
        points = side.sample_points.shape[1]
        weights = np.repeat(side.measure, points) / points / parallel.sum(body.mesh, side.measure.sum())
        components = normal_components(self.fields, side, gamma3.sampled_normal).T @ self.basis
        eigenvalues, vectors = np.linalg.eigh(parallel.sum(body.mesh, components.T @ (weights[:, None] * components)))
        if eigenvalues[0] < TOLERANCE * max(1.0, eigenvalues[-1]):
            motion = self.basis @ vectors[:, 0]
            names = " + ".join(f"{c:.3g} × {name}" for c, (_, name) in zip(motion, self.fields) if abs(c) > 1e-6)
            held = ", ".join(f"{s.key!r}: {''.join(AXES[a] for a in s.axes) or 'normal'}" for s in body.supports)
            raise ValueError(f"supports: the rigid motion {names} is held by neither the supports ({held or 'none'}; "
                             f"clamped: {body.region_names('clamped') or 'none'}) nor the contact (it does not move "
                             "Γ3 towards the obstacle): a body held only by the contact needs supports for every "
                             "motion along the obstacle (e.g. supports={'top': 'x'}), or it is singular")

    def __bool__(self):
        return self.basis.shape[1] > 0

    def vectors(self, space):
        """The free motions as DOF vectors (numpy, columns) of ``space`` (the body's V)."""
        result = []
        for field, _ in self.fields:
            gf = ngs.GridFunction(space)
            gf.Set(field)
            result.append(gf.vec.FV().NumPy().copy())
        return np.array(result).T @ self.basis
