"""Supports: displacements prescribed on named boundaries, in full or per component.

A support is a boundary (or ``"a|b"``) with the components of u it fixes:

* ``"all"`` (every component; the value a vector, like the clamped Γ1 but with data),
* ``"x"``, ``"y"``, ``"z"`` or a combination such as ``"xz"`` (the value one number per
  listed component, in that order),
* ``"normal"``: u·ν only, the tangential components free: a symmetry plane or a roller.

The components along the axes are Dirichlet DOFs of V^h (NGSolve's ``dirichletx=`` ...):
exact, and their values are set at every step from ``Loads.displacement`` (0 when not
given; numbers or CoefficientFunctions of the time Parameter, in m). A ``"normal"`` support
on a flat boundary whose normal is an axis is that axis' component (exact). On any other
boundary u·ν = 0 holds weakly, by the symmetric Nitsche method: the step residual gets

  −∫ σ_ν(u, φ) v_ν − ∫ σ_ν(v, ξ) u_ν + ∫ γ_s u_ν v_ν      (σ_ν of the step, A/dt included),

linear in (u, φ), so it is part of the bulk matrix; γ_s = ``SLIP_GAMMA0`` times the boundary
stiffness p² (λ_max(F + EᵀC⁻¹E) + λ_max(A)/dt)/h. Only the zero normal displacement is
offered there (symmetry planes and rollers on fixed walls).

The reaction of a support (``StepRecord.reactions``, N, per metre of depth in 2D) is
∫ σν da over it: from the residual for Dirichlet DOFs (as for Γ1), and ∫ λ ν da with the
Nitsche multiplier λ = σ_ν − γ_s u_ν on a weak ``"normal"`` support.
"""
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.model.kinematics import mesh_ds

AXES = "xyz"
SLIP_GAMMA0 = 10.0            # Nitsche parameter of weak "normal" supports (coercive from ~2)


@dataclass(frozen=True)
class Support:
    """One support: boundary ``names``, the fixed ``axes`` (indices into x, y, z) or
    ``normal`` (weak u·ν = 0), and the ``key`` it was given under. ``sign`` = ν_i for a
    normal support along axis i (its value u·ν is then u_i = sign · value)."""
    key: str
    names: tuple
    axes: tuple = ()
    normal: bool = False
    sign: float = 1.0

    @property
    def size(self):
        """Components of its value: 1 for a normal support, else one per fixed axis."""
        return 1 if self.normal else len(self.axes)


def parse(supports, mesh, split_names):
    """The ``Body(supports=...)`` dictionary as a list of Support, checked.

    A ``"normal"`` support on a flat boundary with an axis as normal becomes that axis'
    component (exact); the others stay weak (``Support.normal``)."""
    if supports is None:
        return []
    if not isinstance(supports, dict):
        raise TypeError(f"supports must be a dict {{boundary: components}}, got {type(supports).__name__}")
    dim, existing, taken, parsed = mesh.dim, set(mesh.GetBoundaries()), {}, []
    allowed = f"'all', 'normal', or axes among {AXES[:dim]!r} such as {AXES[:dim]!r}"
    for key, spec in supports.items():
        if not isinstance(key, str):
            raise TypeError(f"supports: key {key!r} must be a string naming boundaries (e.g. 'left' or 'left|top')")
        names = split_names(key)
        if not names:
            raise ValueError(f"supports: key {key!r} must name boundaries (e.g. 'left' or 'left|top')")
        missing = [n for n in names if n not in existing]
        if missing:
            raise ValueError(f"supports[{key!r}]: boundary {missing} not in the mesh; its boundaries are "
                             f"{sorted(existing)}")
        for n in names:
            if n in taken:
                raise ValueError(f"supports: boundary {n!r} is listed twice ({taken[n]!r} and {key!r})")
            taken[n] = key
        if not isinstance(spec, str):
            raise TypeError(f"supports[{key!r}] must be a string ({allowed}), got {spec!r}")
        if spec == "all":
            parsed.append(Support(key, tuple(names), tuple(range(dim))))
        elif spec == "normal":
            axis, sign = _normal_axis(mesh, names)
            parsed.append(Support(key, tuple(names), (axis,), sign=sign) if axis is not None
                          else Support(key, tuple(names), normal=True))
        elif spec and all(c in AXES[:dim] for c in spec) and len(set(spec)) == len(spec):
            parsed.append(Support(key, tuple(names), tuple(AXES.index(c) for c in spec)))
        else:
            bad = [c for c in spec if c not in AXES[:dim]]
            why = f" (component {bad[0]!r} does not exist in {dim}D)" if bad and spec != "" else ""
            raise ValueError(f"supports[{key!r}] = {spec!r} is not a set of components{why}; allowed: {allowed}")
    return parsed


def _normal_axis(mesh, names, tol=1e-10):
    """(i, ±1) if the outward unit normal of the boundaries ``names`` is ±e_i on every facet,
    else (None, 1.0)."""
    region = mesh.Boundaries("|".join(names))
    n = ngs.specialcf.normal(mesh.dim)
    area = parallel.sum(mesh, ngs.Integrate(mesh_ds(ngs.CF(1.0), region), mesh))   # the ranks' parts
    mean = parallel.sum(mesh, np.array([ngs.Integrate(mesh_ds(n[i], region), mesh) for i in range(mesh.dim)])) / area
    for i in range(mesh.dim):
        if abs(abs(mean[i]) - 1) < tol:             # |mean| = 1 only if ν = ±e_i everywhere
            return i, float(np.sign(mean[i]))
    return None, 1.0


def weak_regions(mesh, supports):
    """The boundary regions of the weak normal supports among ``supports`` (Nitsche terms)."""
    return [mesh.Boundaries("|".join(s.names)) for s in supports if s.normal]


def dirichlet_flags(clamped, supports, dim):
    """Keyword arguments of ``VectorH1``: ``dirichlet`` (all components: Γ1 and the "all"
    supports) and ``dirichletx`` ... for the per-axis ones."""
    full = list(clamped) + [n for s in supports if len(s.axes) == dim for n in s.names]
    flags = {"dirichlet": "|".join(full)}
    for i in range(dim):
        names = [n for s in supports if i in s.axes and len(s.axes) < dim for n in s.names]
        if names:
            flags["dirichlet" + AXES[i]] = "|".join(names)
    return flags
