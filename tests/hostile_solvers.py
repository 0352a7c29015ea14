"""Hostile inputs of classes ``solvers`` and ``debonded`` (``tests/test_hostile.py``).

``solvers``: linear solver objects of the user's (``Simulation(solver=...)``) that break the
protocol (``ngcontact.solve.linalg.protocol``): corrections with NaN entries, nothing written,
the correction returned instead of written, zeros, the wrong sign, entries outside the free DOFs,
a vector of the wrong size, an exception. Each ends in a NewtonError at the first correction that
names the solver's class and what it returned, never a singular model, a smaller time step or
the supports, and without cut-backs (``Blamed``). The class passed instead of an instance, and a
``solve`` that cannot take Newton's arguments, are TypeErrors naming ``solver`` before any work;
a solver that keeps the protocol gives the scene's force balance.

``debonded``: bodies held only by prescribed displacements, glued to the foundation, lifted until
the glue lets go and on: after it they move rigidly with their support, and a residual at the
round-off of that motion is certified whatever the (tiny) load of the glue's last β. Each runs
to its end with the body at the support's displacement and the reaction and contact force at
round-off of their peak (``Right``).
"""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

CLASSES = ("solvers", "debonded")


# ----------------------------------------------------------------------------- user solvers

class Exact:
    """Newton's corrections by SciPy's sparse LU of the free block: the protocol kept."""
    name = "scipy splu"

    def correction(self, matrix, freedofs, r):
        free = np.flatnonzero(np.array(list(freedofs), dtype=bool))
        rows, cols, values = matrix.COO()
        J = sp.csc_matrix((np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=(matrix.height,) * 2)
        x = np.zeros(matrix.height)
        x[free] = spla.splu(J[free][:, free]).solve(r.FV().NumPy()[free])
        return x

    def solve(self, matrix, freedofs, r, w, generation=None, timer=None, weights=None, tol=None, changing=None):
        w.FV().NumPy()[:] = self.correction(matrix, freedofs, r)


class NaNs(Exact):
    """The correction with one NaN entry."""

    def solve(self, matrix, freedofs, r, w, **options):
        x = self.correction(matrix, freedofs, r)
        x[np.flatnonzero(np.array(list(freedofs)))[0]] = np.nan
        w.FV().NumPy()[:] = x


class Nothing(Exact):
    """Writes nothing, returns None."""

    def solve(self, matrix, freedofs, r, w, **options):
        return None


class Returns(Exact):
    """Returns the correction instead of writing it into w."""

    def solve(self, matrix, freedofs, r, w, **options):
        return self.correction(matrix, freedofs, r)


class Zeros(Exact):
    """Writes zeros, returns 0."""

    def solve(self, matrix, freedofs, r, w, **options):
        w.FV().NumPy()[:] = 0.0
        return 0


class Opposite(Exact):
    """The correction with the wrong sign."""

    def solve(self, matrix, freedofs, r, w, **options):
        w.FV().NumPy()[:] = -self.correction(matrix, freedofs, r)


class Noise(Exact):
    """Writes random numbers of 1e-20 m at the free DOFs."""

    def solve(self, matrix, freedofs, r, w, **options):
        free = np.array(list(freedofs), dtype=bool)
        w.FV().NumPy()[:] = np.where(free, 1e-20 * np.random.default_rng(0).standard_normal(len(free)), 0.0)


class Inexact(Exact):
    """The correction to 10 % (an iterative solver's loose tolerance): slower, not wrong."""

    def solve(self, matrix, freedofs, r, w, **options):
        w.FV().NumPy()[:] = 0.9 * self.correction(matrix, freedofs, r)


class Outside(Exact):
    """The correction, and 1e-3 m at the held DOFs (which would move the supports)."""

    def solve(self, matrix, freedofs, r, w, **options):
        x = self.correction(matrix, freedofs, r)
        x[~np.array(list(freedofs), dtype=bool)] = 1e-3
        w.FV().NumPy()[:] = x


class WrongSize(Exact):
    """Writes a vector one entry too long."""

    def solve(self, matrix, freedofs, r, w, **options):
        w.FV().NumPy()[:] = np.append(self.correction(matrix, freedofs, r), 0.0)


class Raising(Exact):
    """Raises in its factorisation."""

    def solve(self, matrix, freedofs, r, w, **options):
        raise MemoryError("out of memory in the factorisation")


class TwoArguments:
    """A ``solve(A, b)`` that cannot take Newton's arguments."""
    name = "two arguments"

    def solve(self, A, b):
        return b


class Blamed:
    """A NewtonError at the first correction (iteration 1, one time step tried: no cut-backs)
    naming every word (the solver and what it returned), and none of the model's remedies."""

    def __init__(self, h, *words):
        self.h, self.words = h, words

    def problem(self, outcome, references):
        _line, _named = self.h._line, self.h._named
        if outcome.kind != "raised" or "NewtonError" not in outcome.types:
            return f"expected a NewtonError naming {'/'.join(self.words)}; {outcome.describe()}"
        message = outcome.message
        missing = _named(message, self.words)
        if missing:
            return f"the NewtonError does not name {'/'.join(missing)}: {_line(message)}"
        if "iteration 1;" not in message or "dt = 0.05 s; the state" not in message:
            return f"not at the first correction without cut-backs: {_line(message, 400)}"
        wrong = [w for w in ("singular", "smaller time step", "supports that hold") if w in message]
        if wrong:
            return f"blames the model ({', '.join(wrong)}): {_line(message)}"
        return None


class Right:
    """The call returns and ``check(value)`` is None (else what is wrong); like ``Correct``,
    without the suite's reference runs."""

    def __init__(self, check):
        self.check = check

    def problem(self, outcome, references):
        if outcome.kind != "returned":
            return f"expected a correct result; {outcome.describe()}"
        wrong = self.check(outcome.value)
        return None if wrong is None else f"silently wrong: {wrong}"


# ----------------------------------------------------------------------------- debonded scenes

def lifted(dim=2, lift=2e-4, material=None, order=1, update="implicit", **contact):
    """The plate (or 3D block) held only by its top ("all"), glued below (γ_ν = 1e14 Pa/m,
    L = 10 µm, gap 0) and lifted by ``lift`` t (m) over 1 s in steps of 0.1 s: its peak and last
    reaction (N/m or N), last contact force, the bottom's displacement and the time reached."""
    import ngsolve as ngs
    import ngcontact as ngc
    from ngcontact.geometries import block, plate
    mesh = plate(maxh=0.01) if dim == 2 else block(maxh=0.02)
    material = material or ngc.Material.isotropic(6e10, 0.3, 1e-8)
    grounded = dict(grounded="top") if np.any(material.e) else {}
    body = ngc.Body(mesh, material, supports={"top": "all"}, contact_side="bottom", order=order, **grounded)
    t = ngs.Parameter(0.0)
    up = (0.0,) * (dim - 1) + (lift * t,)
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": up}), time=t, contact=ngc.Contact(
        **{**dict(gap=0.0, adhesion=1e14, bond_length=1e-5, beta_update=update), **contact}))
    sim.run(0.1, 1.0)
    reactions = [abs(r.boundary_reaction["top"][dim - 1]) for r in sim.history]
    lowest = min((v.point for v in mesh.vertices), key=lambda p: (p[-1], p[0]))
    bottom = sim.u(mesh(*lowest))
    return dict(time=float(sim.t), peak=max(reactions), reaction=reactions[-1],
                force=float(np.abs(sim.history[-1].contact.force).max()), uz=float(bottom[dim - 1]),
                ux=float(np.abs(bottom[:dim - 1]).max()), target=lift, cutbacks=len(sim.cutbacks))


