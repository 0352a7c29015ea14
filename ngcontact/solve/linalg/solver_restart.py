"""Newton's restart state: what its next solve decides by besides the state (the norm's scales,
a kept factorisation and the rate c it was made at), saved with a step's restart state and put
back at a resume, so that a resumed run repeats the uninterrupted one bitwise (``results``)."""
import numpy as np

FACTORIZATION = ("kept_baseline", "kept_values", "kept_positions")
"""The arrays of a kept factorisation in a restart state (``KeptFactorization.save``): the bulk
of a step archive (the values factorised, many times the state: docs/measurements.md, section
ngcontact/solve/linalg/solver_restart.py)."""


def without_factorization(arrays):
    """``arrays`` (a restart state) without the kept factorisation's (``FACTORIZATION``): a run
    resumed from them factorises anew at its first solve, from the state (``load_restart_state``
    finds no factorisation to put back), and continues the run to Newton's tolerance rather
    than bitwise."""
    return {k: v for k, v in arrays.items() if k not in FACTORIZATION}


def restart_state(newton):
    """What ``newton``'s next solve decides by besides the state, as named arrays for a time
    scheme's restart state (``linear_solver``'s docstring): ``solver_scales`` (the norm's scales, once set),
    and with a kept factorisation that the next solve may keep (``KeptFactorization.save``) its
    arrays and ``solver_rate``, the rate c its StepSystem was last assembled at (the next step
    keeps the factorisation if its c is the same)."""
    system, arrays = newton.system, {}
    if newton.norm.scales is not None:
        arrays["solver_scales"] = np.asarray(newton.norm.scales, dtype=float)
    save = getattr(newton.solver, "save", None)
    rate = getattr(getattr(system, "coefficients", None), "rate", None)
    if save is not None and rate is not None and hasattr(system, "begin_step"):
        kept = save(getattr(system, "generation", None), whole=getattr(system, "laws", None) is not None)
        if kept:
            arrays.update(kept, solver_rate=np.asarray(rate.Get()))
    if getattr(system, "laws", None) is not None:         # the laws' stiffness scales (``law_terms``)
        arrays.update(system.laws.save())
    return arrays


def load_restart_state(newton, arrays):
    """Put back the arrays of ``restart_state`` (after the scheme's state, t_n and β, and the step
    system assembled at the saved rate c by the scheme, the only writer of c): the norm's scales
    and the kept factorisation, made again at the first solve in that generation. Arrays saved
    before these were stored are absent: nothing is put back."""
    system = newton.system
    if "solver_scales" in arrays:
        newton.norm.restore_scales([float(s) for s in np.atleast_1d(arrays["solver_scales"])],
                                   len(newton.gfu.vec.FV().NumPy()))
    load = getattr(newton.solver, "load", None)
    if load is not None:
        load(arrays, getattr(system, "generation", None))
    if getattr(system, "laws", None) is not None:
        system.laws.load(arrays)
