"""The preconditioner of the iterative solvers, written once: a multiplicative Schwarz method of
two parts, Γ3 – bulk – Γ3,

  y = S r;  y += B (r − J y);  y += S (r − J y),

with S an exact solve of the step Jacobian J on the free DOFs of the Γ3 facets (a surface
problem, ~n^(2/3) DOFs; it carries the Γ3 terms, whose Nitsche stiffness γ ~ 10 p² E/h dwarfs
the bulk's and changes at every Newton iteration) and B a block-diagonal preconditioner of the
bulk, diag(B_u, −B_φ), of the SPD forms of ``forms.preconditioner_forms``. Its back-ends give
the parts (``Parts``): NGSolve's (``multigrid.Preconditioner``: UMFPACK on Γ3, NGSolve's
multigrid or BDDC in the bulk, on NGSolve vectors) and PETSc's (``petsc_iterative``: MUMPS on
Γ3, GAMG in the bulk, on PETSc vectors, the products with J taken by its strips J[:, Γ3] and
J[Γ3, :]). Without DOFs on Γ3, M = B.
"""
from typing import Protocol


class Parts(Protocol):
    """The parts of M on one back-end's vectors."""

    surface: bool
    """Whether there are free DOFs on Γ3 (else M = B)."""

    def clear(self, y) -> None:
        """y = 0."""

    def surface_solve(self, r, y) -> None:
        """y = S r (zero off Γ3)."""

    def defect(self, r, y):
        """r − J y for y = S r, as the bulk reads it (a vector of the back-end)."""

    def add_bulk(self, d, y) -> None:
        """y += B d."""

    def surface_defect(self, r, y):
        """Γ3's rows of r − J y, as S reads them."""

    def add_surface(self, s, y) -> None:
        """y += S s."""


def apply(parts, r, y):
    """y = M r (module docstring) with the back-end's ``parts``."""
    if not parts.surface:
        parts.clear(y)
        parts.add_bulk(r, y)
        return
    parts.surface_solve(r, y)
    parts.add_bulk(parts.defect(r, y), y)
    parts.add_surface(parts.surface_defect(r, y), y)
