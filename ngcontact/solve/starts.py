"""Newton's start for a step, apart from the physical state: guesses, and the start of a body
held only by its contact.

Step n solves R(x_n) = 0 by semismooth Newton from the state of step n − 1 (the warm start).
A guess (``Simulation.step(dt, guess=...)``) replaces the displacement of that start at the
free DOFs for one step: the physical state u_{n−1} (of the viscous term and the bonding
update) stays what it was, the supports keep their values at t_n, φ starts from φ_{n−1}, and
the guess may penetrate the obstacle. From a start whose contact set is the solution's, Newton
converges in one iteration; one that overestimates the set costs about an iteration per point
of Γ3 it must release (the linearised problem pulls on the outermost points only), one that
underestimates it fewer (it adds every point that penetrates; the counts of the Hertz
half-disk's starts: docs/speed.md).

Guesses:

* a displacement (m): a tuple of numbers or a CoefficientFunction (interpolated at t_n), a
  GridFunction of u (of this body's V, or interpolated from another mesh), or the DOF values
  of u (numpy);
* ``Approach(depth)``: the warm start moved rigidly by ``depth`` (m) along the contact normal
  (or a given direction): the informed start of force control, e.g. a²/2R for Hertz;
* ``"nested"``: nested iteration on the coarser levels of the mesh (``nested``);
* ``"p1"``: for a body of order p >= 2, the step solved with P1 on the same mesh first (any
  mesh: no hierarchy needed; ``nested.Nested.first_order``).

A body held only by its contact (``rigid.Floating``: e.g. u_x = 0 on top and a traction there)
has a singular Jacobian while Γ3 is open. Without a guess, a step whose start leaves Γ3 open
(its closed points do not hold the free rigid motions) starts from the warm start moved
rigidly, in the free motions the loads push it along, until the points of Γ3 nearest to the
obstacle hold those motions (``Starts.touch``); Newton then converges from that contact, and
an informed guess saves most of its iterations. A body the loads pull off stays singular.
"""
import numbers

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.model.axisymmetric import AXIS_TOLERANCE
from ngcontact.model.loads import as_cf
from ngcontact.solve.nested import Nested
from ngcontact.model.rigid import Floating, normal_components

GUESSES = ("None, a displacement (a tuple of numbers or a CoefficientFunction in m, a GridFunction of u, a numpy "
           "array of u's DOF values), an ngcontact.solve.starts.Approach, 'nested' or 'p1'")


class Approach:
    """The warm start moved rigidly by ``depth`` (m, > 0 towards the obstacle) along
    ``direction`` (a vector, normalised here), by default the contact normal at the point of
    Γ3 nearest to the obstacle (a Plane's −normal)."""

    def __init__(self, depth, direction=None):
        if isinstance(depth, bool) or not isinstance(depth, numbers.Real) or not np.isfinite(depth):
            raise TypeError(f"Approach: depth must be a finite number (m), got {depth!r}")
        self.depth, self.direction = float(depth), None
        if direction is not None:
            vector = np.asarray(direction, dtype=float) if isinstance(direction, (tuple, list, np.ndarray)) else None
            if vector is None or vector.ndim != 1 or not np.all(np.isfinite(vector)) or not np.linalg.norm(vector):
                raise ValueError(f"Approach: direction must be a nonzero finite vector, got {direction!r}")
            self.direction = vector / np.linalg.norm(vector)

    def check(self, starts):
        """A ValueError naming ``guess`` where the approach cannot apply (``starts``: the Starts of
        a simulation)."""
        body = starts.body
        if self.direction is None and starts.gamma3 is None:
            raise ValueError("guess=Approach(depth) without a direction needs a contact (its normal): the simulation "
                             "has contact=None")
        if self.direction is None:
            parallel.serial_only(body.mesh, "guess=Approach(depth) without a direction",
                                 "give Approach(depth, direction=...)")
        if self.direction is not None and len(self.direction) != body.dim:
            raise ValueError(f"guess=Approach: direction must have {body.dim} components, got "
                             f"{len(self.direction)}")

    def __call__(self, starts, u, t, target):
        direction = self.direction
        if direction is None:                              # the contact normal where the gap is smallest
            g = starts.gamma3
            facet, point = np.unravel_index(np.argmin(g.side.sample(g.gap)), g.side.sample_points.shape[:2])
            direction = g.side.normals[facet] if g.sampled_normal is None else \
                g.side.sample(g.sampled_normal)[facet, point]
        shift = ngs.GridFunction(starts.body.V)
        shift.Set(ngs.CF(tuple(self.depth * direction)))
        return u.vec.FV().NumPy() + shift.vec.FV().NumPy()

    def __repr__(self):
        direction = None if self.direction is None else self.direction.tolist()
        return f"Approach(depth={self.depth:g}, direction={direction})"


