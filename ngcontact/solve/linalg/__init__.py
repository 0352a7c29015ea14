"""The linear algebra of a Newton correction: direct and kept factorisations, GMRES, NGSolve's
multigrid and PETSc (MUMPS, GAMG), the scaled residual norm, and the choice among them.

The only layer that imports petsc4py or ngsPETSc. May import: the foundation and
``ngcontact.model``.
"""
