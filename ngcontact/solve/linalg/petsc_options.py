"""PETSc's options database (``PETSC_OPTIONS``) as ngcontact's PETSc solvers read it
(``petsc_solver``, ``petsc_iterative``): an option PETSc cannot read, or one that would make a
factorisation something else than MUMPS's, is a ValueError naming ``PETSC_OPTIONS`` and the
option, not a PETSc traceback or a Newton iteration that diverges.

The options reach the solvers by prefix: none for ``inverse="mumps"``'s factorisation (e.g.
``-mat_mumps_icntl_4 2``, docs/cluster.md), ``ngcontact_u_``, ``ngcontact_phi_`` and
``ngcontact_gamma3_`` for the parts of ``iterative="gamg"``. Options without a prefix meant for a
user's own PETSc solvers reach the factorisation too: ``-pc_type jacobi`` there would turn it
into a preconditioner taken for a solve, so it is refused (``check_factorisation``).
"""
import os
import re
from contextlib import contextmanager


def _environment():
    return f"PETSC_OPTIONS = {os.environ.get('PETSC_OPTIONS', '')!r}"


def options_error(error, what):
    """A PETSc error raised while PETSc read its options for ``what`` (its stack passes through
    PetscOptions*) as a ValueError naming ``PETSC_OPTIONS`` and PETSc's reason; None for any other
    error."""
    text = str(error)
    if "PetscOptions" not in text:
        return None
    said = "; ".join(re.sub(r"^\[\d+\]\s*", "", line).strip() for line in text.splitlines()[1:]
                     if "() at " not in line and line.strip())
    return ValueError(f"PETSc cannot read its options for {what} ({said or text.splitlines()[0]}); {_environment()}")


@contextmanager
def reading_options(what):
    """Turn a PETSc error raised while reading PETSc's options (``setFromOptions``, and MUMPS's
    ``-mat_mumps_*`` at the first factorisation) into ``options_error``'s ValueError."""
    from ngcontact.solve.linalg.petsc_solver import load
    PETSc, _ = load()
    try:
        yield
    except PETSc.Error as error:
        named = options_error(error, what)
        if named is None:
            raise
        raise named from None


def check_factorisation(pc, symmetric, what):
    """Refuse (a ValueError) PETSc options that made the PC ``pc`` of the factorisation ``what``
    something else than MUMPS's LU (or LDLᵀ of a ``symmetric`` matrix): ``-pc_type`` or
    ``-pc_factor_mat_solver_type``; Newton would diverge on a preconditioner taken for a solve."""
    allowed = ("lu", "cholesky") if symmetric else ("lu",)
    kind = pc.getType()
    package = pc.getFactorSolverType() if kind in allowed else None
    if kind not in allowed or package != "mumps":
        made = f"pc_type {kind!r}" if kind not in allowed else f"pc_factor_mat_solver_type {package!r}"
        raise ValueError(f"PETSc's options make the factorisation of {what} {made}: it must stay MUMPS's "
                         f"{' or '.join(allowed)} ({_environment()}; options without a prefix reach it: give your "
                         "own solvers' options a prefix)")
