"""Hostile inputs of the consoles' options (``tests/test_hostile.py``, class ``consoles``): the
obstacles' direction given twice, not at all or wrongly, ``run(restart_data=...)`` of the wrong
type or without ``out``, and ``adapt --tol`` with an empty ``--out``. Each is refused before any
work, naming the argument as the user passed it."""
import ngsolve as ngs

CLASSES = ("consoles",)


def register(h):
    import ngcontact as ngc
    from ngcontact import obstacles
    VE, TE = h.VE, h.TE

    def case(label, call, expect):
        h.case("consoles", label, call, expect)

    case("Plane(outward and normal)", lambda ctx: repr(obstacles.Plane((0, 0), (0, 1), normal=(0, 1))),
         h.Error(TE, "outward", "normal"))
    case("Plane(point) without a direction", lambda ctx: repr(obstacles.Plane((0, 0))), h.Error(TE, "outward"))
    case("SignedDistance(outward=(0, 0))", lambda ctx: h.step_once(h.simulation(contact=ngc.Contact(
        obstacle=obstacles.SignedDistance(ngs.y + 2e-5, outward=(0.0, 0.0))))), h.Error(VE, "outward"))
    case("SignedDistance(outward reversed)", lambda ctx: h.step_once(h.simulation(contact=ngc.Contact(
        obstacle=obstacles.SignedDistance(ngs.y + 2e-5, outward=(0.0, -1.0))))), h.Error(VE, "outward", "reversed"))
    case("SignedDistance(outward='x')", lambda ctx: repr(obstacles.SignedDistance(ngs.y, outward="x")),
         h.Error(TE + "|" + VE, "outward"))
    case("Plane(normal=(0, 0)) by its old name", lambda ctx: repr(obstacles.Plane((0, 0), normal=(0, 0))),
         h.Error(VE, "normal"))
    case("run(restart_data='no')", lambda ctx: h.simulation().run(0.05, 0.1, out=ctx["work"], restart_data="no"),
         h.Error(TE, "restart_data"))
    case("run(restart_data=False) without out", lambda ctx: h.simulation().run(0.05, 0.1, restart_data=False),
         h.Error(VE, "restart_data", "out"))
    case("adapt --tol 0.1 --out ''", lambda ctx: h.command_line(["adapt", "--tol", "0.1", "--out", ""], ctx),
         h.CliError("out"))
