"""The reference scene: a PZT-5A plate pressed onto a glued, conductive rigid foundation,
then pulled off (the demo, the bench, the reference convergence study and most stability
studies run it).

The plate 0 ≤ x ≤ L1, 0 ≤ y ≤ L2 (plane strain, poled along y, Kelvin-Voigt viscosity) is
clamped on the left (Γ1), has its grounded electrode on top (Γa) and the contact side Γ3 at
the bottom, a gap g above the foundation held at φ_Γ, glued (β0 = 1). A pressure on top
bends it onto the foundation: the contact zone grows from the free end. The pressure is then
reversed into a moderate pull: the contact opens, the glue holds the plate while β decays
from the free end, and the plate lifts off. Units: SI, per metre of depth. ``dim=3`` gives
the block L1 × WIDTH × L2 with the same boundary names and data.

``simulation(...)`` builds the whole scene; the material, the load history and the contact
data are parameters.
"""
import ngsolve as ngs

import ngcontact as ngc
from ngcontact.geometries import block, plate

L1, L2 = 0.1, 0.02
"""Plate length and thickness, m."""
WIDTH = 0.04
"""Width of the 3D block variant (y), m; its thickness L2 is along z."""
PRESSURE = 2e6
"""Peak pressure on top, Pa."""
RELAXATION_TIME = 2e-3
"""Kelvin-Voigt relaxation time τ of A = τ F, s."""
LOAD_HISTORY = ((0.0, 0.0), (0.1, 1.0), (0.15, 1.0), (0.2, -0.2), (0.5, -0.2))
"""(time in s, fraction of PRESSURE): push, hold, reverse into a pull, hold the pull."""
PUSH_END = LOAD_HISTORY[1][0]
"""End of the push ramp, s: the full pressure is reached."""
CONTACT = dict(gap=2e-5, adhesion=1e11, eps_a=0.0, bond_length=5e-5, conductance=1e-4,
               ramp_width=1e-6, potential_truncation=1e3, foundation_potential=10.0)
"""Γ3 data: g (m), γ_ν (Pa/m), ε_a, L (m), k_e (F/m²), δ (m), L_φ (V), φ_Γ (V)."""


def load_factor(t, history=LOAD_HISTORY):
    """The piecewise linear ``history`` ((time s, factor), ...) as a CoefficientFunction of
    the Parameter ``t``; constant after its last time."""
    factor = ngs.CF(history[0][1])
    for (a, fa), (b, fb) in zip(history[:-1], history[1:]):
        if fb != fa:
            ramp = ngs.IfPos(t - b, 1, ngs.IfPos(t - a, (t - a) / (b - a), 0))
            factor = factor + (fb - fa) * ramp
    return factor


def pressure(t, history=LOAD_HISTORY):
    """The pressure on top (Pa) as a CoefficientFunction of the time Parameter."""
    return PRESSURE * load_factor(t, history)


def body(order=1, maxh=0.005, refine=0, dim=2, material=None):
    """The plate with its boundary parts; the mesh is halved along Γ3 and refined ``refine``
    times by ``mesh.Refine()``. ``dim=3``: the block L1 × WIDTH × L2 (mesh size ``maxh``,
    poled along z). ``material`` replaces PZT-5A with the relaxation time RELAXATION_TIME."""
    dim = ngc.checks.choice("dim", dim, (2, 3))
    maxh = ngc.checks.number("maxh", maxh, 0, low_open=True, unit="m")
    if dim == 3:
        mesh = block(L1, WIDTH, L2, maxh=maxh, refine=refine)
    else:
        mesh = plate(L1, L2, maxh=maxh, maxh_contact=maxh / 2, refine=refine)
    return ngc.Body(mesh, material or ngc.pzt5a(relaxation_time=RELAXATION_TIME), clamped="left",
                    grounded="top", contact_side="bottom", order=order)


def loads(t, dim=2, history=LOAD_HISTORY):
    """The pressure on top (2D: N/m² per metre of depth; 3D: N/m²)."""
    return ngc.Loads(f2={"top": (0,) * (dim - 1) + (-pressure(t, history),)})


def contact(theta=None, gamma0=None, bare=False, **changes):
    """The Γ3 data ``CONTACT`` with Nitsche's θ and γ0 (None: not given, Contact's 1 and 10);
    ``bare=True``: no glue and an insulating foundation (γ_ν = k_e = 0, Signorini contact
    across the gap), so that with θ = 1 the step Jacobian is symmetric; ``changes`` replace
    any Contact field (another method: θ and γ0 left out)."""
    data = dict(CONTACT, adhesion=0.0, conductance=0.0) if bare else dict(CONTACT)
    nitsche = {k: v for k, v in (("theta", theta), ("gamma0", gamma0)) if v is not None}
    return ngc.Contact(**{**data, **nitsche, **changes})


_contact = contact          # for simulation(), whose parameter ``contact`` hides the function


def simulation(order=1, maxh=0.005, refine=0, dim=2, *, material=None, load_history=LOAD_HISTORY,
               contact=None, **options):
    """The reference scene as a Simulation: ``body(order, maxh, refine, dim, material)``
    under the pressure of ``load_history`` with the Contact ``contact`` (default
    ``contact()``); ``options`` go to Simulation (keep_states, inverse, ...). Its time
    Parameter is ``simulation.time``."""
    t = ngs.Parameter(0.0)
    return ngc.Simulation(body(order, maxh, refine, dim, material), loads(t, dim, load_history),
                          contact=contact if contact is not None else _contact(), time=t, **options)