def glued_disk(pull=1e-4, maxh=4e-4):
    """A PZT-5A disk's section (radius 5 mm, 1 mm thick) glued on its bottom (γ_ν = 1e14 Pa/m,
    L = 1 µm, implicit β), pulled ``pull`` (m) over 1 s by a grounded stud of radius 1 mm on its
    top, in 10 steps: as ``lifted``."""
    import ngsolve as ngs
    from netgen.geom2d import SplineGeometry
    import ngcontact as ngc
    from ngcontact.obstacles import Plane
    W, H, S = 5e-3, 1e-3, 1e-3
    geometry = SplineGeometry()
    points = [geometry.AppendPoint(*p) for p in ((0, 0), (W, 0), (W, H), (S, H), (0, H))]
    for (a, b), name in zip(((0, 1), (1, 2), (2, 3), (3, 4), (4, 0)), ("bottom", "rim", "top", "stud", "axis")):
        geometry.Append(["line", points[a], points[b]], bc=name)
    mesh = ngs.Mesh(geometry.GenerateMesh(maxh=maxh))
    t = ngs.Parameter(0.0)
    body = ngc.Body(mesh, ngc.pzt5a(), supports={"stud": "all"}, grounded="stud", contact_side="bottom",
                    axisymmetric=True)
    contact = ngc.Contact(obstacle=Plane((0, 0), (0, 1)), adhesion=1e14, bond_length=1e-6, beta_update="implicit")
    sim = ngc.Simulation(body, ngc.Loads(displacement={"stud": (0, pull * t)}), contact=contact, time=t,
                         keep_states=False)
    sim.run(0.1, 1.0)
    reactions = [abs(r.boundary_reaction["stud"][1]) for r in sim.history]
    bottom = sim.u(mesh(W / 2, 0.0))
    return dict(time=float(sim.t), peak=max(reactions), reaction=reactions[-1],
                force=float(np.abs(sim.history[-1].contact.force).max()), uz=float(bottom[1]), ux=None,
                target=pull, cutbacks=len(sim.cutbacks))


