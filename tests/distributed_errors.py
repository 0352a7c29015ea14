"""Run under mpiexec by tests/test_parallel.py: what does not run distributed raises a
ValueError naming it (a serial mesh given to Body, the Jacobian as a scipy matrix and the guesses of ``starts``
included); prints one line per case on rank 0. Then two steps with
``run(vtk=<argv[1]>/fields)`` (the ParaView series, one file per computing rank and step)."""
import pathlib
import sys

import ngsolve as ngs

import ngcontact as ngc
from ngcontact import parallel
from ngcontact.geometries import plate
from ngcontact.scenes import reference
from ngcontact.solve.starts import Approach

cases = {"active_set": dict(contact=reference.contact(method="active_set")), "multigrid": dict(solver="multigrid"),
         "umfpack": dict(solver="umfpack")}
try:                                     # a script's own serial mesh: every rank would solve it whole
    ngc.Body(plate(maxh=0.02, comm=False), ngc.pzt5a(), clamped="left", grounded="top")
    message = "no error"
except ValueError as err:
    message = str(err)
if parallel.rank() == 0:
    print(f"serial mesh: {message}", flush=True)
for name, options in cases.items():
    try:
        reference.simulation(1, 0.02, dim=3, **options)
        message = "no error"
    except ValueError as err:
        message = str(err)
    if parallel.rank() == 0:
        print(f"{name}: {message}", flush=True)
sim = reference.simulation(1, 0.02, dim=3)
try:
    sim.jacobian()
    message = "no error"
except ValueError as err:
    message = str(err)
if parallel.rank() == 0:
    print(f"jacobian: {message}", flush=True)
for name, guess in [("nested", "nested"), ("approach", Approach(1e-6))]:
    try:
        sim.step(2.5e-3, guess=guess)
        message = "no error"
    except ValueError as err:
        message = str(err)
    if parallel.rank() == 0:
        print(f"{name}: {message}", flush=True)
refused = {"estimator": lambda: __import__("ngcontact.estimators", fromlist=["x"]).EquilibratedEstimator(sim),
           "adapt": lambda: __import__("ngcontact.adapt", fromlist=["x"]).step(lambda mesh: sim, sim.body.mesh, 2.5e-3),
           "refined": lambda: __import__("ngcontact.meshes", fromlist=["x"]).refined(
               sim.body.mesh, __import__("numpy").zeros(sim.body.mesh.ne, dtype=bool))}
for name, call in refused.items():
    try:
        call()
        message = "no error"
    except ValueError as err:
        message = str(err)
    if parallel.rank() == 0:
        print(f"{name}: {message}", flush=True)
try:                                     # fewer elements than computing ranks
    from netgen.occ import OCCGeometry, WorkPlane
    triangle = WorkPlane()
    triangle.LineTo(1, 0)
    triangle.LineTo(0, 1)
    triangle.Close()
    parallel.distributed_mesh(lambda: OCCGeometry(triangle.Face(), dim=2).GenerateMesh(maxh=10), 0, parallel.world())
    message = "no error"
except ValueError as err:
    message = str(err)
if parallel.rank() == 0:
    print(f"ranks: {message}", flush=True)
sim.run(2.5e-3, 5e-3, vtk=pathlib.Path(sys.argv[1]) / "fields")
if parallel.rank() == 0:
    print(f"vtk: {len(sim.history) - 1} steps", flush=True)
ngs.Parameter(0.0)
