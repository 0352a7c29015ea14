"""The linear algebra of a Newton correction: direct and kept factorisations, one GMRES
(``krylov``), the Γ3 – bulk – Γ3 preconditioner (``gamma3_bulk``) over NGSolve's multigrid or
PETSc's GAMG, MUMPS, the scaled residual norm, and the choice among them.

The only layer that imports petsc4py or ngsPETSc. May import: the foundation and
``ngcontact.model``.
"""