def released(v):
    """At t = 1 s, the glue let go: the reaction and the contact force at round-off of the peak
    reaction, the bottom at the support's displacement (the body moves rigidly; radially free
    for the disk, whose section shrinks by Poisson, so only u_z)."""
    if v["time"] != 1.0:
        return f"stopped at t = {v['time']}"
    if not v["peak"] > 0:
        return "the glue never held"
    for name in ("reaction", "force"):
        if v[name] > 1e-12 * v["peak"]:
            return f"{name} {v[name]:.3g} after release, peak reaction {v['peak']:.3g}"
    if abs(v["uz"] - v["target"]) > 1e-9 * v["target"]:
        return f"the bottom at {v['uz']:.6g} m, the support at {v['target']:.6g} m"
    if v["ux"] is not None and v["ux"] > 1e-9 * v["target"]:
        return f"the bottom moved sideways by {v['ux']:.3g} m"
    return None


def register(h):
    def run(solver, order=1, **options):
        """The coarse reference scene with ``solver``, two steps of 0.05 s (cut-backs allowed)."""
        def call(ctx):
            sim = h.scene.simulation(order, 0.01, solver=solver(), **options)
            sim.run(0.05, 0.1)
            return h.measure(sim, h.applied(sim.t))
        return call

    def balanced(v):
        return h._balance(v)

    h.case("solvers", "a solver object that keeps the protocol", run(Exact), Right(balanced))
    h.case("solvers", "a solver object that solves to 10 %", run(Inexact), Right(balanced))
    h.case("solvers", "a solver object that keeps the protocol, P2 condensed", run(Exact, order=2, condense=True),
           Right(balanced))
    for solver, words in ((NaNs, ("NaNs", "NaN")), (Nothing, ("Nothing", "no correction")),
                          (Returns, ("Returns", "no correction", "returned a ndarray")),
                          (Zeros, ("Zeros", "no correction", "returned 0")),
                          (Opposite, ("Opposite", "opposite sign")), (Noise, ("Noise", "does not solve")),
                          (Outside, ("Outside", "outside the free DOFs")),
                          (WrongSize, ("WrongSize", "ValueError")), (Raising, ("Raising", "MemoryError"))):
        doc = solver.__doc__.strip().rstrip(".")
        h.case("solvers", f"{solver.__name__}: {doc[0].lower()}{doc[1:]}", run(solver),
               Blamed(h, "linear solver", *words))
    h.case("solvers", "the class instead of an instance", lambda ctx: h.built(h.simulation(solver=Exact)),
           h.Error(h.TE, "solver", "instance", "Exact"))
    h.case("solvers", "solve(A, b)", lambda ctx: h.built(h.simulation(solver=TwoArguments())),
           h.Error(h.TE, "solver", "TwoArguments"))

    right = Right(released)
    h.case("debonded", "plate lifted 0.2 mm", lambda ctx: lifted(), right)
    h.case("debonded", "plate lifted 1 mm", lambda ctx: lifted(lift=1e-3), right)
    h.case("debonded", "plate lifted, P2", lambda ctx: lifted(order=2), right)
    h.case("debonded", "plate lifted, glue at a gap of 1 µm", lambda ctx: lifted(gap=1e-6), right)
    h.case("debonded", "plate lifted, explicit β", lambda ctx: lifted(update="explicit"), right)
    h.case("debonded", "PZT-5A plate lifted, grounded on top", lambda ctx: lifted(material=h.ngc.pzt5a()), right)
    h.case("debonded", "block lifted", lambda ctx: lifted(dim=3), right)
    h.case("debonded", "glued disk pulled 100 µm", lambda ctx: glued_disk(), right)
