"""Run by tests/test_petsc.py, serially or under mpiexec: a scene over the push-hold-pull
history with ``inverse`` = argv[2] ("default" for None); rank 0 writes per step the contact
force, the charge flux into the foundation and the Newton iterations, and the solver used, as
JSON to argv[3].

argv[1]: "reference" (the 2D reference plate, P2, maxh 10 mm, 20 steps over 0.5 s) or
"block" (the 3D reference block, P1, maxh 20 mm, 10 steps)."""
import json
import sys

from ngcontact import parallel
from ngcontact.scenes import reference

scene, inverse, out = sys.argv[1], None if sys.argv[2] == "default" else sys.argv[2], sys.argv[3]
if scene == "reference":
    sim, steps = reference.simulation(2, 0.01, keep_states=False, inverse=inverse), 20
else:
    sim, steps = reference.simulation(1, 0.02, dim=3, keep_states=False, inverse=inverse), 10
T = reference.LOAD_HISTORY[-1][0]
sim.run(T / steps, T)
h = sim.history
summary = dict(force=h.contact_column("force")[:, -1].tolist(), charge=h.contact_column("charge_flux").tolist(),
               newton=h.newton_iterations.tolist(), solver=repr(sim.newton.solver),
               ranks=parallel.world().size if parallel.world() else 1)
if parallel.rank() == 0:
    with open(out, "w") as f:
        json.dump(summary, f)
