"""What a time scheme hands the step: the time t_n, the rate coefficient c and the anchor û.

A scheme for the Kelvin–Voigt system approximates the rate of the displacement at t_n by

  δu_n ≈ c (u_n − û)      (c in 1/s, û in m, both fixed within the step),

so that every scheme poses its step as the same nonlinear system (``system.StepSystem``)

  R(x) = K_el x + c K_A (x − x̂) − f(t_n) + R_Γ3(x),   x̂ = (û, ·),

with the viscous stress A ε(δu_n) = c A ε(u − û) in the bulk, in Nitsche's σ_ν on Γ3
(``forms.step_normal_stress``) and in the weak supports. Backward Euler (the paper's (4.3)):
c = 1/k_n, û = u_{n−1}. BDF2 with variable steps, ω = k_n/k_{n−1}: c = (1 + 2ω)/((1 + ω) k_n),
û = ((1 + ω)² u_{n−1} − ω² u_{n−2})/(1 + 2ω).

The scheme is the only writer of t_n, c and û (``set``); forms, enforcement, the recorder
and the multigrid preconditioner read them. Code that evaluates time-dependent data at
another time (checks of the data, fingerprints) does so inside ``at(t)``, which puts t_n back.
"""
from contextlib import contextmanager

import ngsolve as ngs


class StepCoefficients:
    """t_n, c and û of the current step (module docstring).

    Parameters
    ----------
    time : the ngsolve.Parameter the loads and the contact data depend on (s); it holds t_n,
        set here to t_0 = 0.
    V : the displacement space; ``anchor`` is a GridFunction on it.

    Attributes: ``time`` (Parameter, s), ``rate`` (Parameter c, 1/s), ``anchor``
    (GridFunction û, m).
    """

    def __init__(self, time, V):
        self.time = time
        self.time.Set(0.0)
        self.rate = ngs.Parameter(1.0)
        self.anchor = ngs.GridFunction(V, name="anchor")

    @property
    def t(self):
        """t_n, s."""
        return self.time.Get()

    def set(self, t, rate=None, anchor=None):
        """The scheme's: t_n = ``t`` (s), c = ``rate`` (1/s) and û = ``anchor`` (a vector of V)
        where given. c comes from the step's nominal length (``Simulation.run`` steps to n·dt
        with k = dt, not t_n − t_{n−1}, whose round-off would make equal steps differ in the
        last bits of c: a new step size each, a new factorisation)."""
        self.time.Set(t)
        if rate is not None:
            self.rate.Set(float(rate))
        if anchor is not None:
            self.anchor.vec.data = anchor

    @contextmanager
    def at(self, t):
        """Evaluate time-dependent data at ``t`` (s) inside the block; t_n is put back after."""
        now = self.time.Get()
        self.time.Set(t)
        try:
            yield
        finally:
            self.time.Set(now)
