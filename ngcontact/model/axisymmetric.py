"""Bodies of revolution: torsion-free axisymmetric fields on the (r, z) half-plane.

A 2D mesh read as the meridian section of the body: x = r >= 0 (m), y = z the axis of
revolution. u = (u_r, u_z), φ and the loads do not depend on θ, and there is no twist.
The paper's forms keep their shape, with

* the strain ε = (ε_rr, ε_zz, 2ε_rz, ε_θθ), where ε_θθ = u_r/r: the plane-strain vector plus the
  hoop strain (Voigt, engineering shear; ``hoop_strain``);
* ∇φ = (∂_r φ, ∂_z φ);
* the material seen in the frame (e_r, e_z, e_θ), its data axis 3 (poling) along the axis of
  revolution (``Kinematics.indices_3d``, ``twist_coupling``);
* the measures 2π r dr dz on Ω and 2π r ds on its boundary (``weight``). Every integral is
  then over the whole body: forces in N, charges in C, contact areas in m².

The axis r = 0, where the mesh touches it, holds u_r = 0 (``axis_names``): the body, not the user,
imposes it (a support of the x component). Rigid motions are the translations along the axis alone.

The axis is a line without area (its weight 2π r is 0), so no other data may sit on it
(``check_parts``, ``check_loads``): a traction or a surface charge there does nothing; an
electrode, a clamp or a support of u_z there holds nothing as the mesh is refined (a line has no
capacity in 3D: the result depends on the mesh; the unit cylinder, E = 1 Pa, held by u = 0 on its
axis alone and sheared along it by 1 Pa on its rim, moves its rim 13, 15, 17, 19, 21 m at h = 0.2
... 0.0125 m, without a limit); Γ3 there transmits nothing. A support "x" or
"normal" on it is accepted (redundant); u_r prescribed nonzero on it, or where a support meets
it, would tear the body open along its axis.
"""
import math
import numbers

import ngsolve as ngs
import numpy as np

from ngcontact import checks, parallel

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


LINE = "a line without area (its weight 2π r is 0)"


def check_parts(body):
    """A ValueError naming the part and the boundary if a part of ``body`` (a body of revolution)
    other than a support of u_r lies on its axis (``Body.axis``; module docstring)."""
    why = {"clamped": "u_z held there holds nothing as the mesh is refined (the result depends on the mesh); "
                      "the body holds u_r = 0 there itself: hold it on a boundary off the axis",
           "grounded": "an electrode there has no capacity (its charge and the force it exerts depend on the "
                       "mesh): put the electrode on a boundary off the axis",
           "contact_side": "contact there transmits nothing: Γ3 must lie off the axis"}
    for part, reason in why.items():
        on = [n for n in body.boundaries[part] if n in body.axis]
        if on:
            raise ValueError(f"{part}: boundary {on} lies on the axis r = 0 of the body of revolution, {LINE}; "
                             f"{reason}")
    for support in body.supports:
        on = [n for n in support.names if n in body.axis]
        if on and support.axes != (0,):
            held = "u·ν (weak, Nitsche)" if support.normal else ", ".join("u_" + "rz"[a] for a in support.axes)
            raise ValueError(f"supports[{support.key!r}] holds {held} on boundary {on}, which lies on the axis r = 0 "
                             f"of the body of revolution, {LINE}: only u_r = 0 can be held there (the body holds it "
                             "itself; 'x' or 'normal' there is redundant), u_z held on the axis holds nothing as the "
                             "mesh is refined (the result depends on the mesh); give the axis a key of its own "
                             "and hold u_z on a boundary off the axis")


