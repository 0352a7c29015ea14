"""Time: the time schemes (``schemes``: backward Euler, BDF2), the transactional step and the
parts that make it (``step.Step``, what ``Simulation`` hands down), and the stepping of a run
(nominal steps with cut-backs, or steps chosen by the error estimate).

May import: the foundation, ``ngcontact.model``, ``ngcontact.gamma3`` and ``ngcontact.solve``.
"""
from ngcontact.moved import submodule as _submodule


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
