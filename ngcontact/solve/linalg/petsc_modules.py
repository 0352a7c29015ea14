"""PETSc's Python modules, imported once and in the order the wheel needs: what the PETSc
solvers (``petsc_solver``, ``petsc_iterative``, ``krylov``) and the reading of PETSc's options
(``petsc_options``) all start from, so that each of them imports this module and none of them
another for it.

Installing PETSc: PyPI has no binary petsc4py; on Python ≥ 3.12 the ``dolfinx-solver-real``
wheel ships PETSc 3.25 with MUMPS and its own petsc4py (``INSTALL``); on a cluster, build
petsc4py against the site's PETSc (docs/cluster.md). Without PETSc, an option that needs it is
an error that says how to install it, before any work (``PetscMissing``).
"""
from ngcontact import mpi_launch

INSTALL = ('on Python >= 3.12: pip install --no-deps dolfinx-solver-real ngsPETSc && pip install packaging '
           '(or petsc4py built against a PETSc with MUMPS, and ngsPETSc; docs/cluster.md)')
"""How to install what ``solver="mumps"`` needs."""

_modules = None


class PetscMissing(ImportError, ValueError):
    """What an option needs of PETSc is not installed: an ImportError (a module is missing) and a
    ValueError (the option's value cannot be used here), so that the command line reports it in
    one line like any other bad value."""


def load(what='solver="mumps"'):
    """(petsc4py.PETSc, ngsPETSc), imported in the order the wheel needs (mpi4py's MPI first,
    so that PETSc finds the MPI library); ImportError naming ``what`` needs them, with
    ``INSTALL``, if missing."""
    global _modules
    if _modules is None:
        # the wheel's MUMPS and BLAS start OpenMP threads on every rank: one each, unless set
        # (mpiexec -n 2, 34 749 DOFs: 18 factorisations 27-47 s, 5.1 s with one thread each)
        mpi_launch.one_thread_per_rank()
        try:
            from mpi4py import MPI  # noqa: F401  (loads libmpi for petsc4py)
            from petsc4py import PETSc
            import ngsPETSc
        except ImportError as err:
            raise PetscMissing(f'{what} needs PETSc (petsc4py with MUMPS) and ngsPETSc, which are not '
                               f'installed ({err}); {INSTALL}') from None
        _modules = PETSc, ngsPETSc
    return _modules


def available():
    """True if ``solver="mumps"`` can run here."""
    try:
        load()
    except ImportError:
        return False
    return True