class Field:
    """A displacement guess: a CoefficientFunction (interpolated at t_n) or the DOF values of u."""

    def __init__(self, value):
        self.value = value

    def __call__(self, starts, u, t, target):
        if isinstance(self.value, np.ndarray):
            return self.value
        gf = ngs.GridFunction(starts.body.V)
        gf.Set(self.value)
        values = gf.vec.FV().NumPy()
        if parallel.any_rank(starts.body.mesh, not np.all(np.isfinite(values))):     # on every rank
            raise ValueError(f"guess is not finite (NaN or inf) at t = {target:.6g} s")
        return values


class Starts:
    """The Newton starts of a simulation of ``body`` with the Γ3 parts ``gamma3`` (or None) on
    the StepSystem ``system``: ``resolve`` checks a guess before any work, ``apply`` sets the
    start of a step; the nested levels are kept between steps (``nested``). ``at(t)``: the
    context in which time-dependent data are evaluated at t (``StepCoefficients.at``);
    ``coarse(mesh, order)``: the ``time.step.Step`` of the same scene on another mesh or order
    (the levels of ``nested``). ``floating``: the rigid motions only the contact holds
    (``rigid.Floating``, checked when the simulation is built); ``last``: what the last step
    started from ("warm", "guess", "touch", or the fallback of a nested start)."""

    def __init__(self, body, gamma3, system, at, coarse):
        self.body, self.gamma3, self.system, self.at, self.coarse = body, gamma3, system, at, coarse
        self.floating = Floating(body, gamma3)
        self._nested, self._first_order, self._motions = None, None, None
        self.last = None

    @property
    def nested(self):
        """The ``nested.Nested`` start, built at its first use."""
        if self._nested is None:
            self._nested = Nested.on_coarser_meshes(self.body, self.coarse)
        return self._nested

    @property
    def first_order(self):
        """The start "p1" (``nested.Nested.first_order``), built at its first use."""
        if self._first_order is None:
            self._first_order = Nested.first_order(self.body, self.coarse)
        return self._first_order

    def resolve(self, guess):
        """The start for ``guess`` (module docstring), checked: a TypeError or ValueError naming
        ``guess`` for one of the wrong kind, shape or values, or that cannot apply here."""
        body = self.body
        if guess is None:
            return None
        if isinstance(guess, str):
            if guess not in ("nested", "p1"):
                raise ValueError(f"guess must be {GUESSES}; got the string {guess!r}")
            return self.nested if guess == "nested" else self.first_order
        if isinstance(guess, Approach):
            guess.check(self)
            return guess
        if isinstance(guess, np.ndarray):
            if parallel.any_rank(body.mesh, guess.shape != (body.V.ndof,) or not np.issubdtype(
                    guess.dtype, np.number) or np.iscomplexobj(guess)):          # (each rank's DOFs)
                raise ValueError(f"guess: an array of u's DOF values must be real of shape ({body.V.ndof},), got "
                                 f"{guess.dtype} of shape {guess.shape}")
            values = guess.astype(float)
        elif isinstance(guess, ngs.GridFunction):
            if guess.dim != body.dim:
                raise ValueError(f"guess: a GridFunction of u must have {body.dim} components, got {guess.dim}")
            same = guess.space.mesh is body.mesh and guess.space.ndof == body.V.ndof
            values = guess.vec.FV().NumPy().copy() if same else None
            if values is None:                  # another mesh's: finite values from finite coefficients
                if parallel.any_rank(body.mesh, not np.all(np.isfinite(guess.vec.FV().NumPy()))):
                    raise ValueError("guess is not finite (NaN or inf) in the body")
                return Field(guess)
        elif isinstance(guess, (ngs.CoefficientFunction, tuple, list)):
            return self._field(as_cf(guess, body.dim, "guess"))
        else:
            raise TypeError(f"guess must be {GUESSES}; got {type(guess).__name__}")
        if parallel.any_rank(body.mesh, not np.all(np.isfinite(values))):
            raise ValueError("guess is not finite (NaN or inf)")
        return Field(values)

    def _field(self, cf):
        mesh = self.body.mesh
        if not np.isfinite(parallel.sum(mesh, ngs.Integrate(ngs.InnerProduct(cf, cf), mesh))):
            raise ValueError("guess is not finite (NaN or inf) in the body")
        return Field(cf)

    def apply(self, start, u, t, target):
        """Set the displacement ``u`` (GridFunction, holding the warm start with the supports'
        values at ``target``) to the start of the step t → target (s) from ``start`` (from
        ``resolve``), or, for a body held only by its contact whose start leaves Γ3 open, to
        ``touch``. The time Parameter is left as it was (at ``target``): the coarse levels of
        a nested start share it, and a level that fails restores it to its own time."""
        with self.at(target):                            # t_n kept: a coarse level may move it
            values = start(self, u, t, target) if start is not None else None
        self.last = "warm" if start is None else "guess"
        if isinstance(start, Nested) and start.fallback:
            self.last = start.fallback
        if values is None and self.floating and self.gamma3 is not None and self.open(u):
            values = self.touch(u)
            self.last = "touch" if values is not None else self.last
        if values is not None:                           # u's free DOFs from values, the held ones kept
            free = ~self.system.held
            u.vec.FV().NumPy()[free] = values[free]

    def _components(self, u):
        """(u·n − g at the sample points of Γ3, r·n of the free motions there (points × motions)).
        On a body of revolution a point on the axis holds nothing (its ring has no area, the
        weight 2π r of Γ3's terms is 0 there): its components are 0."""
        g = self.gamma3
        opening = g.side.normal_displacement(u, g.sampled_normal).ravel() - g.side.sample(g.gap).ravel()
        components = normal_components(self.floating.fields, g.side, g.sampled_normal).T @ self.floating.basis
        if self.body.axisymmetric:
            radius = g.side.sample_points[..., 0].ravel()
            components = components * (radius > AXIS_TOLERANCE * self.body.size)[:, None]
        return opening, components

    def _holds(self, points, components, gathered=False):
        """Whether the sample points ``points`` (a mask) of Γ3 hold every free motion; the
        rank's points, or with ``gathered`` every rank's (``parallel.gather``: no sum)."""
        total = (lambda a: a) if gathered else (lambda a: parallel.sum(self.body.mesh, a))
        gram = total(components[points].T @ components[points])
        full = total(components.T @ components)
        return np.linalg.eigvalsh(gram)[0] > 1e-6 * np.linalg.eigvalsh(full)[-1]

    def open(self, u):
        """Whether the displacement ``u`` leaves Γ3 too open to hold the free rigid motions."""
        opening, components = self._components(u)
        return not self._holds(opening >= 0, components)

    def touch(self, u):
        """u's DOF values moved rigidly, in the free motions along which the loads push, until
        the points of Γ3 nearest to the obstacle hold every free motion; None where the loads
        push along no free motion towards the obstacle."""
        body, system = self.body, self.system
        if self._motions is None:
            self._motions = self.floating.vectors(body.V)
        load = system.f.vec.FV().NumPy()[:body.V.ndof]
        force = parallel.sum(body.mesh, self._motions.T @ load)
        if not np.linalg.norm(force) > 0:
            return None
        direction = force / np.linalg.norm(force)
        opening, components = self._components(u)            # every rank's points: the same search on each
        opening, components = parallel.gather(body.mesh, opening), parallel.gather(body.mesh, components)
        towards = components @ direction                     # r·n of the motion at each point
        closing = np.where(towards > 1e-12, -opening / np.where(towards > 1e-12, towards, 1.0), np.inf)
        order = np.argsort(closing)
        if not np.isfinite(closing[order[0]]):
            return None
        count = 1
        while count < len(order) and not self._holds(np.isin(np.arange(len(order)), order[:count]), components,
                                                     gathered=True):
            count *= 2
        depth = closing[order[min(count, len(order)) - 1]]
        depth = max(depth, 0.0) * (1 + 1e-6) + 1e-12 * body.size
        return u.vec.FV().NumPy() + depth * (self._motions @ direction)

