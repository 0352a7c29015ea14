"""One step's solve: the step system R(x) = 0 and the semismooth Newton method that solves it.

Owns the ``StepSystem`` (bulk and Γ3 forms, condensation, the laws' terms), ``Newton`` with its
stopping test, step-length cut, line search, cycle detection and continuation, Newton's starts
(guesses, nested iteration), and, in ``linalg``, the linear solvers of a correction.

May import: the foundation, ``ngcontact.model`` and ``ngcontact.gamma3``; ``linalg`` only the
foundation and ``model``.
"""
from ngcontact.moved import submodule as _submodule


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
