"""Run by tests/test_petsc.py, tests/test_petsc_options.py and tests/test_parallel.py, serially
or under mpiexec: a scene over a load history with ``solver`` = argv[2] ("default" for None,
a solver's name such as "mumps" or "gamg", "petsc-gamg" or "petsc-lu" for ``solver=`` a dict of
PETSc options, ``PETSC_OPTIONS``); rank 0 writes per step the contact force, the charge flux into the
foundation, the reactions of the supports, u and φ at a probe point (where the scene has one)
and the Newton iterations, and the solver used, as JSON to argv[3].

argv[1]:

* "reference": the 2D reference plate, P2, maxh 10 mm, 20 steps over the push-hold-pull history;
* "block": the 3D reference block, P1, maxh 20 mm, 10 steps;
* "reference-p3": the 2D reference plate, P3 with static condensation, maxh 10 mm, 20 steps;
* "reference-p1start": the 2D reference plate, P2, maxh 10 mm, 8 steps of 25 ms, each started
  from P1 on the same mesh (``guess="p1"``);
* "hertz-force": the 2D Hertz half-disk (P1) under force control, one step: held only tangentially
  on its top, its vertical motion held by the contact alone (``starts``' "touch" start);
* "reference-law": the 2D reference plate, P1, maxh 5 mm, with the projection law
  F(ε) = ℰε + ζ(ε − P_K ε) (ζ = 5e10 Pa, K the von Mises ball of radius 1e-5), 10 steps of the push;
* "indenter3d": a PZT-5A block 10 × 10 × 4 mm (maxh 0.7 mm, P1) on rollers (its "bottom" held
  in z) with two symmetry planes ("left", "front": u·ν = 0), indented on its "top" by a rigid
  sphere of radius 10 mm driven 0.1 mm down over 4 steps (``obstacles.Sphere``), bottom grounded;
* "axisymmetric": the half-ball of PZT-5A (poled along its axis) on its meridian section
  (``Body(axisymmetric=True)``, P2), its top grounded and moved down 0.01 R over 3 steps onto a
  conducting plane.
"""
import json
import sys

import ngsolve as ngs

import ngcontact as ngc
from ngcontact import laws, parallel
from ngcontact.geometries import block
from ngcontact.obstacles import Sphere
from ngcontact.scenes import reference


def indenter3d(options):
    L, H, R, depth = 0.01, 0.004, 0.01, 1e-4
    body = ngc.Body(block(L, L, H, maxh=0.0007), ngc.pzt5a(), grounded="bottom", contact_side="top",
                    supports={"bottom": "z", "left": "normal", "front": "normal"})
    t = ngs.Parameter(0.0)
    sphere = Sphere(center=(0.0, 0.0, H + R - depth * t), radius=R)
    return ngc.Simulation(body, ngc.Loads(), contact=ngc.Contact(obstacle=sphere, gamma0=10.0), time=t,
                          keep_states=False, **options), 1.0, 4, (0.0, 0.0, H / 2)


PETSC_OPTIONS = {"petsc-gamg": {"pc_type": "gamg", "pc_gamg_threshold": 0.02, "ksp_rtol": 1e-6},
                 "petsc-lu": {"pc_type": "lu", "ksp_type": "preonly", "mat_mumps_icntl_7": 2}}
"""argv[2] naming ``Simulation(solver={...})``."""
scene, solver, out = sys.argv[1], None if sys.argv[2] == "default" else sys.argv[2], sys.argv[3]
options = dict(solver=PETSC_OPTIONS.get(solver, solver),    # a name, or the solver as a dict of PETSc options
               switch_loop=False)      # (a distributed run has plain corrections: the serial one alike)
T, probe = reference.LOAD_HISTORY[-1][0], None
if scene == "reference":
    sim, steps = reference.simulation(2, 0.01, keep_states=False, **options), 20
elif scene == "block":
    sim, steps = reference.simulation(1, 0.02, dim=3, keep_states=False, **options), 10
elif scene == "reference-p3":                 # static condensation (the default at P3 in 2D)
    sim, steps = reference.simulation(3, 0.01, keep_states=False, **options), 20
    assert sim.condense
elif scene == "reference-p1start":            # P2, each step's Newton started from P1 on the same mesh
    sim, steps, T = reference.simulation(2, 0.01, keep_states=False, **options), 8, 0.2
elif scene == "hertz-force":                  # held only in part by its supports: the "touch" start
    from ngcontact.scenes import hertz
    comm = parallel.world()
    mesh = parallel.distributed_mesh(lambda: hertz.mesh(2).ngmesh, 0, comm) if comm else hertz.mesh(2)
    sim, steps, T, probe = hertz.simulation(1, control="force", mesh=mesh, keep_states=False, **options), 1, 1.0, \
        (0.0, 0.5)
elif scene == "reference-law":
    material = ngc.pzt5a(relaxation_time=reference.RELAXATION_TIME).with_elasticity(
        laws.ProjectionLaw(5e10, laws.VonMisesBall(1e-5)))
    sim, steps, T = reference.simulation(1, 0.005, material=material, keep_states=False, **options), 10, 0.1
elif scene == "indenter3d":
    sim, T, steps, probe = indenter3d(options)
elif scene == "axisymmetric":                 # a body of revolution: 2π r in every integral
    from ngcontact.obstacles import Plane
    from ngcontact.scenes import hertz
    comm = parallel.world()
    section = lambda: hertz.mesh(2, h_contact=0.01, axisymmetric=True)      # noqa: E731
    mesh = parallel.distributed_mesh(lambda: section().ngmesh, 0, comm) if comm else section()
    t = ngs.Parameter(0.0)
    body = ngc.Body(mesh, ngc.pzt5a(), supports={"top": "all"}, grounded="top", contact_side="contact", order=2,
                    axisymmetric=True)
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": (0, -0.01 * t)}), time=t, keep_states=False,
                         contact=ngc.Contact(obstacle=Plane((0, 0), (0, 1)), conductance=1e-5), **options)
    steps, T, probe = 3, 1.0, (0.0, 0.5)
else:
    raise SystemExit(f"unknown scene {scene!r}")
probes = []                               # (u, φ) at the probe point after each step
sim.run(T / steps, T, guess="p1" if scene == "reference-p1start" else None, on_step=lambda record: probes.append(
    [parallel.point_values(sim.body.mesh, field, [probe]).ravel().tolist() for field in (sim.u, sim.phi)])
    if probe else None)
h = sim.history
summary = dict(force=h.contact_column("force").tolist(), charge=h.contact_column("charge_flux").tolist(),
               reactions={name: [r.boundary_reaction[name].tolist() for r in h[1:]]
                          for name in h[-1].boundary_reaction},
               probe_u=[u for u, _ in probes], probe_phi=[phi for _, phi in probes],
               newton=h.newton_iterations.tolist(), krylov_failures=sum(r.krylov_failures for r in h),
               solver=sim.solver_detail,
               ranks=parallel.world().size if parallel.world() else 1,
               u_block_size=parallel.every(sim.body.mesh, sim.newton.solver.fields[0].getBlockSize())
               if solver == "gamg" else None)
if parallel.rank() == 0:
    with open(out, "w") as f:
        json.dump(summary, f)
