"""The body and its equations in Ω: the layer every other one builds on.

Owns the Body (mesh, spaces, boundary parts), the materials and the laws A and F (2.16)-(2.17),
the loads and supports, the bulk forms a, b, c, e, f of the paper in Voigt notation, the
electric part of the model (which unknowns are solved), the rigid motions, the physical checks
of a state (``admissible``) and the compilation of integrands to machine code.

May import: ``ngcontact.parallel``, ``checks``, ``meshes`` and ``mpi_launch`` (the foundation);
nothing of Γ3, the solvers, time, output or the Simulation.
"""
from ngcontact.moved import submodule as _submodule


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
