"""Hostile inputs of bodies of revolution, mesh makers and leftovers (``tests/test_hostile.py``):

* ``axis``: data on the axis r = 0 of a body of revolution (``Body(axisymmetric=True)``), a line
  without area. A clamp, an electrode, Γ3 or a support of u_z there, a traction or a charge there,
  u_r prescribed nonzero on the axis or where a support meets it: refused by name (the part, the
  boundary, why). A support "x" or "normal" on the axis is redundant: accepted, and the step
  keeps u_r = 0 there and balances its forces;
* ``meshes``: the mesh makers of the scenes (``scenes.hertz.mesh``, ``scenes.indenter``,
  ``scenes.electrode``) refuse, before meshing, a contact mesh size that is not a positive number
  or would have Netgen make more than ``meshes.MAX_MESHED_VERTICES`` vertices; ``nested_mesh``
  refuses refinements beyond ``checks.MAX_REFINE`` or the memory; a malformed ``Hierarchy`` is
  refused where it is made or where a Body takes it;
* ``leftovers``: raw Python errors of earlier releases, now named: the reference scene's mesh
  size, ``save_html`` of what cannot be drawn, a History's unknown column, Hertz's closed form
  for a force <= 0.
"""
import functools

CLASSES = ("axis", "meshes", "leftovers")