def check_loads(body, loads):
    """A ValueError naming the entry and the boundary if ``loads`` put data on the axis of
    ``body`` (a body of revolution): a traction f2 or a charge qb (weight 0: it would do nothing),
    or a nonzero u_r (``Loads.displacement``) on the axis or where a support meets it (at the
    current value of the time Parameter)."""
    for entry, what in (("f2", "a traction"), ("qb", "a surface charge")):
        for key in getattr(loads, entry):
            on = [n for n in key.split("|") if n in body.axis]
            if on:
                raise ValueError(f"Loads.{entry}[{key!r}]: boundary {on} lies on the axis r = 0 of the body of "
                                 f"revolution, {LINE}: {what} there does nothing; put it on a boundary off the axis"
                                 + (" (or use the body force f0)" if entry == "f2" else " (or the charge density q0)"))
    tolerance = AXIS_TOLERANCE * body.size
    for key, value in loads.displacement.items():
        support = body.support_of(key)
        if 0 not in support.axes:
            continue
        names = [n for n in key.split("|") if n]
        on = [n for n in names if n in body.axis]
        entry = value[support.axes.index(0)] if isinstance(value, (tuple, list)) else value
        name = f"Loads.displacement[{key!r}]"
        if on and not _zero(body, entry, on, tolerance):
            given = (f"{entry!r} m" if isinstance(entry, numbers.Real) else "a CoefficientFunction of time"
                     if isinstance(entry, ngs.CoefficientFunction) and checks.parameters(entry) else f"{entry!r}")
            raise ValueError(f"{name}: u_r = {given} on boundary {on}, which lies on the axis r = 0 of the body of "
                             "revolution, where u_r = 0 (the body would be torn open along its axis); give u_r there "
                             "as the number 0, or leave the axis out of Loads.displacement")
        points = _meeting_points(body, [n for n in names if n not in body.axis], tolerance)
        if len(points):
            cf = value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(
                tuple(value) if isinstance(value, (tuple, list)) else value)
            radial = cf[support.axes.index(0)] if cf.dim > 1 else cf
            values = np.abs(parallel.point_values(body.mesh, radial, points)[:, 0])
            if values.max() > tolerance:
                z = points[int(np.argmax(values)), 1]
                raise ValueError(f"{name}: u_r = {support.sign * values.max():.6g} m at the point r = 0, z = {z:.6g} m "
                                 f"where boundary {key!r} meets the axis of the body of revolution, where u_r = 0 "
                                 "(the body would be torn open along its axis); its radial value must vanish at r = 0 "
                                 "(e.g. proportional to x)")


def _zero(body, entry, on, tolerance):
    """Whether ``entry``, the u_r of a support on the axis boundaries ``on``, is 0: a number, or a
    CoefficientFunction without a time Parameter that is 0 on them (one that depends on time
    cannot be checked for every time)."""
    if isinstance(entry, numbers.Real) and not isinstance(entry, bool):
        return abs(float(entry)) <= tolerance
    if not isinstance(entry, ngs.CoefficientFunction) or checks.parameters(entry):
        return False
    region = body.mesh.Boundaries("|".join(on))
    square = parallel.sum(body.mesh, ngs.Integrate(body.kinematics.ds(entry * entry, region, weighted=False), body.mesh))
    length = parallel.sum(body.mesh, ngs.Integrate(body.kinematics.ds(ngs.CF(1.0), region, weighted=False), body.mesh))
    return square <= tolerance * tolerance * length


def _meeting_points(body, names, tolerance):
    """The vertices (r, z) on the axis of the facets of the boundaries ``names`` (the points where
    they meet the axis), every rank alike."""
    if not names:
        return np.zeros((0, 2))
    coordinates = body.mesh.ngmesh.Coordinates()
    found = set()
    for element in body.mesh.Elements(ngs.BND):
        if element.mat in names:
            found.update(tuple(coordinates[v.nr][:2]) for v in element.vertices if coordinates[v.nr][0] <= tolerance)
    if parallel.is_distributed(body.mesh):
        found = set().union(*parallel.every(body.mesh, sorted(found)))
    return np.array(sorted(found), dtype=float).reshape(-1, 2)
