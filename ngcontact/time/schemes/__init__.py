"""Time schemes: each poses its step through ``StepCoefficients`` (t_n, c, û) and owns what
changes from step to step (the state, β, the memory it needs), saving and restoring it bitwise.

A scheme is a class that follows ``TimeScheme`` (``protocol``: every member the package uses,
the constructor's arguments, what each method is called with and returns).
``Simulation(scheme=...)`` takes a name of ``SCHEMES`` or such a class of the user's, checked
before any work (a TypeError naming ``scheme`` and what the class lacks). A new built-in scheme
is one new module here and one entry in ``SCHEMES``; a scheme of the user's needs neither.
"""
from .backward_euler import BackwardEuler
from .bdf2 import BDF2
from .coefficients import StepCoefficients
from .protocol import TimeScheme, check

SCHEMES = {BackwardEuler.name: BackwardEuler, BDF2.name: BDF2}
"""The time schemes by name: "backward_euler" (the default, the paper's scheme (4.3)–(4.5)) and
"bdf2" (variable-step BDF2, second order: ``bdf2``)."""

DEFAULT = BackwardEuler.name


def scheme_class(scheme):
    """The class of ``scheme``: the scheme of ``SCHEMES`` called so (a ValueError naming
    ``scheme``, the value and the choices otherwise), or a class that follows ``TimeScheme``
    (checked: ``protocol.check``); a TypeError naming ``scheme`` for any other value."""
    if isinstance(scheme, str):
        if scheme not in SCHEMES:
            raise ValueError(f"scheme must be one of {', '.join(repr(s) for s in SCHEMES)}, got {scheme!r} (or a "
                             "time scheme class: ngcontact.schemes.TimeScheme)")
        return SCHEMES[scheme]
    if isinstance(scheme, type):
        check(scheme, SCHEMES)
        return scheme
    raise TypeError(f"scheme must be one of {', '.join(repr(s) for s in SCHEMES)} or a time scheme class "
                    f"(ngcontact.schemes.TimeScheme: the class, not an instance, which the simulation builds with "
                    f"its step system), got {scheme!r:.80} ({type(scheme).__name__})")


__all__ = ["SCHEMES", "DEFAULT", "BackwardEuler", "BDF2", "StepCoefficients", "TimeScheme", "check", "scheme_class"]
