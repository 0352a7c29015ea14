"""The linear algebra of a Newton correction: direct and kept factorisations, one GMRES
(``krylov``), the Γ3 – bulk – Γ3 preconditioner (``gamma3_bulk``) over NGSolve's multigrid or
PETSc's GAMG, MUMPS, the scaled residual norm, and the choice among them.

The only layer that imports petsc4py or ngsPETSc. May import: the foundation and
``ngcontact.model``.
"""
from ngcontact.moved import submodule as _submodule


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
