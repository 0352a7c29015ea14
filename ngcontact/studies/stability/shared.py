"""What the stability studies share: the pressed reference plate, its reference force, and
the measures of a converged run (condition number, pressure oscillation)."""
import numpy as np

from ngcontact.scenes import reference

from ngcontact.studies.common import QUICK, run

APPLIED = reference.PRESSURE * reference.L1
"""The reference scene's peak load on top, N/m."""
STATUS_COLOURS = {"ok": "#4daf4a", "wrong": "#ff7f00", "failed": "#e41a1c"}
"""Chart colours of a run's status: converged with the right force, converged with a wrong
one, Newton failed."""


def press(contact, *, maxh, order, steps, material=None, max_cutbacks=0):
    """The reference plate pushed onto the foundation over the scene's push ramp (0 to
    PUSH_END, full pressure at the end) in ``steps`` time steps, without cut-backs by
    default. Returns (sim, failure), failure as in ``common.run``; ``material`` replaces
    PZT-5A."""
    sim = reference.simulation(order, maxh, material=material, contact=contact, keep_states=False)
    return sim, run(sim, reference.PUSH_END / steps, reference.PUSH_END, max_cutbacks)


def reference_force(maxh, order, steps, gamma0=1000.0):
    """Contact force (N/m) of the pushed plate with θ = −1 and a large γ0 (the reference)."""
    sim, failure = press(reference.contact(-1, gamma0), maxh=maxh, order=order, steps=steps)
    if failure:
        raise RuntimeError(f"the reference solve (θ = -1, γ0 = {gamma0}) failed: {failure}")
    return float(sim.history[-1].contact.force[1])


def scaled_condition_number(sim, max_dofs=4000):
    """The 2-norm condition number of the scaled Newton Jacobian at the current state
    (``Simulation.jacobian``). Dense: small problems only (at most ``max_dofs`` free DOFs)."""
    J = sim.jacobian(scaled=True)
    if J.shape[0] > max_dofs:
        raise ValueError(f"scaled_condition_number is dense: {J.shape[0]} free DOFs > max_dofs = {max_dofs}")
    return float(np.linalg.cond(J.toarray()))


def pressure_oscillation(side, pressure):
    """Oscillation of the facet pressure along Γ3, relative to its maximum.

    (TV(p) − (2 max p − p_first − p_last)) / max p: the total variation beyond that of a
    profile that only rises and then falls; 0 for such a profile, > 0 for a zig-zag or
    for separate contact zones. nan without pressure.
    """
    axis = int(np.ptp(side.midpoints, axis=0).argmax())
    p = np.asarray(pressure)[np.argsort(side.midpoints[:, axis])]
    top = p.max()
    if not top > 0:
        return float("nan")
    return float((np.abs(np.diff(p)).sum() - (2 * top - p[0] - p[-1])) / top)


def short(failure):
    """A short label of a ``failure_kind`` for charts: c2 (cycle 2), stag, nc, div."""
    return {"stagnation": "stag", "no convergence": "nc", "diverged": "div"}.get(
        failure, failure.replace("cycle ", "c"))



def save(fig, path, quick=False):
    """Write the chart ``fig`` to ``path``; a ``quick`` run's chart marked as such in its corner
    (``common.QUICK``: fewer runs, the maps coarser)."""
    if quick:
        fig.text(0.995, 0.005, f"({QUICK})", ha="right", va="bottom", fontsize=8, color="firebrick")
    fig.savefig(path, dpi=100)
