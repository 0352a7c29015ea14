"""Bodies of revolution: torsion-free axisymmetric fields on the (r, z) half-plane.

A 2D mesh read as the meridian section of the body: x = r >= 0 (m), y = z the axis of
revolution. u = (u_r, u_z), φ and the loads do not depend on θ, and there is no twist.
The paper's forms keep their shape, with

* the strain ε = (ε_rr, ε_zz, 2ε_rz, ε_θθ), where ε_θθ = u_r/r: the plane-strain vector plus the
  hoop strain (Voigt, engineering shear; ``hoop_strain``);
* ∇φ = (∂_r φ, ∂_z φ);
* the material seen in the frame (e_r, e_z, e_θ), its data axis 3 (poling) along the axis of
  revolution (``restricted``);
* the measures 2π r dr dz on Ω and 2π r ds on its boundary (``weight``). Every integral is
  then over the whole body: forces in N, charges in C, contact areas in m².

The axis r = 0, where the mesh touches it, holds u_r = 0 (``axis_names``): the body, not the user,
imposes it (a support of the x component). Rigid motions are the translations along the axis alone.
"""
import math

import ngsolve as ngs
import numpy as np

from ngcontact import parallel

VOIGT_3D = {(0, 0): 0, (1, 1): 1, (2, 2): 2, (1, 2): 3, (0, 2): 4, (0, 1): 5}
"""Indices of the 3D Voigt vector (11, 22, 33, 23, 13, 12) by (i, j)."""
INDICES = [VOIGT_3D[(0, 0)], VOIGT_3D[(1, 1)], VOIGT_3D[(0, 1)], VOIGT_3D[(2, 2)]]
"""The axisymmetric components (rr, zz, rz, θθ) in the 3D Voigt vector of the frame
(x, y, z) = (e_r, e_z, e_θ): r the mesh's x, the axis its y."""
AXIS_TOLERANCE = 1e-9
"""Points with r <= this times the body's size lie on the axis."""


def weight():
    """2π r: the measure of a body of revolution per unit area of its meridian section (m)."""
    return 2 * math.pi * ngs.x


def hoop_strain(u, radius_floor):
    """ε_θθ = u_r/r; at r <= ``radius_floor`` (the axis, where u_r = 0) its limit ∂u_r/∂r."""
    r = ngs.x
    return ngs.IfPos(r - radius_floor, u[0] / ngs.IfPos(r - radius_floor, r, 1.0), ngs.Grad(u)[0, 0])


def strain(u, radius_floor=0.0):
    """ε(u) = (ε_rr, ε_zz, 2ε_rz, ε_θθ) (Voigt, engineering shear)."""
    g = ngs.Grad(u)
    return ngs.CF((g[0, 0], g[1, 1], g[0, 1] + g[1, 0], hoop_strain(u, radius_floor)))


TWIST = [VOIGT_3D[(1, 2)], VOIGT_3D[(0, 2)]]
"""The twist components (zθ, rθ) of the 3D Voigt vector in the frame (e_r, e_z, e_θ)."""


def twist_coupling(c, eta, e, eps):
    """What couples the torsion-free axisymmetric fields (ε_rr, ε_zz, ε_rz, ε_θθ, E_r, E_z) to
    the twist (ε_rθ, ε_zθ, E_θ) in the material data of the frame (e_r, e_z, e_θ) (3D Voigt
    c, η (6×6), e (3×6), ε (3×3)): the names of the nonzero couplings, "" if none. The
    material is read in that frame at every point, so a transversely isotropic material poled
    along the axis has none (its c66 does not enter torsion-free fields)."""
    found = []
    for name, block in (("c", c[np.ix_(INDICES, TWIST)]), ("eta", eta[np.ix_(INDICES, TWIST)]),
                        ("e: E_r, E_z with the twist strains", e[:2][:, TWIST]),
                        ("e: E_θ with the axisymmetric strains", e[2, INDICES]), ("eps", eps[:2, 2])):
        scale = {"c": np.abs(c).max(), "eta": np.abs(eta).max(), "eps": np.abs(eps).max()}.get(name, np.abs(e).max())
        if np.abs(block).max(initial=0.0) > 1e-12 * max(scale, 1e-300):
            found.append(name)
    return ", ".join(found)


def restricted(F, A, e, eps):
    """The axisymmetric tensors from the 3D ones in the frame (e_r, e_z, e_θ): F, A (4×4 on
    (rr, zz, rz, θθ)), E (2×4: fields (r, z)), C (2×2)."""
    ix = np.ix_(INDICES, INDICES)
    return F[ix], A[ix], e[:2][:, INDICES], eps[:2, :2]


def axis_names(mesh, size):
    """The boundary names whose facets all lie on the axis r = 0 (within ``AXIS_TOLERANCE``
    of ``size``); a name with facets both on and off the axis is refused (the axis needs a
    name of its own). A mesh with a point at r < 0 is refused."""
    tolerance = AXIS_TOLERANCE * size
    coordinates = mesh.ngmesh.Coordinates()
    lowest = parallel.minimum(mesh, coordinates[:, 0] if len(coordinates) else [])
    if lowest < -tolerance:
        raise ValueError(f"axisymmetric: the mesh must lie in the half-plane x = r >= 0 (x is the radius, y the "
                         f"axis), but it reaches x = {lowest:.6g} m")
    on, off = set(), set()
    for element in mesh.Elements(ngs.BND):
        r = [coordinates[v.nr][0] for v in element.vertices]
        (on if max(r) <= tolerance else off).add(element.mat)
    if parallel.is_distributed(mesh):            # every rank decides alike, on the whole boundary
        on = set().union(*parallel.every(mesh, sorted(on)))
        off = set().union(*parallel.every(mesh, sorted(off)))
    mixed = on & off
    if mixed:
        raise ValueError(f"axisymmetric: boundary {sorted(mixed)} lies partly on the axis r = 0 and partly off it; "
                         "give the axis its own boundary name (u_r = 0 is imposed there)")
    return sorted(on)
