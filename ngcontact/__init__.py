"""ngcontact: a piezoelectric Kelvin-Voigt body in frictionless unilateral contact with a
conductive foundation, with adhesion (Guettaf & Touzaline), on NGSolve.

The public API is the names below; ``ngcontact.geometries`` (meshes with named
boundaries), ``ngcontact.scenes`` (ready scenes and manufactured solutions) and
``ngcontact.contact_laws`` (the laws p, R_ν, φ_L, ψ), ``ngcontact.parallel`` (runs under
mpiexec on a distributed mesh) and ``ngcontact.checks`` (checks of user input: ranges,
booleans, sizes against the machine's memory), ``ngcontact.petsc_solver`` (MUMPS through
PETSc: ``MumpsFactorization`` of an NGSolve matrix, ``available()``), ``ngcontact.meshes``
(nested meshes: a mesh refined with its coarse mesh kept; a copy refined where marked),
``ngcontact.schemes`` (the time schemes), ``ngcontact.estimators`` (a posteriori error
estimates of a step), ``ngcontact.adapt`` (adaptive meshes) and ``ngcontact.laws``
(nonlinear F and A) are public modules too.
"""
import os as _os
import sys as _sys
import warnings as _warnings

from . import mpi_launch as _mpi_launch

if _mpi_launch.launched():                      # before NGSolve loads, if it has not yet
    if "ngsolve" in _sys.modules and "OMP_NUM_THREADS" not in _os.environ:
        _warnings.warn("ngsolve was imported before ngcontact under mpiexec without OMP_NUM_THREADS: every rank "
                       "may start one OpenMP thread per core, which made the solves 8x slower on 2 cores; "
                       "export OMP_NUM_THREADS=1 (docs/cluster.md)", RuntimeWarning, stacklevel=2)
    _mpi_launch.one_thread_per_rank()
    _mpi_launch.yield_when_oversubscribed()

from . import adapt, checks, contact_laws, estimators, laws, meshes, parallel, petsc_solver, schemes  # noqa: E402
from .admissible import PhysicsWarning
from .body import Body
from .contact import Contact
from .enforcement import METHODS, Nitsche, NodalConstraint, Penalty
from .loads import Loads
from .arguments import MIN_DT
from .materials import EPS0, Material, academic, batio3, pzt5a
from .newton import NewtonError
from .records import ContactRecord, History, StepRecord
from .simulation import Simulation
from .stepping import AccuracyWarning
from .webgui import save_html

__all__ = ["Body", "Contact", "Nitsche", "Penalty", "NodalConstraint", "Loads", "Material", "Simulation", "History", "StepRecord", "ContactRecord",
           "NewtonError", "PhysicsWarning", "AccuracyWarning", "METHODS", "EPS0", "MIN_DT", "academic", "pzt5a", "batio3", "save_html", "contact_laws",
           "parallel", "checks", "meshes", "schemes", "adapt", "estimators", "laws", "petsc_solver"]
