"""Whether a scene has an electric part, so that its simulation solves for φ as well as u.

A scene without piezoelectric coupling, conduction on Γ3 and electric loads (charges,
nonzero electrode potentials) has φ = 0: ``Simulation`` then leaves φ's DOFs out of every
solve (``Simulation.model`` says which unknowns it solves).
"""
import ngsolve as ngs
import numpy as np


def electric_parts(body, loads, contact):
    """The electric parts of a scene, as phrases (empty: u alone)."""
    parts = []
    if body.coupled:
        parts.append("piezoelectric coupling")
    if contact is not None and contact.conducts:
        parts.append("conduction on Γ3")
    potentials = [v for v in loads.potential.values() if isinstance(v, ngs.CoefficientFunction) or
                  np.any(np.asarray(v, dtype=float) != 0)]
    if loads.q0 is not None or loads.qb or potentials:
        parts.append("charges or electrode potentials")
    return parts


def solves_potential(electric, parts, body):
    """Whether φ is solved for: ``electric`` None (when the scene has an electric part), True
    or False (checked against the parts and the electrodes of the body)."""
    if electric not in (None, True, False):
        raise ValueError(f"electric must be None, True or False, got {electric!r}")
    if electric is False and parts:
        raise ValueError(f"electric=False, but the scene has {', '.join(parts)}: φ must be solved for")
    solve = bool(parts) if electric is None else electric
    if solve and not body.boundaries["grounded"]:
        raise ValueError("Body.grounded must name at least one boundary: the scene solves for φ "
                         f"({', '.join(parts) or 'electric=True'})")
    return solve
