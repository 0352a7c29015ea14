"""The body Ω: mesh, material, the two boundary partitions of (2.5)-(2.6), and V^h × W^h (4.1).

Boundaries are named as in the Netgen mesh; a part may list several names joined by
"|" (Netgen's regex syntax, e.g. ``"top|right"``).

* mechanical: Γ1 ``clamped`` (u = 0), ``supports`` (u or some of its components prescribed,
  ``Loads.displacement``; symmetry planes and rollers), Γ3 ``contact_side``, Γ2 = the rest
  (tractions f2; also on a support's free components);
* electric:   Γa ``grounded`` (φ prescribed, 0 by default), Γb = the rest (charges qb),
  with Γ3 ⊂ Γb.
"""
from __future__ import annotations

import functools

import ngsolve as ngs
import numpy as np

from ngcontact import checks, meshes, parallel
from ngcontact.model import axisymmetric as axisymmetric_model
from ngcontact.model import kinematics as kinematics_model
from ngcontact.model.materials import Material
from ngcontact.model.supports import dirichlet_flags
from ngcontact.model.supports import parse as parse_supports


def split_names(names):
    """``"top|right"`` -> ``["top", "right"]``; None or "" -> []."""
    return [n for n in (names or "").split("|") if n]


class Body:
    """A piezoelectric body and its finite element spaces.

    Parameters
    ----------
    mesh : ngsolve.Mesh, 2D (plane strain, quantities per metre of depth) or 3D, in metres.
        Under mpiexec with several ranks it must be distributed (``ngcontact.geometries``
        distribute theirs; ``parallel.distributed_mesh``): a serial mesh would have every
        rank solve the whole problem, and is refused.
    material : Material.
    clamped : str or None, boundary names of Γ1 (u = 0).
    supports : dict or None, {boundaries: components} with components "all", "normal"
        (u·ν = 0: symmetry plane, roller) or axes such as "x", "yz" (``ngcontact.model.supports``);
        their values come from ``Loads.displacement`` (0 by default). Γ1 and the supports
        together must be nonempty, and rigid motions they leave free must be held by contact.
    grounded : str, boundary names of Γa (φ prescribed); nonempty for a piezoelectric
        material, optional (None) for one without coupling, whose simulations then solve for
        u alone unless the scene has an electric part (``Simulation.model``).
    contact_side : str or None, boundary names of Γ3; without a contact law
        (``Simulation(contact=...)``) it is traction-free and charge-free.
    order : int in [1, 10] (``checks.MAX_ORDER``), polynomial order of u (1 = the paper's P1
        space (4.1)).
    order_phi : int in [1, 10] or None, order of φ (default: ``order``).
    hierarchy : the nested meshes whose finest level is ``mesh`` (``meshes.Hierarchy``: the coarse
        mesh and its refinements, for multigrid and nested iteration; one given is checked: its
        coarse mesh refined is the mesh, the same boundaries and vertices); default: the one
        ``meshes.nested_mesh`` made the mesh with (``ngcontact.geometries`` do), else None.
    axisymmetric : a body of revolution (``model.axisymmetric``): the 2D mesh is its meridian
        section, x = r >= 0 and y the axis; ε_θθ = u_r/r joins the strains, every integral
        is taken with 2π r (forces in N, charges in C, areas in m², as in 3D), and the
        boundaries on the axis r = 0 hold u_r = 0 without being named (``axis``). The
        material is read in the frame (e_r, e_z, e_θ), poled along the axis. The axis, a line
        without area, takes no other part (clamped, grounded, contact_side, a support of u_z:
        refused by name); a support "x" or "normal" there is redundant.

    ``X = V × W`` is the body's space; each simulation works on its own copy (``space()``),
    so that what one simulation sets on it (static condensation) does not reach another.
    """

    def __init__(self, mesh: ngs.Mesh, material: Material, *, clamped: str | tuple | None = None,
                 grounded: str | tuple | None = None, contact_side: str | tuple | None = None,
                 supports: tuple | list | None = None, order: int = 1, order_phi: int | None = None,
                 hierarchy: meshes.Hierarchy | None = None, axisymmetric: bool = False, **renamed) -> None:
        if "contact" in renamed:
            raise TypeError("Body(contact=...) is now Body(contact_side=...): the boundary names of Γ3 "
                            "(contact= is the contact law, given to Simulation)")
        if renamed:
            raise TypeError(f"Body got unexpected keyword arguments {sorted(renamed)}")
        if not isinstance(mesh, ngs.Mesh):
            raise TypeError(f"mesh must be an ngsolve.Mesh, got {type(mesh).__name__}")
        if not isinstance(material, Material):
            raise TypeError(f"material must be an ngcontact.Material, got {type(material).__name__}")
        order_phi = order if order_phi is None else order_phi
        for name, p in (("order", order), ("order_phi", order_phi)):
            checks.order(name, p)
        comm = parallel.world()
        if comm is not None and not parallel.is_distributed(mesh):
            raise ValueError(f"mesh: a serial mesh under mpiexec with {comm.size} ranks (every rank would solve "
                             "the whole problem); distribute it (ngcontact.geometries do; "
                             "GenerateMesh(..., comm=MPI.COMM_WORLD) or parallel.distributed_mesh) or run without "
                             "mpiexec")
        self.mesh = mesh
        self.hierarchy = meshes.hierarchy(mesh) if hierarchy is None else hierarchy
        if hierarchy is not None and not isinstance(hierarchy, meshes.Hierarchy):
            raise TypeError(f"hierarchy must be an ngcontact.meshes.Hierarchy (made by meshes.nested_mesh, or "
                            f"Hierarchy(coarse, refinements, vertices)) or None, got {type(hierarchy).__name__}")
        if hierarchy is not None:
            hierarchy.check_finest(mesh, self.size)
        self.dim = mesh.dim
        self.material = material
        self.kinematics = kinematics_model.of(self.dim, checks.flag("axisymmetric", axisymmetric))
        """How u makes the strain and how integrals are taken (``model.kinematics``)."""
        self.tensors = material.tensors(self.kinematics)
        self.order, self.order_phi = int(order), int(order_phi)
        existing = set(mesh.GetBoundaries())
        self.boundaries = {}
        for part, names in (("clamped", clamped), ("grounded", grounded), ("contact_side", contact_side)):
            if names is not None and not isinstance(names, str):
                raise TypeError(f"{part} must name boundaries in a string ('left' or 'left|top'), got {names!r}")
            listed = split_names(names)
            missing = [n for n in listed if n not in existing]
            if missing:
                raise ValueError(f"{part}: boundary {missing} not in the mesh; its boundaries are "
                                 f"{sorted(existing)}")
            self.boundaries[part] = listed
        self.axis = axisymmetric_model.axis_names(mesh, self.size) if self.axisymmetric else []
        """The boundaries on the axis r = 0 of a body of revolution (u_r = 0 there)."""
        supports = self._axis_supports(supports)
        self.supports = parse_supports(supports, mesh, split_names)
        self.boundaries["supports"] = [n for s in self.supports for n in s.names]
        if not self.boundaries["clamped"] and not self.supports:
            raise ValueError("clamped or supports must name at least one boundary (a held boundary is "
                             f"needed for a unique displacement); the mesh has {sorted(existing)}")
        if not self.boundaries["grounded"] and self.coupled:
            raise ValueError("grounded must name at least one boundary (meas > 0 is needed "
                             f"for a unique potential); the mesh has {sorted(existing)}")
        for part in ("clamped", "grounded", "supports"):
            both = set(self.boundaries[part]) & set(self.boundaries["contact_side"])
            if both:
                raise ValueError(f"contact_side Γ3 must not overlap {part}: {sorted(both)}")
        both = set(self.boundaries["clamped"]) & set(self.boundaries["supports"])
        if both:
            raise ValueError(f"supports must not overlap clamped Γ1 (u = 0 there already): {sorted(both)}")
        if self.axisymmetric:
            axisymmetric_model.check_parts(self)
        self.V, self.W, self.X = self._spaces()

    def _axis_supports(self, supports):
        """``supports`` with u_r = 0 (component x) on the axis boundaries that no part holds yet."""
        if supports is not None and not isinstance(supports, dict):
            return supports                                          # refused by name when parsed
        held = set(self.boundaries["clamped"]) | set(self.boundaries["contact_side"])
        held |= {n for key in supports or {} if isinstance(key, str) for n in split_names(key)}
        free = [name for name in self.axis if name not in held]
        if not free:
            return supports
        return {**(supports or {}), "|".join(free): "x"}

    @property
    def axisymmetric(self):
        """True for a body of revolution (``kinematics.Axisymmetric``)."""
        return isinstance(self.kinematics, kinematics_model.Axisymmetric)

    def weighted(self, integrand):
        """``integrand`` times the measure's weight: 2π r for a body of revolution, else as it is
        (``Kinematics.weighted``)."""
        return self.kinematics.weighted(integrand)

    def _spaces(self):
        V = ngs.VectorH1(self.mesh, order=self.order,
                         **dirichlet_flags(self.boundaries["clamped"], self.supports, self.dim))
        W = ngs.H1(self.mesh, order=self.order_phi, dirichlet=self.region_names("grounded"))
        return V, W, V * W

    def space(self):
        """A new product space V × W, numbered as ``X`` (a simulation's own copy)."""
        return self._spaces()[2]

    def region_names(self, part):
        """The names of a part joined for ``mesh.Boundaries``."""
        return "|".join(self.boundaries[part])

    def region(self, part):
        """The boundary region of a part ("clamped", "grounded", "contact_side" or "supports")."""
        return self.mesh.Boundaries(self.region_names(part))

    def free_names(self, excluded):
        """Boundary names not in the listed parts: Γ2 ⊂ free_names(("clamped", "contact_side")),
        Γb minus Γ3 = free_names(("grounded", "contact_side"))."""
        taken = {n for part in excluded for n in self.boundaries[part]}
        return [n for n in dict.fromkeys(self.mesh.GetBoundaries()) if n not in taken]

    @functools.cached_property
    def size(self):
        """The diagonal of the mesh's bounding box (m): the scale of the checks of
        ``admissible``."""
        coordinates = self.mesh.ngmesh.Coordinates()
        if parallel.is_distributed(self.mesh):               # each rank holds its part
            high = [parallel.maximum(self.mesh, c) for c in coordinates.T]
            low = [parallel.minimum(self.mesh, c) for c in coordinates.T]
            return float(np.linalg.norm(np.subtract(high, low)))
        return float(np.linalg.norm(coordinates.max(axis=0) - coordinates.min(axis=0)))

    @property
    def coupled(self):
        """True if the material couples u and φ (a nonzero piezoelectric tensor E)."""
        return bool(abs(self.tensors.E).max(initial=0.0) > 0)

    def support_of(self, key):
        """The Support holding every boundary of ``key`` (``"a"`` or ``"a|b"``)."""
        names = split_names(key) if isinstance(key, str) else []
        for support in self.supports:
            if names and set(names) <= set(support.names):
                return support
        raise ValueError(f"{key!r} is not a support of the body (a key within one of supports="
                         f"{[s.key for s in self.supports]}); prescribed displacements need supports={{...}}")

    @property
    def ndof(self):
        """Number of DOFs of V × W (all, Dirichlet ones included; over all ranks on a
        distributed mesh)."""
        return self.X.ndofglobal if parallel.is_distributed(self.mesh) else self.X.ndof

    def __repr__(self):
        kind = ", axisymmetric" if self.axisymmetric else ""
        return (f"Body({self.material.name or 'material'}, dim={self.dim}{kind}, order=({self.order}, "
                f"{self.order_phi}), ndof={self.ndof}, {self.boundaries})")