def register(h):
    VE, TE, NAN, INF = h.VE, h.TE, h.NAN, h.INF
    ngc, ngs = h.ngc, h.ngs

    # ------------------------------------------------------------------ scenes (built in the case's process)

    @functools.cache
    def section():
        """The coarse meridian section of Hertz's half-ball (boundaries "axis", "top", "contact")."""
        from ngcontact.scenes import hertz
        return hertz.mesh(2, h_contact=0.1, axisymmetric=True)

    def body(**parts):
        from ngcontact.scenes import hertz
        parts.setdefault("supports", {"top": "all"})
        return ngc.Body(section(), hertz.material(), axisymmetric=True, **parts)

    def simulation(loads, **parts):
        """The section pressed 0.01 R onto the plane y = 0 by its top, with ``loads(t)``' entries added."""
        from ngcontact.gamma3.obstacles import Plane
        t = ngs.Parameter(0.0)
        given = loads(t)
        displacement = {"top": (0.0, -0.01 * t), **given.pop("displacement", {})}
        return ngc.Simulation(body(contact_side="contact", **parts), ngc.Loads(displacement=displacement, **given),
                              contact=ngc.Contact(obstacle=Plane((0.0, 0.0), (0.0, 1.0))), time=t)

    def axis(label, call, *words):
        h.case("axis", label, call, h.Error(VE, *words))

    # ------------------------------------------------------------------ parts on the axis

    axis("Body(clamped='axis')", lambda ctx: repr(body(clamped="axis")), "clamped", "axis")
    axis("Body(grounded='axis')", lambda ctx: repr(body(grounded="axis")), "grounded", "axis", "capacity")
    axis("Body(grounded='axis|top')", lambda ctx: repr(body(grounded="axis|top")), "grounded", "axis")
    axis("Body(contact_side='axis|contact')", lambda ctx: repr(body(contact_side="axis|contact")),
         "contact_side", "axis")
    for supports in ({"top": "all", "axis": "all"}, {"top": "all", "axis": "y"}, {"axis|top": "all"}):
        axis(f"Body(supports={supports})", lambda ctx, s=supports: repr(body(supports=s)), "supports", "axis")

    def redundant(kind):
        """A support ``kind`` on the axis: accepted, u_r = 0 there after a step that balances."""
        def call(ctx):
            sim = simulation(lambda t: dict(displacement={"axis": 0.0}), supports={"top": "all", "axis": kind})
            sim.step(1.0)
            record, mesh = sim.history[-1], sim.body.mesh
            on_axis = [v.point for v in mesh.vertices if abs(v.point[0]) < 1e-12]
            return dict(u_r=max(abs(sim.u(mesh(*p))[0]) for p in on_axis), force=float(record.contact.force[1]),
                        reaction=float(record.boundary_reaction["top"][1]),
                        axial=float(record.boundary_reaction["axis"][1]), axes=repr(sim.body.support_of("axis").axes))

        def check(v, references):
            wrong = []
            if v["u_r"] > 0 or v["axes"] != "(0,)":
                wrong.append(f"u_r = {v['u_r']:.3g} m on the axis (support axes {v['axes']})")
            if not v["force"] > 0 or abs(v["force"] + v["reaction"]) > 1e-8 * v["force"] or v["axial"] != 0:
                wrong.append(f"contact force {v['force']:.6g} N, top's reaction {v['reaction']:.6g} N, the axis' "
                             f"axial reaction {v['axial']:.3g} N")
            return "; ".join(wrong) or None
        h.case("axis", f"supports axis: {kind!r}, u_r = 0 (redundant)", call, h.Correct(check))

    for kind in ("x", "normal"):
        redundant(kind)

    # ------------------------------------------------------------------ loads on the axis

    axis("Loads(f2 on the axis)", lambda ctx: h.built(simulation(lambda t: dict(f2={"axis": (0.0, 1.0)}))),
         "f2", "axis")
    axis("Loads(f2 on axis|top)", lambda ctx: h.built(simulation(lambda t: dict(f2={"axis|contact": (0.0, 1.0)}),
                                                                 supports={"top": "x"})), "f2", "axis")
    axis("Loads(qb on the axis)", lambda ctx: h.built(simulation(lambda t: dict(qb={"axis": 1e-3}))), "qb", "axis")
    axis("Loads(u_r 1e-3 on the axis)", lambda ctx: h.built(simulation(lambda t: dict(displacement={"axis": 1e-3}))),
         "displacement", "axis")
    axis("Loads(u_r 1e-3 t on the axis, support x)", lambda ctx: h.built(simulation(
        lambda t: dict(displacement={"axis": 1e-3 * t}), supports={"top": "all", "axis": "x"})),
         "displacement", "axis")
    axis("Loads(u_r 1e-3 on the top, meeting the axis)", lambda ctx: h.built(simulation(
        lambda t: dict(displacement={"top": (1e-3, -0.01 * t)}))), "displacement", "axis")
    def stepped(sim):
        sim.step(0.5)
        sim.step(0.5)
        return dict(t=sim.t)

    h.case("axis", "Loads(u_r = 1e-3 t on the top, meeting the axis: 0 when built)",
           lambda ctx: stepped(simulation(lambda t: dict(displacement={"top": (1e-3 * t, -0.01 * t)}))),
           h.Error(VE, "displacement", "axis", "t"))
    axis("indenter with the tip's electrode on the axis", lambda ctx: repr(ngc.Body(
        section(), ngc.pzt5a(), supports={"top": "all"}, grounded="axis", axisymmetric=True)), "grounded", "axis")

    # ------------------------------------------------------------------ mesh makers

    def meshes(label, call, kind, *words):
        h.case("meshes", label, call, h.Error(kind, *words))

    def hertz_mesh(*args, **kwargs):
        def call(ctx):
            from ngcontact.scenes import hertz
            return hertz.mesh(*args, **kwargs).nv
        return call

    meshes("hertz.mesh(2, h_contact=1e-5, axisymmetric=True)", hertz_mesh(2, h_contact=1e-5, axisymmetric=True), VE,
           "h_contact")
    for value in (0.0, -1.0, NAN, INF, 2.0, 1e-300):
        meshes(f"hertz.mesh(h_contact={value:g})", hertz_mesh(h_contact=value), VE, "h_contact")
    meshes("hertz.mesh(h_contact='x')", hertz_mesh(h_contact="x"), TE, "h_contact")
    meshes("hertz.mesh(3, h_contact=1e-3)", hertz_mesh(3, h_contact=1e-3), VE, "h_contact")
    meshes("hertz.mesh(3, h_contact=2e-3, quarter=True)", hertz_mesh(3, h_contact=2e-3, quarter=True), VE, "h_contact")
    meshes("hertz.mesh(dim=4)", hertz_mesh(4), VE, "dim")
    meshes("hertz.mesh(refine=12)", hertz_mesh(2, 0.2, refine=12), VE, "refine")
    meshes("hertz.mesh(radius=0)", hertz_mesh(2, radius=0.0), VE, "radius")

    def scene(module, **kwargs):
        def call(ctx):
            import importlib
            return repr(importlib.import_module(f"ngcontact.scenes.{module}").simulation(**kwargs))
        return call

    meshes("hertz.simulation(h_contact=1e-5)", scene("hertz", h_contact=1e-5), VE, "h_contact")
    meshes("indenter.simulation(h_contact=2e-8)", scene("indenter", h_contact=2e-8), VE, "h_contact")
    meshes("indenter.simulation(h_contact=0)", scene("indenter", h_contact=0.0), VE, "h_contact")
    meshes("electrode.simulation(h_contact=1e-7)", scene("electrode", h_contact=1e-7), VE, "h_contact")
    meshes("indenter.simulation(width=1)", scene("indenter", width=1.0), VE, "width", "thickness")
    meshes("indenter.mesh(fine=0)", lambda ctx: repr(__import__("ngcontact.scenes.indenter", fromlist=["mesh"]).mesh(
        fine=0.0)), VE, "fine")

    def square(maxh=0.25):
        from netgen.geom2d import unit_square
        return unit_square.GenerateMesh(maxh=maxh)

    def nested(refine, wrap=False, maxh=0.25):
        def call(ctx):
            from ngcontact.meshes import nested_mesh
            return nested_mesh(ngs.Mesh(square(maxh)) if wrap else square(maxh), refine).nv
        return call

    meshes("nested_mesh(m, 14)", nested(14), VE, "refine")
    # about 3000 vertices refined 10 times: 1e10 DOFs, 18 TiB, more than any machine
    meshes("nested_mesh(m, 10) (memory)", nested(10, maxh=0.02), VE, "refine", "TiB")
    meshes("nested_mesh(m, -1)", nested(-1), VE, "refine")
    meshes("nested_mesh(m, None)", nested(None), TE, "refine")
    meshes("nested_mesh(ngsolve.Mesh, 1)", nested(1, wrap=True), TE, "nested_mesh", "Netgen")

    def hierarchy(coarse=square, refinements=1, vertices=None, at_body=False, shift=False):
        """``Hierarchy(coarse(), refinements, vertices)`` (default: those of the square refined
        once), given to a Body of that square refined once where ``at_body``."""
        def call(ctx):
            from ngcontact import meshes as m
            fine = m.nested_mesh(square(), 1)
            if shift:                               # another mesh with the same counts
                for point in fine.ngmesh.Points():
                    point[0] = point[0] * 0.5
            given = coarse()
            kept = m.Hierarchy(given, refinements, fine.nv if vertices is None else vertices)
            if not at_body:
                return repr(kept)
            return repr(ngc.Body(fine, ngc.Material.isotropic(1.0, 0.3, permittivity=1.0), clamped="left",
                                 hierarchy=kept).hierarchy)
        return call

    meshes("Hierarchy(ngsolve.Mesh, 1, n)", hierarchy(lambda: ngs.Mesh(square())), TE, "coarse", "Netgen")
    meshes("Hierarchy(coarse, -1, n)", hierarchy(refinements=-1), VE, "refinements")
    meshes("Hierarchy(coarse, 1.5, n)", hierarchy(refinements=1.5), TE, "refinements")
    meshes("Hierarchy(coarse, 1, 'x')", hierarchy(vertices="x"), TE, "vertices")
    meshes("Hierarchy(coarse, 1, 3)", hierarchy(vertices=3), VE, "vertices")
    meshes("Body(hierarchy=[coarse])", lambda ctx: repr(ngc.Body(
        ngc.meshes.nested_mesh(square(), 1), ngc.Material.isotropic(1.0, 0.3, permittivity=1.0), clamped="left",
        hierarchy=[square()])), TE, "hierarchy")
    meshes("Body(hierarchy: refinements 2 for 1)", hierarchy(refinements=2, at_body=True), VE, "hierarchy")
    meshes("Body(hierarchy: vertices + 1)", lambda ctx: hierarchy(
        at_body=True, vertices=ngc.meshes.nested_mesh(square(), 1).nv + 1)(ctx), VE, "hierarchy")

    def renamed():
        mesh = square()
        mesh.SetBCName(0, "floor")
        return mesh

    meshes("Body(hierarchy: other boundary names)", hierarchy(renamed, at_body=True), VE, "hierarchy", "boundaries")
    meshes("Body(hierarchy: another mesh, same counts)", hierarchy(at_body=True, shift=True), VE, "hierarchy",
           "vertices")

    def accepted(ctx):
        return dict(refinements=int(hierarchy(at_body=True)(ctx).split("refinements=")[1].split(",")[0]))
    h.case("meshes", "Body(hierarchy: a valid one)", accepted,
           h.Correct(lambda v, references: None if v["refinements"] == 1 else f"refinements {v['refinements']}"))

    # ------------------------------------------------------------------ leftovers

    def leftover(label, call, kind, *words):
        h.case("leftovers", label, call, h.Error(kind, *words))

    def reference(*args, **kwargs):
        def call(ctx):
            from ngcontact.scenes import reference as scene
            return repr(scene.simulation(*args, **kwargs))
        return call

    leftover("reference.simulation(1, 'fine')", reference(1, "fine"), TE, "maxh")
    leftover("reference.simulation(1, 0)", reference(1, 0.0), VE, "maxh")
    leftover("reference.simulation(1, 0.01, dim=4)", reference(1, 0.01, dim=4), VE, "dim")

    def page(*args, **kwargs):
        def call(ctx):
            return str(ngc.save_html(*args, **kwargs))
        return call

    leftover("save_html('u.html', 'text')", page("u.html", "text"), TE, "save_html", "GridFunction")
    leftover("save_html('u.html')", page("u.html"), TE, "save_html", "GridFunction")
    leftover("save_html(3, mesh)", lambda ctx: page(3, ngs.Mesh(square()))(ctx), TE, "filename")
    leftover("save_html('u.html', x)", lambda ctx: page("u.html", ngs.x)(ctx), TE, "mesh")

    def history(contact=True):
        """The History (step 0) of a unit square, clamped on the left, pressed onto a plane or free."""
        from ngcontact.gamma3.obstacles import Plane
        body = ngc.Body(ngs.Mesh(square()), ngc.Material.isotropic(1.0, 0.3, permittivity=1.0), clamped="top",
                        contact_side="bottom" if contact else None)
        obstacle = ngc.Contact(obstacle=Plane((0.0, 0.0), (0.0, 1.0))) if contact else None
        return ngc.Simulation(body, ngc.Loads(), contact=obstacle).history

    leftover("history.contact_column('nope')", lambda ctx: repr(history().contact_column("nope")), VE,
             "contact_column", "nope", "ContactRecord")
    leftover("history.contact_column(3)", lambda ctx: repr(history().contact_column(3)), TE, "contact_column")
    leftover("history.column('nope')", lambda ctx: repr(history().column("nope")), VE, "column", "nope")
    leftover("history.contact_column('force') without contact", lambda ctx: repr(
        history(contact=False).contact_column("force")), VE, "contact_column", "contact")

    def closed(*args):
        def call(ctx):
            from ngcontact.scenes import hertz
            return repr(hertz.closed_form(*args))
        return call

    for force in (-1.0, 0.0, NAN, INF):
        leftover(f"hertz.closed_form({force:g})", closed(force), VE, "force")
    leftover("hertz.closed_form('x')", closed("x"), TE, "force")
    leftover("hertz.closed_form(1, 4)", closed(1.0, 4), VE, "dim")

    def hertz_2d(ctx):
        import math
        from ngcontact.scenes import hertz
        a, p0 = hertz.closed_form(0.01)
        return dict(a=a, p0=p0, expected_a=math.sqrt(4 * 0.01 * hertz.R / (math.pi * hertz.E_STAR)))
    h.case("leftovers", "hertz.closed_form(0.01)", hertz_2d, h.Correct(
        lambda v, references: None if abs(v["a"] - v["expected_a"]) <= 1e-14 * v["a"] and
        abs(v["p0"] - 2 * 0.01 / (3.141592653589793 * v["a"])) <= 1e-14 * v["p0"] else f"a, p0 = {v['a']}, {v['p0']}"))
