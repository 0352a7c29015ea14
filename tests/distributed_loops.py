"""Run by tests/test_parallel.py, serially or under mpiexec: small scenes whose loops stop on
data (BDF2's passes of β consistent with u_n, Newton's stopping test and step length, the
cut-backs, the error-controlled steps), to the end on every rank; rank 0 writes per case the
contact force, the charge flux, β on Γ3 (gathered), the times and Newton iterations of every
step, and every rank's word that it finished, as JSON to argv[2].

argv[1] is a comma-separated list of cases:

* "bdf2": the 2D reference plate, P1, maxh 20 mm, BDF2 with 4 nominal steps over the push, hold
  and pull (cut-backs included, β debonds: several passes of β from u_n per step);
* "bdf2-rtol": the same plate, BDF2 with 3 fixed steps to the end of the hold (0.15 s), then
  error-controlled steps (``run(rtol=1e-2)``) to 0.25 s, across the lift-off (rejected tries,
  the event located, β decaying);
* "penalty": the plate with ``Contact(method="penalty")``, backward Euler, 5 steps of the push;
* "law": the plate with the projection law of elasticity (ζ = 5e10 Pa, the von Mises ball of
  radius 1e-5) and BDF2, 4 steps of the push and hold;
* "active_set": the nodal constraint, which runs serially only: every rank's error message
  (or "no error" serially after 2 steps).
"""
import json
import sys

import numpy as np

import ngcontact as ngc
from ngcontact import laws, parallel
from ngcontact.scenes import reference

MAXH = 0.02
PLAIN = dict(switch_loop=False)
"""A distributed run has plain Newton corrections (the switch loop is serial only): so do the serial
runs it is compared with."""


def summary(sim):
    h, mesh = sim.history, sim.body.mesh
    midpoints = parallel.gather(mesh, sim.side.midpoints)         # the records' facets, gathered in rank order
    order = np.lexsort(midpoints.T[::-1])                         # by position: the same order on any ranks
    return dict(times=[r.time for r in h], force=h.contact_column("force").tolist(),
                charge=h.contact_column("charge_flux").tolist(), beta=[r.contact.beta[order].tolist() for r in h],
                newton=h.newton_iterations.tolist(), rejections=len(sim.rejections),
                events=[r.event for r in h[1:]] if hasattr(h[-1], "event") else None,
                finished=parallel.every(mesh, True))


def bdf2():
    sim = reference.simulation(1, MAXH, scheme="bdf2", keep_states=False, **PLAIN)
    T = reference.LOAD_HISTORY[-1][0]
    sim.run(T / 4, T)
    return summary(sim)


def bdf2_rtol():
    sim = reference.simulation(1, MAXH, scheme="bdf2", keep_states=False, **PLAIN)
    sim.run(0.05, 0.15)                                      # push and hold: fixed steps
    sim.run(0.01, 0.25, rtol=1e-2)                           # the pull: lift-off, β decays
    return summary(sim)


def penalty():
    sim = reference.simulation(1, MAXH, contact=reference.contact(method="penalty"), keep_states=False)
    sim.run(0.02, 0.1)
    return summary(sim)


def law():
    material = ngc.pzt5a(relaxation_time=reference.RELAXATION_TIME).with_elasticity(
        laws.ProjectionLaw(5e10, laws.VonMisesBall(1e-5)))
    sim = reference.simulation(1, MAXH, material=material, scheme="bdf2", keep_states=False)
    sim.run(0.15 / 4, 0.15)
    return summary(sim)


def active_set():
    comm = parallel.world()
    try:
        sim = reference.simulation(1, MAXH, contact=reference.contact(method="active_set"), keep_states=False)
        sim.run(0.05, 0.1)
        message = "no error"
    except ValueError as err:
        message = str(err)
    return dict(messages=comm.allgather(message) if comm is not None else [message])


CASES = {"bdf2": bdf2, "bdf2-rtol": bdf2_rtol, "penalty": penalty, "law": law, "active_set": active_set}

if __name__ == "__main__":
    found = {name: CASES[name]() for name in sys.argv[1].split(",")}
    found["ranks"] = parallel.size()
    if parallel.rank() == 0:
        with open(sys.argv[2], "w") as f:
            json.dump(found, f)
